"""The paper's planar n-link arm (sec. 4, Fig. 2) with revolute joints.

Joint angles are relative: ``q1`` is measured from the x axis, ``qi`` from
link ``i - 1``. Link ``i`` ends at
``sum_{j<=i} l_j (cos s_j, sin s_j)`` with ``s_j = q1 + ... + qj``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

TASKS = {"position": 2, "pose": 3}


def _per_joint(
    name: str, value: float | Sequence[float] | None, n: int, default: float
) -> FloatArray:
    if value is None:
        return np.full(n, default)
    arr = (
        np.broadcast_to(np.asarray(value, dtype=np.float64), (n,))
        if np.ndim(value) == 0
        else np.asarray(value, dtype=np.float64)
    )
    if arr.shape != (n,):
        raise ValueError(f"{name}: must have one entry per joint ({n}), got shape {arr.shape}")
    if np.isnan(arr).any():
        raise ValueError(f"{name}: contains NaN")
    return np.array(arr, dtype=np.float64)


class PlanarArm:
    """Planar serial arm with n revolute joints and relative joint angles.

    Implements :class:`lpik.robots.base.TaskModel`.

    Args:
        link_lengths: Length of each link [m], all > 0.
        q_min: Lower end-stops [rad], one per joint or one for all; default unbounded.
        q_max: Upper end-stops [rad]; default unbounded.
        qd_max: Symmetric joint velocity limits [rad/s]; default unbounded.
        task: ``"position"`` (x, y; m = 2) or ``"pose"`` (x, y and the tool angle
            ``q1 + ... + qn``; m = 3).
        name: Name of the model.

    Raises:
        ValueError: Naming the argument that is wrong.
    """

    def __init__(
        self,
        link_lengths: Sequence[float],
        q_min: float | Sequence[float] | None = None,
        q_max: float | Sequence[float] | None = None,
        qd_max: float | Sequence[float] | None = None,
        *,
        task: str = "position",
        name: str | None = None,
    ) -> None:
        lengths = np.asarray(link_lengths, dtype=np.float64)
        if lengths.ndim != 1 or lengths.size < 1:
            raise ValueError("link_lengths: must be a non-empty list of lengths [m]")
        if not np.isfinite(lengths).all() or (lengths <= 0).any():
            raise ValueError("link_lengths: every length must be finite and > 0")
        if task not in TASKS:
            raise ValueError(f"task: unknown planar task {task!r}; available: {', '.join(TASKS)}")
        n = lengths.size
        self.link_lengths = lengths
        self.n_joints = n
        self.task = task
        self.task_dim = TASKS[task]
        self.name = name or f"planar-{n}"
        self.joint_names = tuple(f"joint {i + 1}" for i in range(n))
        self.q_min = _per_joint("q_min", q_min, n, -np.inf)
        self.q_max = _per_joint("q_max", q_max, n, np.inf)
        self.qd_max = _per_joint("qd_max", qd_max, n, np.inf)
        if (self.q_min > self.q_max).any():
            i = int(np.argmax(self.q_min > self.q_max))
            raise ValueError(f"q_min: q_min[{i}] exceeds q_max[{i}]")
        if (self.qd_max <= 0).any():
            raise ValueError("qd_max: velocity limits must be > 0")

    @property
    def reach(self) -> float:
        """Largest distance of the end effector from the base [m]."""
        return float(self.link_lengths.sum())

    def _q(self, q: Sequence[float] | FloatArray) -> FloatArray:
        arr = np.asarray(q, dtype=np.float64)
        if arr.shape != (self.n_joints,):
            raise ValueError(f"q: must have length {self.n_joints}, got shape {arr.shape}")
        return arr

    def joint_positions(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Base, every joint and the end effector, shape (n + 1, 2) [m] (for drawing)."""
        s = np.cumsum(self._q(q))
        pts = np.zeros((self.n_joints + 1, 2))
        pts[1:, 0] = np.cumsum(self.link_lengths * np.cos(s))
        pts[1:, 1] = np.cumsum(self.link_lengths * np.sin(s))
        return pts

    def position(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """End-effector position (x, y) [m] (eq. 1)."""
        s = np.cumsum(self._q(q))
        return np.array([self.link_lengths @ np.cos(s), self.link_lengths @ np.sin(s)])

    def pose(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Task coordinates ``w = phi(q)``: (x, y) or (x, y, tool angle) (eq. 1)."""
        qa = self._q(q)
        xy = self.position(qa)
        return xy if self.task == "position" else np.append(xy, qa.sum())

    def difference(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """``b - a``, with the tool-angle difference wrapped to (-pi, pi]."""
        d = np.asarray(b, dtype=np.float64) - np.asarray(a, dtype=np.float64)
        if self.task == "pose":
            d[2] = -((-d[2] + np.pi) % (2 * np.pi) - np.pi)
        return d

    def jacobian(self, q: Sequence[float] | FloatArray) -> FloatArray:
        """Task Jacobian ``d phi / d q``, shape (m, n) (eq. 2)."""
        s = np.cumsum(self._q(q))
        lx = self.link_lengths * np.cos(s)
        ly = self.link_lengths * np.sin(s)
        # Joint i moves every link from i on: reverse cumulative sums.
        J = np.vstack([-np.cumsum(ly[::-1])[::-1], np.cumsum(lx[::-1])[::-1]])
        if self.task == "pose":
            J = np.vstack([J, np.ones(self.n_joints)])
        return J

    def __repr__(self) -> str:
        return f"PlanarArm(link_lengths={self.link_lengths.tolist()}, task={self.task!r})"
