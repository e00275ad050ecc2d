"""Pinocchio as the kinematics backend (optional: ``pip install "lpik[pinocchio]"``).

:class:`PinocchioChain` satisfies :class:`~lpik.robots.tasks.Kinematics`, so
every task of :mod:`lpik.robots.tasks` runs on a Pinocchio model::

    from lpik.robots.pinocchio_adapter import PinocchioChain
    from lpik.robots.tasks import PoseTask

    task = PoseTask(PinocchioChain.from_urdf("arm.urdf", tip_link="tool0"))

The joints between the base frame and the tip frame are the chain; every other
joint of the model (a gripper, a second arm) is locked at its neutral
configuration with ``pinocchio.buildReducedModel``. Poses and Jacobians are
given in the base frame, the Jacobian world-aligned at the task point
(``LOCAL_WORLD_ALIGNED``), as for :class:`~lpik.robots.chain.SerialChain`.
"""

from __future__ import annotations

import os
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.robots.rotations import as_transform
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
    """

    def __init__(
        self,
        model: Any,
        tip_frame: str,
        base_frame: str | None = None,
        tool: ArrayLike | None = None,
        qd_max: ArrayLike | None = None,
        name: str | None = None,
    ) -> None:
        """Wrap a Pinocchio model.

        Args:
            model: A ``pinocchio.Model`` (not modified).
            tip_frame: Frame of the task point (a URDF link name).
            base_frame: Frame that serves as the world frame; the model's
                universe when None.
            tool: Offset of the task point from the tip frame: 4 x 4, xyz (3,)
                [m] or xyz + rpy (6,) [m, rad].
            qd_max: Velocity limits overriding the model's, shape (n,).
            name: Model name; the Pinocchio model's name when None.

        Raises:
            ImportError: Pinocchio is not installed (message: the pip command).
            ValueError: Unknown frames, a base frame that is not an ancestor
                of the tip frame, or a chain joint of an unsupported type.
        """
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

    def _setup_joints(self, model: Any, qd_max: ArrayLike | None) -> None:
        names, lower, upper, velocity, idx_q, idx_v, angle = [], [], [], [], [], [], []
        for j in range(1, model.njoints):
            joint = model.joints[j]
            kind = joint.shortname()
            iq, iv = int(joint.idx_q), int(joint.idx_v)
            if joint.nv != 1 or joint.nq not in (1, 2):
                raise ValueError(
                    f"joint '{model.names[j]}' of type {kind} is not supported "
                    "(revolute, continuous and prismatic joints are)"
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
        path: str | os.PathLike[str],
        tip_link: str,
        base_link: str | None = None,
        tool: ArrayLike | None = None,
    ) -> PinocchioChain:
        """Build the Pinocchio model of a URDF file and wrap it.

        Args:
            path: URDF file.
            tip_link: Link of the task point.
            base_link: Link that serves as the world frame; the root when None.
            tool: Offset of the task point from the tip link.
        """
        pin = import_pinocchio()
        return cls(pin.buildModelFromUrdf(str(path)), tip_link, base_link, tool)

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
