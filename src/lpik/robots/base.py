"""The protocol every kinematic model of lpik implements.

A *task model* is a robot together with the task its end effector is asked to
do (planar position, 3-D position, orientation, full pose, a masked subset).
The methods of lpik never see the robot: they see one step's Jacobian ``J``
and displacement ``dw``. The simulation layer and the nonlinear baseline
(``lpik.methods.nlp``) build those from a task model through this protocol.

Task-space values are opaque to the caller: a planar arm's pose is a vector,
a 3-D pose may be a (position, rotation) pair. Only :meth:`difference` turns
two of them into a displacement vector of length ``task_dim``; for vector
tasks it is ``b - a``, for orientations a log map.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from lpik.types import FloatArray


@runtime_checkable
class TaskModel(Protocol):
    """A manipulator and the task of its end effector.

    Attributes:
        name: Short name of the model.
        n_joints: Number of joint coordinates n.
        joint_names: One name per joint.
        task_dim: Number of task coordinates m.
        q_min: Lower joint end-stops, shape (n,) [rad or m]; ``-inf`` when unbounded.
        q_max: Upper joint end-stops, shape (n,) [rad or m]; ``+inf`` when unbounded.
        qd_max: Symmetric joint velocity limits, shape (n,) [rad/s or m/s]; ``inf`` when none.
    """

    name: str
    n_joints: int
    joint_names: tuple[str, ...]
    task_dim: int
    q_min: FloatArray
    q_max: FloatArray
    qd_max: FloatArray

    def pose(self, q: FloatArray) -> Any:
        """Task-space value of the end effector at ``q`` (eq. 1, phi(q))."""
        ...

    def difference(self, a: Any, b: Any) -> FloatArray:
        """Displacement from task value ``a`` to task value ``b``, shape (m,)."""
        ...

    def jacobian(self, q: FloatArray) -> FloatArray:
        """Task Jacobian at ``q``, shape (m, n), consistent with :meth:`difference`."""
        ...

    def position(self, q: FloatArray) -> FloatArray:
        """Cartesian position of the task point at ``q``: (x, y) or (x, y, z) [m]."""
        ...


def velocity_limits(value: Any, joint_names: Sequence[str], missing: str) -> FloatArray:
    """Velocity limits [rad/s or m/s] of the named joints: one number for all, or one each.

    ``inf`` means no limit. A backend whose model keeps none demands them
    (``missing`` says why they are needed).

    Raises:
        ValueError: For ``None`` (naming the joints), a wrong length, NaN or a value <= 0.
    """
    n = len(joint_names)
    if value is None:
        raise ValueError(
            f"qd_max: velocity limits are needed ({missing}); pass one number or {n} "
            f"[rad/s] for {', '.join(joint_names)}, or float('inf') for none"
        )
    arr = np.array(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"qd_max: expected one number or shape ({n},), got {arr.shape}")
    if np.isnan(arr).any() or (arr <= 0).any():
        raise ValueError(f"qd_max: every limit must be > 0 (inf: none), got {arr.tolist()}")
    return arr
