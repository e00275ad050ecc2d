"""Bundled robot arms, selectable by name.

The kinematics-only URDFs live in ``lpik/robots/data/<name>/`` with a NOTICE
(upstream repository, licence, what was changed) and the licence text. They
were expanded from the upstream xacro/yaml files; see each file's header.

==========  ==  =================================================  ===============
name        n   upstream                                           tip link
==========  ==  =================================================  ===============
panda       7   frankaemika/franka_ros (Apache-2.0)                panda_hand_tcp
ur5e        6   UniversalRobots/Universal_Robots_ROS2_Description  tool0
                (BSD-3-Clause)
iiwa14      7   ros-industrial/kuka_experimental (Apache-2.0)      tool0
==========  ==  =================================================  ===============
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from lpik.naming import lookup
from lpik.robots.chain import SerialChain
from lpik.robots.tasks import OrientationTask, PoseTask, PositionTask, make_task
from lpik.robots.urdf import load_urdf
from lpik.types import FloatArray

_PI = math.pi
DATA_DIR = Path(__file__).resolve().parent / "data"


@dataclass(frozen=True)
class RobotSpec:
    """A bundled arm.

    Attributes:
        name: Name used by :func:`load_robot` and ``--robot``.
        description: One line for listings.
        urdf: File name inside ``lpik/robots/data/<name>/``.
        base_link: Link whose frame is the world frame.
        tip_link: Default link of the task point.
        home: A comfortable configuration away from limits and singularities
            [rad], used as the start of the 3-D scenarios.
    """

    name: str
    description: str
    urdf: str
    base_link: str
    tip_link: str
    home: tuple[float, ...]


_SPECS = (
    RobotSpec(
        "panda",
        "Franka Emika Panda with Franka Hand, task point at the hand TCP",
        "panda.urdf",
        "panda_link0",
        "panda_hand_tcp",
        (0.0, -_PI / 4, 0.0, -3 * _PI / 4, 0.0, _PI / 2, _PI / 4),
    ),
    RobotSpec(
        "ur5e",
        "Universal Robots UR5e, task point at tool0 (flange)",
        "ur5e.urdf",
        "base_link",
        "tool0",
        (0.0, -_PI / 2, _PI / 2, -_PI / 2, -_PI / 2, 0.0),
    ),
    RobotSpec(
        "iiwa14",
        "KUKA LBR iiwa 14 R820, task point at tool0 (flange)",
        "iiwa14.urdf",
        "base_link",
        "tool0",
        (0.0, _PI / 6, 0.0, -_PI / 3, 0.0, _PI / 3, 0.0),
    ),
)
ROBOTS: dict[str, RobotSpec] = {spec.name: spec for spec in _SPECS}


@dataclass(frozen=True)
class RobotInfo:
    """What ``lpik robots`` lists about a bundled arm.

    Attributes:
        name: Robot name.
        description: One line.
        n_joints: Number of joints.
        joint_names: Joint names in chain order.
        q_min: Lower end-stops [rad].
        q_max: Upper end-stops [rad].
        qd_max: Velocity limits [rad/s].
        tip_link: Default task link.
        urdf: Path of the URDF file used.
    """

    name: str
    description: str
    n_joints: int
    joint_names: tuple[str, ...]
    q_min: tuple[float, ...]
    q_max: tuple[float, ...]
    qd_max: tuple[float, ...]
    tip_link: str
    urdf: str


def robot_names() -> tuple[str, ...]:
    """Names of the bundled robots."""
    return tuple(ROBOTS)


def get_spec(name: str) -> RobotSpec:
    """The bundled robot called ``name``.

    Raises:
        ValueError: If there is none; the message lists the available names.
    """
    return lookup(ROBOTS, name, "unknown robot")


def urdf_path(name: str) -> Path:
    """Path of a bundled robot's URDF file."""
    spec = get_spec(name)
    return DATA_DIR / spec.name / spec.urdf


def home_configuration(name: str) -> FloatArray:
    """The bundled robot's home configuration, shape (n,) [rad]."""
    return np.array(get_spec(name).home, dtype=float)


def load_chain(
    name: str, tip_link: str | None = None, tool: ArrayLike | None = None
) -> SerialChain:
    """Kinematic chain of a bundled robot.

    Args:
        name: Robot name (see :func:`robot_names`).
        tip_link: Link of the task point; the robot's default when None.
        tool: Offset of the task point from the tip link: 4 x 4, xyz (3,) [m]
            or xyz + rpy (6,) [m, rad].

    Raises:
        ValueError: Unknown robot or link.
    """
    spec = get_spec(name)
    return load_urdf(
        urdf_path(name),
        tip_link=tip_link or spec.tip_link,
        base_link=spec.base_link,
        tool=tool,
        name=spec.name,
    )


def load_robot(
    name: str,
    task: str = "pose",
    mask: str | Sequence[bool] | None = None,
    tip_link: str | None = None,
    tool: ArrayLike | None = None,
) -> PositionTask | OrientationTask | PoseTask:
    """Task model of a bundled robot, ready for the methods and the simulation.

    Args:
        name: Robot name (see :func:`robot_names`).
        task: ``"position"`` (3 rows), ``"orientation"`` (3) or ``"pose"`` (6).
        mask: Rows to keep, e.g. ``"xyz rz"`` or ``(1, 1, 1, 0, 0, 1)``.
        tip_link: Link of the task point; the robot's default when None.
        tool: Offset of the task point from the tip link.

    Returns:
        A :class:`~lpik.robots.base.TaskModel` named after the robot.

    Raises:
        ValueError: Unknown robot, task, link or mask.
    """
    return make_task(load_chain(name, tip_link, tool), task=task, mask=mask, name=name)


def list_robots() -> list[RobotInfo]:
    """Facts about every bundled robot, in registry order."""
    out = []
    for spec in _SPECS:
        chain = load_chain(spec.name)
        out.append(
            RobotInfo(
                name=spec.name,
                description=spec.description,
                n_joints=chain.n_joints,
                joint_names=chain.joint_names,
                q_min=tuple(float(v) for v in chain.q_min),
                q_max=tuple(float(v) for v in chain.q_max),
                qd_max=tuple(float(v) for v in chain.qd_max),
                tip_link=spec.tip_link,
                urdf=str(urdf_path(spec.name)),
            )
        )
    return out
