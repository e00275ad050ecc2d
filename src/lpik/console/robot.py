"""What the console drives: a robot model, its start, its drawing capsules and its scene.

:func:`console_robot` builds a :class:`ConsoleRobot` for the paper's planar arm
(the ``pull-in`` scenario's arm of :mod:`lpik.paper.scenarios`: links 1 m,
``q1 <= 95`` deg, joint velocity limit 1 rad/s, period 0.01 s, ``v_max`` 0.5 m/s)
or for a 3-D arm, bundled or read from a URDF (:class:`lpik.robots.arm.Arm`;
pose task from its start configuration, period 0.001 s, the command law's
default speeds), optionally with a scene of obstacles.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lpik.collision import LinkCapsule, Scene, default_capsules, frame_capsules, load_scene
from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX
from lpik.paper.scenarios import PLANAR, get_scenario
from lpik.robots.arm import Arm, as_arm
from lpik.robots.base import TaskModel
from lpik.types import FloatArray

#: Control period of the 3-D arms [s] (1 kHz).
ARM_DT = 0.001
#: Radius [m] of the drawn links of an arm whose collision radii are unknown (drawing only).
DRAWING_RADIUS = 0.04


@dataclass(frozen=True, eq=False)
class ConsoleRobot:
    """One robot as the console drives and draws it.

    Attributes:
        name: The robot's name (``"planar"`` for the paper's arm).
        model: The task model the controller steps.
        q0: Start (and reset) configuration [rad].
        dt: Control period [s].
        v_max: Default largest commanded linear speed [m/s].
        w_max: Default largest commanded angular speed [rad/s].
        capsules: The links' capsules (collision model, or drawing capsules).
        scene: The obstacles, or None.
        planar: Whether the arm moves in the x-y plane (position task, no orientation).
    """

    name: str
    model: TaskModel
    q0: FloatArray
    dt: float
    v_max: float
    w_max: float
    capsules: tuple[LinkCapsule, ...]
    scene: Scene | None = None
    planar: bool = False

    @property
    def orientation(self) -> bool:
        """Whether the task includes the tool's orientation (a pose target)."""
        return self.model.task_dim > 3

    def home_target(self) -> FloatArray:
        """The task value at ``q0``: a 4 x 4 pose, or an xyz point (z = 0 in the plane)."""
        pose = np.asarray(self.model.kinematics.fk(self.q0), dtype=float)  # type: ignore[attr-defined]
        return pose.copy() if self.orientation else pose[:3, 3].copy()

    def tool_pose(self, q: FloatArray) -> FloatArray:
        """The tool frame at ``q``, 4 x 4."""
        return np.asarray(self.model.kinematics.fk(q), dtype=float)  # type: ignore[attr-defined]


def _capsules(model: Any) -> tuple[LinkCapsule, ...]:
    try:
        return default_capsules(model)
    except ValueError:  # no collision radii known: thin drawing capsules
        return frame_capsules(model, DRAWING_RADIUS)


def console_robot(
    name: str | Arm = PLANAR, scene: str | Path | Scene | None = None
) -> ConsoleRobot:
    """The robot ``name`` (``"planar"``, a bundled arm or an ``Arm``), with ``scene`` when given.

    Args:
        name: ``"planar"`` (the paper's arm), a name of
            :func:`lpik.robots.registry.robot_names` or an :class:`~lpik.robots.arm.Arm`
            (a URDF's chain and its start).
        scene: A scene JSON file, a :class:`~lpik.collision.Scene`, or None.

    Raises:
        ValueError: For an unknown robot, a bad scene, or one that does not fit the robot.
    """
    if isinstance(scene, str | Path):
        scene = load_scene(scene)
    planar = name == PLANAR
    if planar:
        label, setup = PLANAR, get_scenario("pull-in").setup(PLANAR)
        model, q0, dt, v_max, w_max = setup.model, setup.q0, setup.dt, setup.v_max, setup.w_max
    else:
        arm = as_arm(name)
        label, model = arm.name, arm.task("pose")
        q0, dt, v_max, w_max = arm.home, ARM_DT, DEFAULT_V_MAX, DEFAULT_W_MAX
    if scene is not None and (scene.dims == 2) != planar:
        want = "a 2-D scene" if planar else "a 3-D scene"
        raise ValueError(f"scene: the {label} arm needs {want}, got a {scene.dims}-D one")
    return ConsoleRobot(
        name=label,
        model=model,
        q0=np.array(q0, dtype=float),
        dt=float(dt),
        v_max=float(v_max),
        w_max=float(w_max),
        capsules=_capsules(model),
        scene=scene,
        planar=planar,
    )
