"""Task spaces of an arm: position, orientation, full pose, and axis masks.

Each task wraps a kinematics backend (a :class:`~lpik.robots.chain.SerialChain`
or one of the Pinocchio / MuJoCo adapters: anything that satisfies
:class:`Kinematics`) and implements :class:`~lpik.robots.base.TaskModel`.

Conventions, shared by :meth:`difference` and :meth:`jacobian` so that
``difference(pose(q), pose(q + dq)) = jacobian(q) @ dq + O(|dq|^2)``:

- position rows (x, y, z): the task point's displacement in the base frame [m];
- orientation rows (rx, ry, rz): the rotation vector ``log(R_b @ R_a.T)`` that
  turns orientation ``a`` into ``b``, in the base frame [rad]. The matching
  Jacobian rows are the world-aligned angular velocity rows.

Beyond the protocol, every task has :meth:`difference_jacobian`, the exact
derivative of ``difference(a, pose(q))`` with respect to q, which differs from
``jacobian(q)`` on orientation rows once ``pose(q)`` is away from ``a``; a
nonlinear solver that iterates on q wants that one.

The affine dexterity p of a step scales this displacement: p = 0.5 means the
step moves the task point halfway and turns the tool halfway along the
geodesic towards the command.

A *mask* keeps a subset of the rows, e.g. ``mask="xy"`` on a position task is
the planar position task of the paper's 4-link arm, and ``mask=(1, 1, 1, 0, 0,
1)`` on a pose task leaves rotations about x and y free.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from lpik.robots.rotations import left_jacobian_inverse, log_so3
from lpik.types import FloatArray

POSITION_ROWS = ("x", "y", "z")
ORIENTATION_ROWS = ("rx", "ry", "rz")


@runtime_checkable
class Kinematics(Protocol):
    """A kinematics backend: limits, forward kinematics and Jacobian of one task frame.

    Attributes:
        name: Model name.
        n_joints: Number of joint coordinates n.
        joint_names: Joint names, in the order of q.
        q_min: Lower end-stops, shape (n,) [rad or m].
        q_max: Upper end-stops, shape (n,) [rad or m].
        qd_max: Velocity limits, shape (n,) [rad/s or m/s].
    """

    name: str
    n_joints: int
    joint_names: tuple[str, ...]
    q_min: FloatArray
    q_max: FloatArray
    qd_max: FloatArray

    def fk(self, q: ArrayLike) -> FloatArray:
        """Pose of the task frame in the base frame, shape (4, 4)."""
        ...

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """World-aligned geometric Jacobian at the task point, (6, n): [v; omega]."""
        ...


def _mask(mask: str | Sequence[bool] | None, names: tuple[str, ...]) -> tuple[int, ...]:
    """Row indices kept by a mask given as a string of row names or flags."""
    if mask is None:
        return tuple(range(len(names)))
    if isinstance(mask, str):
        tokens = [t for t in mask.replace(",", " ").split()]
        if len(tokens) == 1 and tokens[0] not in names:
            tokens = list(tokens[0])  # "xy" -> ["x", "y"]
        unknown = [t for t in tokens if t not in names]
        if unknown or not tokens:
            raise ValueError(
                f"mask: unknown row name(s) {unknown or [mask]}; available: " + ", ".join(names)
            )
        return tuple(i for i, n in enumerate(names) if n in tokens)
    flags = [bool(f) for f in mask]
    if len(flags) != len(names):
        raise ValueError(
            f"mask: expected {len(names)} flags for rows {', '.join(names)}, got {len(flags)}"
        )
    rows = tuple(i for i, f in enumerate(flags) if f)
    if not rows:
        raise ValueError("mask: keeps no row; keep at least one")
    return rows


def _pose_and_jacobian(kinematics: Kinematics, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Pose and Jacobian, in one pass where the backend offers ``fk_jacobian``."""
    both = getattr(kinematics, "fk_jacobian", None)
    if both is not None:
        return both(q)
    return kinematics.fk(q), kinematics.jacobian(q)


class _Task:
    """Shared part of the tasks: limits from the backend, masking of rows."""

    ROWS: tuple[str, ...] = ()
    KIND = ""

    def __init__(
        self,
        kinematics: Kinematics,
        mask: str | Sequence[bool] | None = None,
        name: str | None = None,
    ) -> None:
        """Wrap a kinematics backend.

        Args:
            kinematics: The backend (chain or adapter).
            mask: Rows to keep: a string of row names (``"xz"``, ``"x y rz"``)
                or one flag per row; all rows when None.
            name: Task model name; ``"<backend name>-<task kind>"`` when None.

        Raises:
            ValueError: If the mask is invalid.
        """
        self.kinematics = kinematics
        self._rows = _mask(mask, self.ROWS)
        self._full = len(self._rows) == len(self.ROWS)
        self.row_names = tuple(self.ROWS[i] for i in self._rows)
        self.task_dim = len(self._rows)
        self.name = name or f"{kinematics.name}-{self.KIND}"
        self.n_joints = kinematics.n_joints
        self.joint_names = tuple(kinematics.joint_names)
        self.q_min = np.asarray(kinematics.q_min, dtype=float)
        self.q_max = np.asarray(kinematics.q_max, dtype=float)
        self.qd_max = np.asarray(kinematics.qd_max, dtype=float)
        #: Coordinates :meth:`position` reports: 2 (x, y) for a planar chain, else 3.
        self.position_dims = 2 if getattr(kinematics, "planar", False) else 3

    def _select(self, full: FloatArray) -> FloatArray:
        return full if self._full else full[list(self._rows)]

    def position(self, q: ArrayLike) -> FloatArray:
        """Position of the task point in the base frame: (x, y, z), or (x, y) when planar [m]."""
        return self.kinematics.fk(q)[: self.position_dims, 3].copy()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.kinematics!r}, rows={self.row_names})"


class PositionTask(_Task):
    """Position of the task point; task values are xyz vectors (3,) [m]."""

    ROWS = POSITION_ROWS
    KIND = "position"

    def pose(self, q: ArrayLike) -> FloatArray:
        """Task point position at ``q``, shape (3,) [m]."""
        return self.kinematics.fk(q)[:3, 3].copy()

    def difference(self, a: ArrayLike, b: ArrayLike) -> FloatArray:
        """Displacement ``b - a`` on the kept rows, shape (m,) [m]."""
        return self._select(np.asarray(b, dtype=float) - np.asarray(a, dtype=float))

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """Linear-velocity rows of the world-aligned Jacobian, shape (m, n)."""
        return self._select(self.kinematics.jacobian(q)[:3])

    def difference_jacobian(self, a: ArrayLike, q: ArrayLike) -> FloatArray:
        """Derivative of ``difference(a, pose(q))`` in q: the Jacobian, shape (m, n)."""
        return self.jacobian(q)


class OrientationTask(_Task):
    """Orientation of the task frame; task values are rotation matrices (3, 3)."""

    ROWS = ORIENTATION_ROWS
    KIND = "orientation"

    def pose(self, q: ArrayLike) -> FloatArray:
        """Task frame orientation at ``q``, shape (3, 3)."""
        return self.kinematics.fk(q)[:3, :3].copy()

    def difference(self, a: ArrayLike, b: ArrayLike) -> FloatArray:
        """Rotation vector ``log(R_b R_a^T)`` in the base frame, kept rows, (m,) [rad]."""
        ra, rb = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        return self._select(log_so3(rb @ ra.T))

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """Angular-velocity rows of the world-aligned Jacobian, shape (m, n)."""
        return self._select(self.kinematics.jacobian(q)[3:])

    def difference_jacobian(self, a: ArrayLike, q: ArrayLike) -> FloatArray:
        """Derivative of ``difference(a, pose(q))`` in q, shape (m, n).

        ``J_l^-1(log(R(q) R_a^T)) @ J_omega(q)``, with ``J_l`` the left
        Jacobian of SO(3); equal to :meth:`jacobian` when ``pose(q) == a``.
        """
        pose, jac = _pose_and_jacobian(self.kinematics, q)
        phi = log_so3(pose[:3, :3] @ np.asarray(a, dtype=float).T)
        return self._select(left_jacobian_inverse(phi) @ jac[3:])


class PoseTask(_Task):
    """Position and orientation; task values are homogeneous transforms (4, 4)."""

    ROWS = POSITION_ROWS + ORIENTATION_ROWS
    KIND = "pose"

    def pose(self, q: ArrayLike) -> FloatArray:
        """Task frame pose at ``q`` in the base frame, shape (4, 4)."""
        return np.array(self.kinematics.fk(q), dtype=float)

    def difference(self, a: ArrayLike, b: ArrayLike) -> FloatArray:
        """Translation [m] then rotation vector [rad] from ``a`` to ``b``, kept rows."""
        return self._select(pose_difference(a, b))

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """World-aligned geometric Jacobian at the task point, kept rows, (m, n)."""
        return self._select(self.kinematics.jacobian(q))

    def difference_jacobian(self, a: ArrayLike, q: ArrayLike) -> FloatArray:
        """Derivative of ``difference(a, pose(q))`` in q, shape (m, n).

        Position rows as :meth:`jacobian`; orientation rows premultiplied by
        ``J_l^-1(log(R(q) R_a^T))`` (see :meth:`OrientationTask.difference_jacobian`).
        """
        pose, jac = _pose_and_jacobian(self.kinematics, q)
        phi = log_so3(pose[:3, :3] @ np.asarray(a, dtype=float)[:3, :3].T)
        full = np.vstack((jac[:3], left_jacobian_inverse(phi) @ jac[3:]))
        return self._select(full)


def pose_difference(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """All six rows of :meth:`PoseTask.difference`: ``[p_b - p_a; log(R_b R_a^T)]``, (6,)."""
    ta, tb = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return np.concatenate((tb[:3, 3] - ta[:3, 3], log_so3(tb[:3, :3] @ ta[:3, :3].T)))


TASKS = {"position": PositionTask, "orientation": OrientationTask, "pose": PoseTask}


def make_task(
    kinematics: Kinematics,
    task: str = "pose",
    mask: str | Sequence[bool] | None = None,
    name: str | None = None,
) -> PositionTask | OrientationTask | PoseTask:
    """Build a task model by the task's name.

    Args:
        kinematics: The backend (chain or adapter).
        task: ``"position"``, ``"orientation"`` or ``"pose"``.
        mask: Rows to keep (see :class:`PositionTask`).
        name: Task model name.

    Raises:
        ValueError: If the task name or the mask is unknown.
    """
    try:
        cls = TASKS[task]
    except KeyError:
        raise ValueError(f"unknown task '{task}'; available: " + ", ".join(TASKS)) from None
    return cls(kinematics, mask=mask, name=name)


def as_task_model(model: Any) -> Any:
    """``model`` itself when it is a task model; a chain alone becomes its task.

    A :class:`~lpik.robots.chain.SerialChain` (e.g. from
    :func:`~lpik.robots.urdf.load_urdf`) or an adapter (Pinocchio, MuJoCo) has
    no task: a planar chain gets the planar position task (rows x, y, as
    :func:`~lpik.robots.planar.planar_arm`), any other the full pose task.

    Raises:
        ValueError: For anything else, saying what to pass.
    """
    if hasattr(model, "task_dim"):
        return model
    if isinstance(model, Kinematics):
        if getattr(model, "planar", False):
            return PositionTask(model, mask="xy")
        return PoseTask(model)
    raise ValueError(
        f"model: expected a task model (planar_arm, load_robot, make_task(chain, 'pose')) or "
        f"a chain (load_urdf, PinocchioChain, MujocoChain), got {type(model).__name__}"
    )
