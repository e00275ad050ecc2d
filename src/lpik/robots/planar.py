"""The paper's planar n-link arm (sec. 4, Fig. 2): a serial chain that moves in the x-y plane.

Joint angles are relative: ``q1`` is measured from the x axis, ``qi`` from
link ``i - 1``; every joint turns about z. Link ``i`` ends at
``sum_{j<=i} l_j (cos s_j, sin s_j)`` with ``s_j = q1 + ... + qj``. The arm is
a :class:`~lpik.robots.chain.SerialChain` like any URDF arm, and its task is
a masked task of :mod:`lpik.robots.tasks`: ``"xy"`` (position) or ``"x y rz"``
(position and the tool angle ``q1 + ... + qn``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lpik.labels import default_joint_names
from lpik.robots.chain import ChainJoint, SerialChain
from lpik.robots.rotations import transform
from lpik.robots.tasks import PoseTask, PositionTask
from lpik.types import FloatArray

#: Planar task name -> the rows of a 3-D task it keeps.
PLANAR_TASKS = {"position": "xy", "pose": "x y rz"}


def _per_joint(
    name: str, value: float | Sequence[float] | None, n: int, default: float
) -> FloatArray:
    if value is None:
        return np.full(n, default)
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name}: must have one entry per joint ({n}), got shape {arr.shape}")
    if np.isnan(arr).any():
        raise ValueError(f"{name}: contains NaN")
    return arr


def planar_chain(
    link_lengths: Sequence[float],
    q_min: float | Sequence[float] | None = None,
    q_max: float | Sequence[float] | None = None,
    qd_max: float | Sequence[float] | None = None,
    *,
    name: str | None = None,
) -> SerialChain:
    """The planar arm as a serial chain of z-axis revolute joints (sec. 4, Fig. 2).

    Args:
        link_lengths: Length of each link [m], all > 0.
        q_min: Lower end-stops [rad], one per joint or one for all; default unbounded.
        q_max: Upper end-stops [rad]; default unbounded.
        qd_max: Symmetric joint velocity limits [rad/s]; default unbounded.
        name: Name of the model; default ``"planar-<n>"``.

    Raises:
        ValueError: Naming the argument that is wrong.
    """
    lengths = np.asarray(link_lengths, dtype=np.float64)
    if lengths.ndim != 1 or lengths.size < 1:
        raise ValueError("link_lengths: must be a non-empty list of lengths [m]")
    if not np.isfinite(lengths).all() or (lengths <= 0).any():
        raise ValueError("link_lengths: every length must be finite and > 0")
    n = lengths.size
    lower = _per_joint("q_min", q_min, n, -np.inf)
    upper = _per_joint("q_max", q_max, n, np.inf)
    speed = _per_joint("qd_max", qd_max, n, np.inf)
    if (lower > upper).any():
        i = int(np.argmax(lower > upper))
        raise ValueError(f"q_min: q_min[{i}] exceeds q_max[{i}]")
    if (speed <= 0).any():
        raise ValueError("qd_max: velocity limits must be > 0")
    offsets = np.concatenate([[0.0], lengths[:-1]])  # joint i sits at the end of link i - 1
    joints = [
        ChainJoint(
            name=joint,
            kind="revolute",
            origin=transform((offset, 0.0, 0.0)),
            axis=(0.0, 0.0, 1.0),
            lower=float(lo),
            upper=float(hi),
            velocity=float(v),
        )
        for joint, offset, lo, hi, v in zip(default_joint_names(n), offsets, lower, upper, speed)
    ]
    return SerialChain(
        joints,
        tip_offset=transform((float(lengths[-1]), 0.0, 0.0)),
        name=name or f"planar-{n}",
        tip_link="end effector",
    )


def planar_arm(
    link_lengths: Sequence[float],
    q_min: float | Sequence[float] | None = None,
    q_max: float | Sequence[float] | None = None,
    qd_max: float | Sequence[float] | None = None,
    *,
    task: str = "position",
    name: str | None = None,
) -> PositionTask | PoseTask:
    """The paper's planar arm with its task: a task model like any other.

    Args:
        link_lengths: Length of each link [m], all > 0.
        q_min: Lower end-stops [rad], one per joint or one for all; default unbounded.
        q_max: Upper end-stops [rad]; default unbounded.
        qd_max: Symmetric joint velocity limits [rad/s]; default unbounded.
        task: ``"position"`` (x, y; m = 2) or ``"pose"`` (x, y and the tool
            angle about z; m = 3). Task values are those of the 3-D tasks: an
            xyz point (z = 0) or a 4 x 4 pose.
        name: Name of the model; default ``"planar-<n>"``.

    Raises:
        ValueError: Naming the argument that is wrong.
    """
    if task not in PLANAR_TASKS:
        raise ValueError(
            f"task: unknown planar task {task!r}; available: {', '.join(PLANAR_TASKS)}"
        )
    chain = planar_chain(link_lengths, q_min, q_max, qd_max, name=name)
    cls = PositionTask if task == "position" else PoseTask
    return cls(chain, mask=PLANAR_TASKS[task], name=chain.name)
