"""What :class:`~lpik.control.controller.Lp2Controller` accepts, checked and converted.

The compiled step takes C-contiguous, writable float64 arrays only; these
helpers turn anything else into them, or raise a ``ValueError`` that names
the argument (and the row of a batch) that is wrong.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

from lpik.command import TASK_ROWS, checked_target, target_fits, task_rows
from lpik.limits import (
    AccelerationLimits,
    AutomaticMultiplierBounds,
    EndStops,
    LambdaBound,
    Limit,
    LinearRows,
    MultiplierBounds,
    StepContext,
    VelocityLimits,
    multiplier_limit,
    standard_limits,
)
from lpik.robots.base import TaskModel
from lpik.robots.chain import SerialChain
from lpik.robots.rotations import check_rotation, rotation_defects
from lpik.robots.tasks import OrientationTask, PositionTask
from lpik.tolerances import MAX_MAGNITUDE, ROTATION_TOL
from lpik.types import FloatArray, NotRealError, numbers_of, real_array

#: The shapes a target may have: xyz, a rotation, a pose.
TARGET_SHAPES = ((3,), (3, 3), (4, 4))


def positive_number(name: str, value: Any) -> float:
    """``value`` as a float when it is a finite number in (0, MAX_MAGNITUDE], else a ValueError.

    Raises:
        ValueError: Naming ``name``.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name}: must be a number > 0, got {value!r}")
    number = float(value)
    if not (math.isfinite(number) and 0.0 < number <= MAX_MAGNITUDE):
        raise ValueError(
            f"{name}: must be a finite number > 0 (at most {MAX_MAGNITUDE:g}), got {value!r}"
        )
    return number


def joint_rates(name: str, value: Any, n: int) -> FloatArray:
    """Per-joint limits > 0 (``inf``: none) from a scalar or ``n`` numbers, or a ValueError.

    Raises:
        ValueError: Naming ``name``, for a wrong length, NaN, a value <= 0 or too large,
            or booleans (``True`` is not a switch that turns the limits on: it would be
            a limit of 1).
    """
    try:
        arr = real_array(value)
    except NotRealError as exc:
        raise ValueError(f"{name}: must be a number or {n} numbers, got {exc} {value!r}") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be a number or {n} numbers, got {value!r}") from None
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name}: must be a number or {n} numbers, got shape {arr.shape}")
    bad = np.isnan(arr) | (arr <= 0.0) | (np.isfinite(arr) & (arr > MAX_MAGNITUDE))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"{name}: must be > 0 (inf: no limit, finite at most {MAX_MAGNITUDE:g}), "
            f"got {arr[i]:g} at index {i}"
        )
    return arr


def extra_rows(G: Any, h: Any, n: int) -> tuple[FloatArray, FloatArray]:
    """Rows ``G q <= h`` as float arrays (r, n) and (r,), or a ValueError naming G or h.

    Their shapes and values are checked further by :class:`~lpik.problem.Problem`.
    """
    if G is None or h is None:
        raise ValueError(f"{'G' if G is None else 'h'}: G and h must be given together")
    arrays = []
    for name, value in (("G", G), ("h", h)):
        try:
            arrays.append(np.atleast_1d(real_array(value)))
        except (TypeError, ValueError):
            raise ValueError(f"{name}: must be numbers, got {value!r}"[:200]) from None
    rows = arrays[0].reshape(1, n) if arrays[0].shape == (n,) else arrays[0]
    return rows, arrays[1]


def row_names(value: Any) -> tuple[str, ...]:
    """Labels of the rows ``G q <= h`` as a tuple of strings (none: ``()``), or a ValueError."""
    if value is None:
        return ()
    if isinstance(value, str) or not isinstance(value, list | tuple):
        raise ValueError(f"row_labels: must be a list of strings, got {value!r}"[:200])
    if not all(isinstance(label, str) for label in value):
        raise ValueError("row_labels: must be a list of strings")
    return tuple(value)


#: The limits whose bounds do not depend on the state: what a compiled step can hold.
STATE_FREE_LIMITS = (EndStops, VelocityLimits, AccelerationLimits, MultiplierBounds, LinearRows,
                     AutomaticMultiplierBounds)  # fmt: skip


def rate_limits(limits: Sequence[Limit], n: int) -> FloatArray:
    """The joints' velocity and acceleration limits the ``limits`` set, per second.

    Read from the same pieces :func:`build_problem` stacks (a velocity limit's
    step bound at ``dt = 1`` s is the limit itself), so that the compiled step
    (:class:`~lpik.control.controller.Lp2Controller`) and the numpy layers
    derive each step's bounds (eq. 14, :mod:`lpik.bands`) from the same values.

    Returns:
        (4, n): ``qd_min, qd_max`` [rad/s], ``qdd_min, qdd_max`` [rad/s^2];
        ``-inf``/``inf`` where none.

    Raises:
        ValueError: For a limit whose bounds depend on the state (not one of
            :data:`STATE_FREE_LIMITS`): the compiled step cannot hold it.
    """
    out = np.vstack([np.full(n, -np.inf), np.full(n, np.inf)] * 2)
    context = StepContext(q0=np.zeros(n), dt=1.0)
    for limit in limits:
        if not isinstance(limit, STATE_FREE_LIMITS):
            names = ", ".join(cls.__name__ for cls in STATE_FREE_LIMITS)
            raise ValueError(
                f"limits: the compiled step holds {names}; {type(limit).__name__} depends on "
                "the state: run it with simulate(..., method='lp2') or build_problem"
            )
        piece = limit.apply(context)
        values = (piece.dq_min, piece.dq_max, piece.qdd_min, piece.qdd_max)
        for row, value in enumerate(values):
            if value is not None:
                tighter = np.maximum if row % 2 == 0 else np.minimum  # lower rows: the largest
                out[row] = tighter(out[row], np.broadcast_to(value, (n,)))
    return out


def step_limits(
    model: TaskModel,
    limits: Sequence[Limit] | None,
    *,
    velocity_limits: bool,
    qdd_max: Any,
    lambda_bound: LambdaBound,
    rows: tuple[Any, Any, Any],
) -> tuple[Limit, ...]:
    """The limits every step holds: ``limits`` as given, else the model's, plus the keywords.

    ``limits`` are the values :func:`lpik.limits.build_problem` takes; without
    them, the model's end-stops and (``velocity_limits``) velocity limits
    (:func:`lpik.limits.standard_limits`). The keywords add to either:
    ``qdd_max`` [rad/s^2] an :class:`~lpik.limits.AccelerationLimits`,
    ``lambda_bound`` the multiplier limit :func:`lpik.limits.multiplier_limit`
    reads (``"auto"``, the default, only where ``limits`` do not bound the
    multipliers already), ``rows`` ``(G, h,
    row_labels)`` a :class:`~lpik.limits.LinearRows`.

    Raises:
        ValueError: Naming the argument that is wrong.
    """
    n = model.n_joints
    if limits is None:
        held: list[Limit] = standard_limits(model, velocity=velocity_limits, lambda_bound=None)
    elif isinstance(limits, Sequence) and all(hasattr(v, "apply") for v in limits):
        held = list(limits)
    else:
        raise ValueError(
            "limits: must be a list of limits (EndStops, VelocityLimits, AccelerationLimits, "
            f"MultiplierBounds, LinearRows), got {type(limits).__name__}"
        )
    bound = multiplier_limit(lambda_bound)
    if lambda_bound != "auto" or not any(
        isinstance(limit, MultiplierBounds | AutomaticMultiplierBounds) for limit in held
    ):  # "auto" (the default) holds unless the limits bound the multipliers
        held.extend([] if bound is None else [bound])
    if qdd_max is not None:
        held.append(AccelerationLimits(joint_rates("qdd_max", qdd_max, n)))
    G, h, row_labels = rows
    if G is not None or h is not None:
        G, h = extra_rows(G, h, n)
        held.append(LinearRows(G, h, row_names(row_labels)))
    return tuple(held)


def placeholder_chain(n: int) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Chain blocks for a backend step, which does not read them: origins, axes, revolute, tip."""
    return np.tile(np.eye(4), (n, 1, 1)), np.zeros((n, 3)), np.ones(n), np.eye(4)


def chain_arrays(model: TaskModel) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The model's chain as the compiled kinematics' arrays: origins, axes, revolute, tip.

    See :meth:`lpik.robots.chain.SerialChain.arrays`; ``revolute`` as floats. A
    task over another backend (Pinocchio, MuJoCo) gets placeholders: its own
    kinematics run each step (:mod:`lpik.control.backend_step`).

    Raises:
        ValueError: For a model that is not a task of :mod:`lpik.robots.tasks`.
    """
    chain = getattr(model, "kinematics", None)
    if chain is None or getattr(model, "row_names", None) is None:
        raise ValueError(
            "model: Lp2Controller takes a task of lpik.robots.tasks (PoseTask, PositionTask, "
            "OrientationTask, make_task) over a SerialChain, a PinocchioChain or a MujocoChain, "
            f"or such a chain itself (a pose task); got {type(model).__name__}"
        )
    if not isinstance(chain, SerialChain):
        return placeholder_chain(model.n_joints)
    origins, axes, revolute, tip = chain.arrays()
    return origins, axes, revolute.astype(np.float64), tip


def joint_vector(name: str, value: Any, n: int, check_finite: bool) -> FloatArray:
    """A writable C-contiguous float64 copy of a joint vector of length ``n``."""
    v = numbers_of(name, value, f"{n} numbers", order="C")
    if v.shape != (n,):
        raise ValueError(f"{name}: must have length {n}, got shape {v.shape}")
    if check_finite and not np.isfinite(v).all():
        raise ValueError(f"{name}: contains NaN or inf")
    return v


def target_array(target: Any, check_finite: bool) -> FloatArray:
    """A writable C-contiguous float64 copy of a target: xyz (3,), a rotation (3, 3) or a pose."""
    t = numbers_of("target", target, order="C")
    if t.shape not in TARGET_SHAPES:
        raise ValueError(
            f"target: must be xyz (3,), a rotation (3, 3) or a pose (4, 4), got {t.shape}"
        )
    if check_finite or t.ndim == 2:  # else the compiled step checks it (BAD_INPUT)
        checked_target(t)
    return t


def task_value(model: TaskModel, target: Any) -> FloatArray:
    """The target as the model's task value (what ``model.pose`` returns), as the step reads it.

    The target must command every row of the task (:func:`lpik.command.target_fits`):
    an xyz (3,) for a task of position rows only, a rotation (3, 3) for one of
    rotation rows only, a pose (4, 4) for any task.

    Raises:
        ValueError: Naming ``target`` when it is not a task value, or leaves a part
            the task controls (an xyz for a pose task: no rotation is made up).
    """
    t = target_array(target, check_finite=True)
    rows = task_rows(model)
    if not target_fits(t.shape != (3, 3), t.shape != (3,), rows):
        wanted = "a pose (4, 4)" + (", or a rotation (3, 3)" if rows.min() >= 3 else "")
        given = {(3,): "xyz (3,): it has no rotation", (3, 3): "a rotation: it has no position"}
        raise ValueError(
            f"target: the task controls {', '.join(TASK_ROWS[int(r)] for r in rows)}; give "
            f"{wanted}, not {given[t.shape]}"
        )
    goal = np.eye(4)
    if t.shape == (3,):
        goal[:3, 3] = t
    elif t.shape == (3, 3):
        goal[:3, :3] = t
    else:
        goal = t
    if isinstance(model, PositionTask):
        return goal[:3, 3]
    if isinstance(model, OrientationTask):
        return goal[:3, :3]
    return goal


def stacked_rows(
    name: str, value: Any, shapes: tuple[tuple[int, ...], ...], count: int | None = None
) -> FloatArray:
    """A C-contiguous float64 stack (B, *shape) of finite rows, or a ValueError naming them.

    ``shapes`` lists the accepted shapes of one row; ``count`` the required B.
    """
    arr = numbers_of(name, value, order="C")  # a copy: the compiled step takes writable arrays
    if arr.ndim == 0 or arr.shape[1:] not in shapes or arr.shape[0] == 0:
        wanted = " or ".join(str(("B",) + s).replace("'", "") for s in shapes)
        raise ValueError(f"{name}: must have shape {wanted} with B >= 1, got {arr.shape}")
    if count is not None and arr.shape[0] != count:
        raise ValueError(f"{name}: must have {count} rows (one per row of q0), got {arr.shape[0]}")
    finite = np.isfinite(arr).reshape(arr.shape[0], -1).all(axis=1)
    if not finite.all():
        raise ValueError(f"{name}: row {int(np.argmin(finite))} contains NaN or inf")
    if arr.ndim == 3:
        bad = rotation_defects(arr) > ROTATION_TOL
        if bad.any():
            row = int(np.argmax(bad))
            check_rotation(f"{name}: row {row}", arr[row])
    return arr
