"""Pinocchio as the kinematics backend (optional: ``pip install "lpik[pinocchio]"``).

:class:`PinocchioChain` satisfies :class:`~lpik.robots.tasks.Kinematics`, so
every task of :mod:`lpik.robots.tasks` runs on a Pinocchio model::

    from lpik.robots.pinocchio_adapter import PinocchioChain
    from lpik.robots.tasks import PoseTask

    task = PoseTask(PinocchioChain.from_urdf("arm.urdf", tip_link="tool0"))

The joints between the base frame and the tip frame are the chain (``tip_link``:
the name every backend uses, a URDF link is a Pinocchio frame); every other
joint of the model (a gripper, a second arm: ``held_joints``) is locked at its
neutral configuration with ``pinocchio.buildReducedModel``. Chain joint ``i`` is
``v[v_index[i]]`` of your full model (:meth:`PinocchioChain.read_q`,
:meth:`PinocchioChain.write_q` map configurations both ways). Poses and Jacobians are
given in the base frame, the Jacobian world-aligned at the task point
(``LOCAL_WORLD_ALIGNED``), as for :class:`~lpik.robots.chain.SerialChain`.
"""

from __future__ import annotations

import os
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.naming import renamed_keyword
from lpik.robots.rotations import as_transform
from lpik.robots.urdf import read_urdf_text
from lpik.types import FloatArray

INSTALL_HINT = 'pip install "lpik[pinocchio]"'
_TOOL_FRAME = "lpik_task_point"


def import_pinocchio() -> ModuleType:
    """Import ``pinocchio``; the ImportError's message is the install command."""
    try:
        import pinocchio
    except ImportError:
        raise ImportError(INSTALL_HINT) from None
    return pinocchio


def _frame_id(pin: ModuleType, model: Any, frame: str, role: str) -> int:
    if not model.existFrame(frame):
        names = ", ".join(f.name for f in model.frames)
        raise ValueError(
            f"{role} frame '{frame}' is not in the Pinocchio model; available: {names}"
        )
    return int(model.getFrameId(frame))


class PinocchioChain:
    """Kinematics of one frame of a Pinocchio model.

    Attributes:
        name: Model name.
        n_joints: Number of chain joints n.
        joint_names: Chain joint names, base to tip.
        q_min: Lower end-stops, shape (n,) [rad or m]; ``-inf`` for continuous joints.
        q_max: Upper end-stops, shape (n,) [rad or m].
        qd_max: Velocity limits, shape (n,) [rad/s or m/s].
        model: The reduced Pinocchio model (chain joints only).
        q_index: Where each chain joint's coordinate starts in your full model's ``q``.
        v_index: Where each chain joint sits in your full model's ``v``.
        held_joints: The full model's other joints, locked at their neutral configuration.
    """

    def __init__(
        self,
        model: Any,
        tip_link: str | None = None,
        base_link: str | None = None,
        tool: ArrayLike | None = None,
        qd_max: ArrayLike | None = None,
        name: str | None = None,
        *,
        tip_frame: str | None = None,
        base_frame: str | None = None,
    ) -> None:
        """Wrap a Pinocchio model.

        Args:
            model: A ``pinocchio.Model`` (not modified).
            tip_link: Frame of the task point (a URDF link name).
            base_link: Frame that serves as the world frame; the model's
                universe when None.
            tool: Offset of the task point from the tip frame: 4 x 4, xyz (3,)
                [m] or xyz + rpy (6,) [m, rad].
            qd_max: Velocity limits overriding the model's, shape (n,).
            name: Model name; the Pinocchio model's name when None.
            tip_frame: Former name of ``tip_link`` (deprecated).
            base_frame: Former name of ``base_link`` (deprecated).

        Raises:
            ImportError: Pinocchio is not installed (message: the pip command).
            ValueError: Unknown frames, a base frame that is not an ancestor
                of the tip frame, or a chain joint of an unsupported type.
        """
        tip_frame = renamed_keyword(tip_link, tip_frame, "tip_frame", "tip_link")
        base_frame = renamed_keyword(base_link, base_frame, "base_frame", "base_link")
        if tip_frame is None:
            raise ValueError("tip_link: name the frame of the task point")
        pin = import_pinocchio()
        self._pin = pin
        full = model
        tip_id = _frame_id(pin, full, tip_frame, "tip")
        base_id = _frame_id(pin, full, base_frame, "base") if base_frame else None
        tip_support = list(full.supports[full.frames[tip_id].parentJoint])
        base_support = (
            list(full.supports[full.frames[base_id].parentJoint]) if base_id is not None else [0]
        )
        if tip_support[: len(base_support)] != base_support:
            raise ValueError(
                f"frames '{base_frame}' and '{tip_frame}' do not form a chain: "
                f"'{tip_frame}' does not descend from '{base_frame}'"
            )
        keep = set(tip_support[len(base_support) :])
        if not keep:
            raise ValueError(f"no joint moves '{tip_frame}' relative to '{base_frame}'")
        lock = [j for j in range(1, full.njoints) if j not in keep]
        reduced = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full.copy()
        tip_id = int(reduced.getFrameId(tip_frame))
        tip = reduced.frames[tip_id]
        placement = tip.placement.homogeneous @ as_transform(tool, what="tool")
        self._tip_id = int(
            reduced.addFrame(
                pin.Frame(
                    _TOOL_FRAME,
                    tip.parentJoint,
                    tip_id,
                    pin.SE3(placement[:3, :3], placement[:3, 3]),
                    pin.FrameType.OP_FRAME,
                )
            )
        )
        self._base_id = int(reduced.getFrameId(base_frame)) if base_frame else None
        self.model = reduced
        self._data = reduced.createData()
        self.name = name or str(full.name)
        self._setup_joints(reduced, qd_max)
        ids = [int(full.getJointId(joint)) for joint in self.joint_names]
        self.q_index = np.array([int(full.joints[j].idx_q) for j in ids])
        self.v_index = np.array([int(full.joints[j].idx_v) for j in ids])
        self.held_joints = tuple(str(full.names[j]) for j in lock)
        self._full_nq = int(full.nq)

    def _setup_joints(self, model: Any, qd_max: ArrayLike | None) -> None:
        names, lower, upper, velocity, idx_q, idx_v, angle = [], [], [], [], [], [], []
        for j in range(1, model.njoints):
            joint = model.joints[j]
            kind = joint.shortname()
            iq, iv = int(joint.idx_q), int(joint.idx_v)
            if joint.nv != 1 or joint.nq not in (1, 2):
                raise ValueError(
                    f"joint '{model.names[j]}' of type {kind} is on the chain, which lpik "
                    "would have to move, and is not supported (revolute, continuous and "
                    "prismatic joints are): pass base_link=<the arm's base frame> to start "
                    "the chain after it"
                )
            names.append(str(model.names[j]))
            idx_q.append(iq)
            idx_v.append(iv)
            velocity.append(float(model.velocityLimit[iv]))
            if joint.nq == 2:  # unbounded revolute, stored as (cos, sin)
                angle.append(True)
                lower.append(-np.inf)
                upper.append(np.inf)
            else:
                angle.append(False)
                lower.append(float(model.lowerPositionLimit[iq]))
                upper.append(float(model.upperPositionLimit[iq]))
        self.n_joints = len(names)
        self.joint_names = tuple(names)
        self.q_min = np.array(lower)
        self.q_max = np.array(upper)
        self.qd_max = np.array(velocity)
        if qd_max is not None:
            override = np.asarray(qd_max, dtype=float)
            if override.shape != (self.n_joints,):
                raise ValueError(f"qd_max: expected shape ({self.n_joints},), got {override.shape}")
            self.qd_max = override.copy()
        self._idx_q = np.array(idx_q)
        self._idx_v = np.array(idx_v)
        self._unbounded = np.array(angle, dtype=bool)
        self._q_pin = self._pin.neutral(model)

    @classmethod
    def from_urdf(
        cls,
        source: str | os.PathLike[str],
        tip_link: str,
        base_link: str | None = None,
        tool: ArrayLike | None = None,
    ) -> PinocchioChain:
        """Build the Pinocchio model of a URDF and wrap it (as :meth:`MujocoChain.from_urdf`).

        Args:
            source: URDF file or XML text.
            tip_link: Link of the task point.
            base_link: Link that serves as the world frame; the root when None.
            tool: Offset of the task point from the tip link.

        Raises:
            ValueError: For a file that cannot be read or a URDF Pinocchio
                rejects (naming the file, never echoing its text).
        """
        pin = import_pinocchio()
        text, label = read_urdf_text(source)
        try:
            model = pin.buildModelFromXML(text)
        except (RuntimeError, ValueError) as exc:
            reason = str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
            raise ValueError(f"URDF {label}: Pinocchio cannot build it: {reason}") from None
        return cls(model, tip_link, base_link, tool)

    def read_q(self, q_full: ArrayLike) -> FloatArray:
        """The chain's joint coordinates (n,) out of your full model's configuration ``q``."""
        q_full = np.asarray(q_full, dtype=float)
        if q_full.shape != (self._full_nq,):
            raise ValueError(f"q: expected shape ({self._full_nq},), got {q_full.shape}")
        q = q_full[self.q_index].copy()
        if self._unbounded.any():  # (cos, sin) pairs
            at = self.q_index[self._unbounded]
            q[self._unbounded] = np.arctan2(q_full[at + 1], q_full[at])
        return q

    def write_q(self, q: ArrayLike, q_full: Any) -> None:
        """Write the chain's ``q`` (n,) into your full model's configuration in place."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(f"q: expected shape ({self.n_joints},), got {q.shape}")
        if np.shape(q_full) != (self._full_nq,):
            raise ValueError(f"q_full: expected shape ({self._full_nq},), got {np.shape(q_full)}")
        plain = ~self._unbounded
        q_full[self.q_index[plain]] = q[plain]
        at = self.q_index[self._unbounded]
        q_full[at] = np.cos(q[self._unbounded])
        q_full[at + 1] = np.sin(q[self._unbounded])

    def _configuration(self, q: ArrayLike) -> Any:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(f"q: expected shape ({self.n_joints},), got {q.shape}")
        q_pin = self._q_pin.copy()
        plain = ~self._unbounded
        q_pin[self._idx_q[plain]] = q[plain]
        if self._unbounded.any():
            q_pin[self._idx_q[self._unbounded]] = np.cos(q[self._unbounded])
            q_pin[self._idx_q[self._unbounded] + 1] = np.sin(q[self._unbounded])
        return q_pin

    def _base_pose(self) -> FloatArray | None:
        if self._base_id is None:
            return None
        return self._data.oMf[self._base_id].homogeneous

    def fk_jacobian(self, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """:meth:`fk` and :meth:`jacobian` at ``q`` in one pass of Pinocchio's kinematics."""
        pin, model, data = self._pin, self.model, self._data
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        q_pin = self._configuration(q)
        jac = pin.computeFrameJacobian(model, data, q_pin, self._tip_id, frame)[:, self._idx_v]
        pose = pin.updateFramePlacement(model, data, self._tip_id).homogeneous
        if self._base_id is None:
            return pose, jac
        base = pin.updateFramePlacement(model, data, self._base_id).homogeneous
        rot_t = base[:3, :3].T
        return np.linalg.inv(base) @ pose, np.vstack((rot_t @ jac[:3], rot_t @ jac[3:]))

    def fk(self, q: ArrayLike) -> FloatArray:
        """Pose of the task frame in the base frame, shape (4, 4)."""
        pin = self._pin
        pin.framesForwardKinematics(self.model, self._data, self._configuration(q))
        pose = self._data.oMf[self._tip_id].homogeneous
        base = self._base_pose()
        return pose.copy() if base is None else np.linalg.inv(base) @ pose

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """World-aligned geometric Jacobian at the task point, (6, n): [v; omega]."""
        pin = self._pin
        jac = pin.computeFrameJacobian(
            self.model,
            self._data,
            self._configuration(q),
            self._tip_id,
            pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
        )[:, self._idx_v]
        if self._base_id is None:
            return np.array(jac)
        pin.updateFramePlacement(self.model, self._data, self._base_id)
        rot_t = self._data.oMf[self._base_id].rotation.T
        return np.vstack((rot_t @ jac[:3], rot_t @ jac[3:]))

    def position(self, q: ArrayLike) -> FloatArray:
        """Position of the task point in the base frame, shape (3,) [m]."""
        return self.fk(q)[:3, 3]

    def __repr__(self) -> str:
        return f"PinocchioChain(name={self.name!r}, n_joints={self.n_joints})"
