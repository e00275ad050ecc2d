"""3-D serial kinematic chains: forward kinematics and the geometric Jacobian.

A :class:`SerialChain` is the path of joints from a base link to a tip link
(usually read from a URDF by :func:`lpik.robots.urdf.load_urdf`). Fixed joints
are folded into the origin of the next moving joint, so one step of the chain
is ``T_i = T_{i-1} @ origin_i @ motion_i(q_i)`` with ``motion_i`` a rotation
about (revolute, continuous) or a translation along (prismatic) the joint's
unit axis. Everything is expressed in the base link's frame, which lpik calls
the world frame.

The Jacobian is the geometric one at the task point, with world-aligned axes:
rows 0-2 are the linear velocity of the task point [m/s], rows 3-5 the angular
velocity of the task frame [rad/s], both in base-frame coordinates
(Pinocchio's ``LOCAL_WORLD_ALIGNED``).

Every joint frame is stored re-expressed with z along the joint axis, so a
motion changes one or two columns of a batched (n, 4, 4) array, and the
running product of the n local transforms is a prefix product in
ceil(log2 n) batched matrix products (timings: ``docs/benchmarks.md``).

A chain whose joints all turn about the base's z axis, with every offset in
the x-y plane, moves in that plane: :attr:`SerialChain.planar` says so, and
its tasks report (x, y) positions (the paper's planar arm,
:func:`lpik.robots.planar.planar_arm`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from lpik.robots.rotations import as_transform
from lpik.types import FloatArray

JOINT_KINDS = ("revolute", "prismatic")


@dataclass(frozen=True)
class ChainJoint:
    """One moving joint of a serial chain.

    Attributes:
        name: Joint name (the URDF joint's name).
        kind: ``"revolute"`` (also URDF ``continuous``) or ``"prismatic"``.
        origin: Transform from the previous moving joint's frame (or the base)
            to this joint's frame at q = 0, fixed joints included, shape (4, 4).
        axis: Unit joint axis in this joint's frame, shape (3,).
        lower: Lower end-stop [rad or m]; ``-inf`` when unbounded.
        upper: Upper end-stop [rad or m]; ``+inf`` when unbounded.
        velocity: Symmetric velocity limit [rad/s or m/s]; ``inf`` when none.
    """

    name: str
    kind: str
    origin: FloatArray
    axis: FloatArray
    lower: float = -np.inf
    upper: float = np.inf
    velocity: float = np.inf

    def __post_init__(self) -> None:
        if self.kind not in JOINT_KINDS:
            raise ValueError(
                f"joint '{self.name}': kind must be one of {JOINT_KINDS}, got '{self.kind}'"
            )
        origin = as_transform(self.origin, what=f"joint '{self.name}' origin")
        axis = np.asarray(self.axis, dtype=float).reshape(-1)
        norm = float(np.linalg.norm(axis)) if axis.shape == (3,) else 0.0
        if axis.shape != (3,) or not np.isfinite(norm) or norm < 1e-12:
            raise ValueError(f"joint '{self.name}': axis must be a non-zero 3-vector")
        if np.isnan(self.lower) or np.isnan(self.upper) or self.lower > self.upper:
            raise ValueError(
                f"joint '{self.name}': lower limit {self.lower} must not exceed upper {self.upper}"
            )
        if not self.velocity > 0:
            raise ValueError(
                f"joint '{self.name}': velocity limit must be > 0, got {self.velocity}"
            )
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "axis", axis / norm)


def _in_plane(T: FloatArray) -> bool:
    """True when ``T`` turns about z only and moves within the x-y plane."""
    return abs(T[2, 2] - 1.0) < 1e-12 and abs(T[2, 3]) < 1e-12


@dataclass(frozen=True)
class _LinkRef:
    joint: int  # index of the last moving joint before the link, -1 for the base
    offset: FloatArray = field(default_factory=lambda: np.eye(4))


def _z_to(axis: FloatArray) -> FloatArray:
    """A rigid rotation (4, 4) whose z axis is the unit vector ``axis``."""
    z = np.asarray(axis, dtype=float)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = helper - (helper @ z) * z
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, 0] = x
    out[:3, 1] = np.cross(z, x)
    out[:3, 2] = z
    return out


class SerialChain:
    """Forward kinematics and geometric Jacobian of a serial chain.

    Attributes:
        name: Name of the model.
        n_joints: Number of moving joints n.
        joint_names: Joint names in chain order.
        q_min: Lower end-stops, shape (n,) [rad or m].
        q_max: Upper end-stops, shape (n,) [rad or m].
        qd_max: Velocity limits, shape (n,) [rad/s or m/s].
        base_link: Name of the base (world) frame.
        tip_link: Name of the link the task point is attached to.
        tool: Offset of the task point from the tip link, shape (4, 4).
        planar: True when every joint is revolute about the base's z axis and
            every offset lies in the x-y plane: the chain moves in that plane.
    """

    def __init__(
        self,
        joints: Sequence[ChainJoint],
        *,
        tip_offset: ArrayLike | None = None,
        tool: ArrayLike | None = None,
        name: str = "chain",
        base_link: str = "base",
        tip_link: str = "tip",
        links: Mapping[str, tuple[int, ArrayLike]] | None = None,
    ) -> None:
        """Build a chain.

        Args:
            joints: The moving joints from base to tip (at least one).
            tip_offset: Transform from the last joint's frame to the tip link,
                shape (4, 4); identity when None.
            tool: Offset of the task point from the tip link: a 4 x 4 transform,
                xyz (3,) [m] or xyz + rpy (6,) [m, rad]; identity when None.
            name: Name of the model.
            base_link: Name of the base frame.
            tip_link: Name of the tip link.
            links: Other named frames on the chain: name -> (index of the last
                moving joint before it, -1 for the base; transform from that
                joint's frame to the link).

        Raises:
            ValueError: If there are no joints, or a link reference is invalid.
        """
        if len(joints) == 0:
            raise ValueError(
                f"chain '{name}' from '{base_link}' to '{tip_link}' has no moving joint"
            )
        names = [j.name for j in joints]
        if len(set(names)) != len(names):
            raise ValueError(f"chain '{name}': joint names must be unique, got {names}")
        self.name = name
        self.joints = tuple(joints)
        self.n_joints = len(joints)
        self.joint_names = tuple(names)
        self.q_min = np.array([j.lower for j in joints], dtype=float)
        self.q_max = np.array([j.upper for j in joints], dtype=float)
        self.qd_max = np.array([j.velocity for j in joints], dtype=float)
        self.base_link = base_link
        self.tip_link = tip_link
        self.tip_offset = as_transform(tip_offset, what=f"chain '{name}' tip offset")
        self.tool = as_transform(tool, what="tool")
        self._tip = self.tip_offset @ self.tool
        refs: dict[str, _LinkRef] = {base_link: _LinkRef(-1)}
        for link, (index, offset) in (links or {}).items():
            if not -1 <= int(index) < self.n_joints:
                raise ValueError(f"link '{link}': joint index {index} is outside the chain")
            refs[link] = _LinkRef(int(index), as_transform(offset, what=f"link '{link}' offset"))
        refs[tip_link] = _LinkRef(self.n_joints - 1, self.tip_offset)
        self._links = refs
        # Each joint frame i is re-expressed as frame_i @ A_i with A_i taking z
        # onto the joint axis, so that every motion is about or along z: the
        # batched update below then touches two or one columns per joint.
        align = np.array([_z_to(j.axis) for j in joints])
        prev = np.concatenate((np.eye(4)[None], align[:-1]))
        self._align = align
        self._origins = np.transpose(prev, (0, 2, 1)) @ np.array([j.origin for j in joints]) @ align
        self._rev = np.array([j.kind == "revolute" for j in joints], dtype=float)
        self._pri = 1.0 - self._rev
        self._tip_aligned = align[-1].T @ self._tip
        self._offsets = {
            k: (v.offset if v.joint < 0 else align[v.joint].T @ v.offset) for k, v in refs.items()
        }
        self.planar = all(
            j.kind == "revolute" and _in_plane(j.origin) and abs(abs(j.axis[2]) - 1.0) < 1e-12
            for j in joints
        ) and _in_plane(self._tip)

    @property
    def link_names(self) -> tuple[str, ...]:
        """Names of the frames that :meth:`fk` and :meth:`jacobian` accept."""
        return tuple(self._links)

    def link_anchor(self, link: str) -> tuple[int, FloatArray]:
        """Where a named frame sits on the chain.

        Returns:
            The index of the last moving joint before it (-1 for the base) and
            the frame's transform (4, 4) in that joint's frame of :meth:`joint_frames`.

        Raises:
            ValueError: For an unknown link, listing the known ones.
        """
        if link not in self._links:
            known = ", ".join(self._links)
            raise ValueError(f"unknown link '{link}' on chain '{self.name}'; available: {known}")
        ref = self._links[link]
        return ref.joint, ref.offset.copy()

    def with_tool(self, tool: ArrayLike | None) -> SerialChain:
        """Same chain with another task-point offset from the tip link.

        Args:
            tool: 4 x 4 transform, xyz (3,) [m] or xyz + rpy (6,) [m, rad].
        """
        links = {k: (v.joint, v.offset) for k, v in self._links.items()}
        links.pop(self.base_link)
        links.pop(self.tip_link)
        return SerialChain(
            self.joints,
            tip_offset=self.tip_offset,
            tool=tool,
            name=self.name,
            base_link=self.base_link,
            tip_link=self.tip_link,
            links=links,
        )

    def arrays(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The chain as plain arrays, for compiled kernels.

        Returns:
            ``origins`` (n, 4, 4), unit ``axes`` (n, 3), ``revolute`` flags (n,)
            (False: prismatic) and ``tip`` (4, 4), the task point in the last
            joint's frame (tip offset and tool), such that
            ``T_i = T_{i-1} @ origins[i] @ motion_i(q_i)`` and the task frame
            is ``T_{n-1} @ tip``.
        """
        return (
            np.array([j.origin for j in self.joints]),
            np.array([j.axis for j in self.joints]),
            self._rev.astype(bool),
            self._tip.copy(),
        )

    def _check_q(self, q: ArrayLike) -> FloatArray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(f"q: expected shape ({self.n_joints},), got {q.shape}")
        return q

    def _aligned_frames(self, q: FloatArray) -> FloatArray:
        """Joint frames with z along each joint axis, after the motion, (n, 4, 4)."""
        angle = q * self._rev
        c = np.cos(angle)[:, None]
        s = np.sin(angle)[:, None]
        o = self._origins
        frames = o.copy()
        frames[:, :, 0] = o[:, :, 0] * c + o[:, :, 1] * s
        frames[:, :, 1] = o[:, :, 1] * c - o[:, :, 0] * s
        frames[:, :, 3] += o[:, :, 2] * (q * self._pri)[:, None]
        # Prefix product T_i = L_0 L_1 ... L_i in ceil(log2 n) batched steps.
        step = 1
        while step < self.n_joints:
            frames[step:] = frames[:-step] @ frames[step:]
            step *= 2
        return frames

    def joint_frames(self, q: ArrayLike) -> FloatArray:
        """Frames of the moving joints after their motion, in the base frame.

        Args:
            q: Joint coordinates, shape (n,) [rad or m].

        Returns:
            ``T[i]`` is the pose of joint i's child frame, shape (n, 4, 4).
        """
        frames = self._aligned_frames(self._check_q(q))
        return frames @ np.transpose(self._align, (0, 2, 1))

    def _aligned_ref(self, link: str | None) -> tuple[int, FloatArray]:
        """Joint index and offset from that joint's aligned frame to ``link``."""
        if link is None:
            return self.n_joints - 1, self._tip_aligned
        try:
            return self._links[link].joint, self._offsets[link]
        except KeyError:
            raise ValueError(
                f"unknown link '{link}' on chain '{self.name}'; available: "
                + ", ".join(self._links)
            ) from None

    def fk(self, q: ArrayLike, link: str | None = None) -> FloatArray:
        """Pose of a frame in the base frame.

        Args:
            q: Joint coordinates, shape (n,) [rad or m].
            link: A name from :attr:`link_names`; None for the task point (the
                tip link with the tool offset).

        Returns:
            Homogeneous transform, shape (4, 4).
        """
        index, offset = self._aligned_ref(link)
        q = self._check_q(q)
        if index < 0:
            return offset.copy()
        return self._aligned_frames(q)[index] @ offset

    def position(self, q: ArrayLike) -> FloatArray:
        """Position of the task point in the base frame, shape (3,) [m]."""
        return self.fk(q)[:3, 3]

    def fk_jacobian(self, q: ArrayLike, link: str | None = None) -> tuple[FloatArray, FloatArray]:
        """Pose and world-aligned geometric Jacobian of a frame, in one pass.

        Args:
            q: Joint coordinates, shape (n,) [rad or m].
            link: A name from :attr:`link_names`; None for the task point.

        Returns:
            The pose (4, 4) and the Jacobian (6, n): linear velocity of the
            frame's origin [m/s] over angular velocity [rad/s], base axes.
        """
        index, offset = self._aligned_ref(link)
        q = self._check_q(q)
        jac = np.zeros((6, self.n_joints))
        if index < 0:
            return offset.copy(), jac
        frames = self._aligned_frames(q)
        pose = frames[index] @ offset
        k = index + 1
        z = frames[:k, :3, 2]
        d = pose[:3, 3] - frames[:k, :3, 3]
        rev = self._rev[:k]
        jac[0, :k] = (z[:, 1] * d[:, 2] - z[:, 2] * d[:, 1]) * rev
        jac[1, :k] = (z[:, 2] * d[:, 0] - z[:, 0] * d[:, 2]) * rev
        jac[2, :k] = (z[:, 0] * d[:, 1] - z[:, 1] * d[:, 0]) * rev
        jac[:3, :k] += z.T * self._pri[:k]
        jac[3:, :k] = z.T * rev
        return pose, jac

    def jacobian(self, q: ArrayLike, link: str | None = None) -> FloatArray:
        """World-aligned geometric Jacobian of a frame, shape (6, n).

        Args:
            q: Joint coordinates, shape (n,) [rad or m].
            link: A name from :attr:`link_names`; None for the task point.
        """
        return self.fk_jacobian(q, link)[1]

    def __repr__(self) -> str:
        return (
            f"SerialChain(name={self.name!r}, n_joints={self.n_joints}, "
            f"base_link={self.base_link!r}, tip_link={self.tip_link!r})"
        )
