"""The command law: how a target becomes one step's commanded displacement ``dw`` (eq. 2).

One law serves every path: :func:`simulate`, the compiled
:class:`~lpik.control.controller.Lp2Controller` (whose kernel compiles
:func:`clamp_command` itself), the command line and the benchmarks. Toward a
target, the step's displacement is ``dw = difference(pose(q), target)``,
scaled down (as a whole, so that its direction is kept) until its linear part
is at most ``v_max dt`` [m] and its angular part at most ``w_max dt`` [rad].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from lpik.robots.base import TaskModel
from lpik.robots.rotations import check_rotation
from lpik.types import FloatArray

#: Default largest commanded linear speed of the task point [m/s].
DEFAULT_V_MAX = 0.5
#: Default largest commanded angular speed of the task frame [rad/s].
DEFAULT_W_MAX = 1.0
#: The rows a task may keep, in order; rows 0-2 are linear [m], 3-5 angular [rad].
TASK_ROWS = ("x", "y", "z", "rx", "ry", "rz")


def task_rows(model: TaskModel) -> FloatArray:
    """Index in :data:`TASK_ROWS` of each of the model's task rows, as floats (kernel input)."""
    names = getattr(model, "row_names", None)
    if names is None:  # a model without row names: every row is linear
        return np.zeros(model.task_dim)
    return np.array([TASK_ROWS.index(name) for name in names], dtype=np.float64)


def clamp_command(dw: FloatArray, rows: FloatArray, v_max: float, w_max: float, dt: float) -> None:
    """Scale ``dw`` in place: linear part at most ``v_max dt``, angular part at most ``w_max dt``.

    The whole displacement is scaled by one factor, so that its direction is kept.
    Written in plain loops so that :mod:`lpik.fast` compiles this very function.

    Args:
        dw: Commanded displacement, (m,), changed in place.
        rows: Index of each row in :data:`TASK_ROWS` (``< 3``: linear), (m,).
        v_max: Largest linear speed [m/s].
        w_max: Largest angular speed [rad/s].
        dt: Control period [s].
    """
    lin, ang = 0.0, 0.0
    for k in range(dw.shape[0]):
        if rows[k] < 3:
            lin += dw[k] * dw[k]
        else:
            ang += dw[k] * dw[k]
    lin, ang = math.sqrt(lin), math.sqrt(ang)
    scale = 1.0
    if lin > v_max * dt:
        scale = min(scale, v_max * dt / lin)
    if ang > w_max * dt:
        scale = min(scale, w_max * dt / ang)
    for k in range(dw.shape[0]):
        dw[k] *= scale


class CommandLaw(Protocol):
    """Turns the state of the robot into one step's commanded task displacement ``dw``."""

    def __call__(self, model: TaskModel, q: FloatArray, dt: float) -> FloatArray:
        """The displacement ``dw`` (shape (m,)) commanded for the step from ``q``."""
        ...


def _speed(name: str, value: float) -> float:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
    return float(value)


def _check_target(target: Any) -> None:
    try:
        t = np.asarray(target, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"target: must be numbers, got {type(target).__name__}") from None
    if not np.isfinite(t).all():
        raise ValueError("target: contains NaN or inf")
    if t.shape in ((3, 3), (4, 4)):
        check_rotation("target", t)


@dataclass(frozen=True, eq=False)
class ClampedTarget:
    """Straight toward a target, at most ``v_max`` [m/s] and ``w_max`` [rad/s] fast.

    Args:
        target: Task-space value to move to (what ``model.pose`` returns): an
            xyz point [m], a rotation (3, 3) or a pose (4, 4).
        v_max: Largest commanded linear speed of the task point [m/s].
        w_max: Largest commanded angular speed of the task frame [rad/s].

    Raises:
        ValueError: Naming ``target`` when it is not finite numbers, or a
            rotation or pose whose rotation part is not a rotation (within
            :data:`lpik.tolerances.ROTATION_TOL`) or whose bottom row is not
            (0, 0, 0, 1); naming ``v_max`` or ``w_max`` when not > 0.
    """

    target: Any
    v_max: float = DEFAULT_V_MAX
    w_max: float = DEFAULT_W_MAX

    def __post_init__(self) -> None:
        _check_target(self.target)
        object.__setattr__(self, "v_max", _speed("v_max", self.v_max))
        object.__setattr__(self, "w_max", _speed("w_max", self.w_max))

    def __call__(self, model: TaskModel, q: FloatArray, dt: float) -> FloatArray:
        """The clamped displacement toward the target for one step of ``dt`` [s]."""
        dw = np.array(model.difference(model.pose(q), self.target), dtype=np.float64)
        clamp_command(dw, task_rows(model), self.v_max, self.w_max, dt)
        return dw
