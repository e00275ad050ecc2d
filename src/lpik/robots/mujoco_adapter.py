"""MuJoCo as the kinematics backend (optional: ``pip install "lpik[mujoco]"``).

:class:`MujocoChain` satisfies :class:`~lpik.robots.tasks.Kinematics`::

    from lpik.robots.mujoco_adapter import MujocoChain
    from lpik.robots.tasks import PoseTask

    task = PoseTask(MujocoChain.from_urdf("arm.urdf", tip_link="tool0"))

The chain is the hinge and slide joints on the path from the base body to the
tip body (``tip_link``: the name every backend uses, a URDF link is a MuJoCo
body). The other joints (``held_joints``: fingers, a second arm) cannot move
the tip relative to the base; lpik's kinematics hold them at ``qpos0`` and
:meth:`MujocoChain.write_qpos` never touches them in yours. Chain joint ``i``
is ``qpos[qpos_index[i]]`` (:meth:`MujocoChain.read_qpos`). MuJoCo keeps no
velocity limits: pass ``qd_max`` (``inf`` for none), or use
:meth:`MujocoChain.from_urdf`, which reads them from the URDF. Poses and
Jacobians are in the base body's frame, the Jacobian world-aligned at the task
point, as for :class:`~lpik.robots.chain.SerialChain`.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.naming import renamed_keyword
from lpik.robots.base import velocity_limits
from lpik.robots.rotations import as_transform
from lpik.robots.urdf import parse_urdf, read_urdf_text
from lpik.types import FloatArray

INSTALL_HINT = 'pip install "lpik[mujoco]"'

#: Compiler settings for a kinematics-only URDF: keep every link as a body
#: (fixed joints included, so that tool frames exist) and accept massless links.
URDF_COMPILER = {
    "fusestatic": "false",
    "discardvisual": "true",
    "boundmass": "1e-6",
    "boundinertia": "1e-9",
}


def import_mujoco() -> ModuleType:
    """Import ``mujoco``; the ImportError's message is the install command."""
    try:
        import mujoco
    except ImportError:
        raise ImportError(INSTALL_HINT) from None
    return mujoco


def kinematic_urdf(text: str) -> str:
    """A URDF's text with geometry and inertia removed and MuJoCo compiler settings added.

    Meshes would have to be found on disk, and inertias do not matter for
    kinematics; see :data:`URDF_COMPILER` for the settings.
    """
    root = ET.fromstring(text)
    for link in root.iter("link"):
        for child in list(link):
            if child.tag in ("visual", "collision", "inertial"):
                link.remove(child)
    ext = root.find("mujoco")
    if ext is None:
        ext = ET.SubElement(root, "mujoco")
    compiler = ext.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(ext, "compiler")
    compiler.attrib.update(URDF_COMPILER)
    return ET.tostring(root, encoding="unicode")


def _pose(rot: Any, pos: Any) -> FloatArray:
    out = np.eye(4)
    out[:3, :3] = np.asarray(rot).reshape(3, 3)
    out[:3, 3] = pos
    return out


class MujocoChain:
    """Kinematics of one body of a MuJoCo model.

    Attributes:
        name: Model name.
        n_joints: Number of chain joints n.
        joint_names: Chain joint names, base to tip.
        q_min: Lower end-stops, shape (n,) [rad or m]; infinite where unlimited.
        q_max: Upper end-stops, shape (n,) [rad or m].
        qd_max: Velocity limits, shape (n,) [rad/s or m/s], as given.
        model: The ``mujoco.MjModel``.
        qpos_index: Where each chain joint sits in MuJoCo's ``qpos``, shape (n,).
        dof_index: Where each chain joint sits in MuJoCo's ``qvel``, shape (n,).
        held_joints: The model's other joints, held at ``qpos0`` by lpik's kinematics.
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
        tip_body: str | None = None,
        base_body: str | None = None,
    ) -> None:
        """Wrap a MuJoCo model.

        Args:
            model: A ``mujoco.MjModel``.
            tip_link: Body of the task point (a URDF link name).
            base_link: Body whose frame is the world frame; MuJoCo's world
                when None.
            tool: Offset of the task point from the tip body: 4 x 4, xyz (3,)
                [m] or xyz + rpy (6,) [m, rad].
            qd_max: Velocity limits of the chain joints [rad/s or m/s]: one
                number or one per joint, ``inf`` for none. Required: MuJoCo
                keeps none (:meth:`from_urdf` reads the URDF's).
            name: Model name.
            tip_body: Former name of ``tip_link`` (deprecated).
            base_body: Former name of ``base_link`` (deprecated).

        Raises:
            ImportError: MuJoCo is not installed (message: the pip command).
            ValueError: Unknown bodies, a base that is not an ancestor of the
                tip, a ball or free joint on the chain, or no ``qd_max``.
        """
        tip_body = renamed_keyword(tip_link, tip_body, "tip_body", "tip_link")
        base_body = renamed_keyword(base_link, base_body, "base_body", "base_link")
        if tip_body is None:
            raise ValueError("tip_link: name the body of the task point")
        mj = import_mujoco()
        self._mj = mj
        self.model = model
        self._data = mj.MjData(model)
        self._tip = self._body(tip_body, "tip")
        self._base = self._body(base_body, "base") if base_body else 0
        joints: list[int] = []
        body = self._tip
        while body != self._base:
            if body == 0:
                raise ValueError(
                    f"bodies '{base_body}' and '{tip_body}' do not form a chain: "
                    f"'{tip_body}' does not descend from '{base_body}'"
                )
            first, count = int(model.body_jntadr[body]), int(model.body_jntnum[body])
            joints[:0] = range(first, first + count)
            body = int(model.body_parentid[body])
        if not joints:
            raise ValueError(f"no joint moves '{tip_body}' relative to the base")
        kinds = {int(mj.mjtJoint.mjJNT_HINGE), int(mj.mjtJoint.mjJNT_SLIDE)}
        for j in joints:
            if int(model.jnt_type[j]) not in kinds:
                raise ValueError(
                    f"joint '{model.joint(j).name}' is a ball or free joint on the chain "
                    f"to '{tip_body}', which lpik would have to move; only hinge and slide "
                    "joints are supported: pass base_link=<the arm's first body> to start "
                    "the chain after it"
                )
        self.n_joints = len(joints)
        self.joint_names = tuple(model.joint(j).name for j in joints)
        limited = np.array([bool(model.jnt_limited[j]) for j in joints])
        ranges = np.array([model.jnt_range[j] for j in joints], dtype=float)
        self.q_min = np.where(limited, ranges[:, 0], -np.inf)
        self.q_max = np.where(limited, ranges[:, 1], np.inf)
        self.qd_max = velocity_limits(qd_max, self.joint_names, "MuJoCo models keep none")
        self._qadr = np.array([model.jnt_qposadr[j] for j in joints])
        self._dadr = np.array([model.jnt_dofadr[j] for j in joints])
        self.qpos_index = self._qadr.copy()
        self.dof_index = self._dadr.copy()
        self.held_joints = tuple(
            model.joint(j).name for j in range(model.njnt) if j not in set(joints)
        )
        self._tool = as_transform(tool, what="tool")
        self.name = name or "mujoco"
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))

    def _body(self, name: str, role: str) -> int:
        index = self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_BODY, name)
        if index < 0:
            names = ", ".join(self.model.body(i).name for i in range(self.model.nbody))
            raise ValueError(f"{role} body '{name}' is not in the MuJoCo model; available: {names}")
        return int(index)

    @classmethod
    def from_urdf(
        cls,
        source: str | os.PathLike[str],
        tip_link: str,
        base_link: str | None = None,
        tool: ArrayLike | None = None,
    ) -> MujocoChain:
        """Compile a URDF with MuJoCo and wrap it, velocity limits from the URDF.

        Args:
            source: URDF file or XML text.
            tip_link: Link of the task point.
            base_link: Link whose frame is the world frame; MuJoCo's world
                (the URDF root's pose) when None.
            tool: Offset of the task point from the tip link.
        """
        mj = import_mujoco()
        text, _ = read_urdf_text(source)
        robot = parse_urdf(text)
        model = mj.MjModel.from_xml_string(kinematic_urdf(text))
        chain = cls(model, tip_link, base_link, tool, qd_max=np.inf, name=robot.name)
        velocity = []
        for joint_name in chain.joint_names:
            limit = robot.joint_map[joint_name].limit
            velocity.append(np.inf if limit is None or limit.velocity is None else limit.velocity)
        chain.qd_max = np.array(velocity, dtype=float)
        return chain

    def read_qpos(self, qpos: ArrayLike) -> FloatArray:
        """The chain's joint coordinates ``q`` (n,) out of a MuJoCo ``qpos`` (the whole model's).

        Raises:
            ValueError: For a ``qpos`` that is not the model's size.
        """
        qpos = np.asarray(qpos, dtype=float)
        if qpos.shape != (self.model.nq,):
            raise ValueError(f"qpos: expected shape ({self.model.nq},), got {qpos.shape}")
        return qpos[self._qadr].copy()

    def write_qpos(self, q: ArrayLike, qpos: Any) -> None:
        """Write the chain's ``q`` (n,) into a MuJoCo ``qpos`` in place; other joints stay.

        Raises:
            ValueError: For a ``q`` or ``qpos`` of the wrong size.
        """
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(f"q: expected shape ({self.n_joints},), got {q.shape}")
        if np.shape(qpos) != (self.model.nq,):
            raise ValueError(f"qpos: expected shape ({self.model.nq},), got {np.shape(qpos)}")
        qpos[self._qadr] = q

    def _update(self, q: ArrayLike, jacobian: bool) -> None:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(f"q: expected shape ({self.n_joints},), got {q.shape}")
        data = self._data
        data.qpos[:] = self.model.qpos0
        data.qpos[self._qadr] = q
        self._mj.mj_kinematics(self.model, data)
        if jacobian:
            self._mj.mj_comPos(self.model, data)

    def _world_pose(self, body: int) -> FloatArray:
        return _pose(self._data.xmat[body], self._data.xpos[body])

    def fk_jacobian(self, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """:meth:`fk` and :meth:`jacobian` at ``q`` in one pass of MuJoCo's kinematics."""
        self._update(q, jacobian=True)
        pose = self._world_pose(self._tip) @ self._tool
        self._mj.mj_jac(self.model, self._data, self._jacp, self._jacr, pose[:3, 3], self._tip)
        jac = np.vstack((self._jacp[:, self._dadr], self._jacr[:, self._dadr]))
        if self._base == 0:
            return pose, jac
        base = self._world_pose(self._base)
        rot_t = base[:3, :3].T
        return np.linalg.inv(base) @ pose, np.vstack((rot_t @ jac[:3], rot_t @ jac[3:]))

    def fk(self, q: ArrayLike) -> FloatArray:
        """Pose of the task frame in the base frame, shape (4, 4)."""
        self._update(q, jacobian=False)
        pose = self._world_pose(self._tip) @ self._tool
        return pose if self._base == 0 else np.linalg.inv(self._world_pose(self._base)) @ pose

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """World-aligned geometric Jacobian at the task point, (6, n): [v; omega]."""
        self._update(q, jacobian=True)
        point = (self._world_pose(self._tip) @ self._tool)[:3, 3]
        self._mj.mj_jac(self.model, self._data, self._jacp, self._jacr, point, self._tip)
        jac = np.vstack((self._jacp[:, self._dadr], self._jacr[:, self._dadr]))
        if self._base == 0:
            return jac
        rot_t = self._data.xmat[self._base].reshape(3, 3).T
        return np.vstack((rot_t @ jac[:3], rot_t @ jac[3:]))

    def position(self, q: ArrayLike) -> FloatArray:
        """Position of the task point in the base frame, shape (3,) [m]."""
        return self.fk(q)[:3, 3]

    def __repr__(self) -> str:
        return f"MujocoChain(name={self.name!r}, n_joints={self.n_joints})"
