"""The paper's experiments (sec. 4) as data: one scenario type, run on any robot.

Each scenario runs on the paper's planar 4-link arm (robot :data:`PLANAR`,
the default) or on a bundled 3-D arm (``robot="panda"``, ``"ur5e"``,
``"iiwa14"``). :meth:`Scenario.setup` turns a scenario and a robot into a
:class:`Setup`: the task model, start, target, command law, limits and
weights of the run, which :meth:`Setup.run` simulates and from which
:meth:`Setup.controller` builds the compiled controller that follows the
same joint path.

The planar runs (sec. 4, Fig. 2): links 1 m, relative joint angles, start
``q0 = (60, -30, -30, -30)`` deg (end effector at (3.2321, 0.8660) m), joint
velocity limit 1 rad/s, ``dt = 0.01`` s, ``v_max = 0.5`` m/s, ``M = I``,
``f = 0``, ``Lambda = 0``.

* ``pull-in``: pull the end effector in horizontally to (0.2, 0.8660) m with
  ``q1 <= 95`` deg (Figs. 3-6). On a 3-D arm (pose task): pull the tool in
  horizontally across the base's vertical axis, to :data:`PULL_BEYOND` past
  it, holding its orientation, until a joint end-stop (Panda: joint 2; iiwa
  14: joint A4) or, on the UR5e, the shoulder singularity stops it.
* ``edge-singularity``: move toward (4.5, 0.3) m, beyond the 4 m reach, into
  the edge singularity (Figs. 7-9). On a 3-D arm (position task): stretch the
  tool horizontally :data:`STRETCH_BEYOND` further out, beyond its reach.
* ``obstacle`` (beyond the paper; planar only): the pull-in with every joint
  within +-180 deg past a circular obstacle (:data:`OBSTACLE`) beside the path
  of the elbow, the collision avoidance the paper's abstract promises
  (:mod:`lpik.collision`; ``d_s`` 0.05 m, ``d_i`` 0.3 m, links 0.05 m thick).

3-D runs start at the arm's home configuration with its own end-stops and
velocity limits, ``dt = 0.01`` s and ``v_max = 0.25`` m/s.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from lpik.command import DEFAULT_W_MAX
from lpik.defaults import DEFAULT_MODE, DEFAULT_ON_STALL
from lpik.methods.registry import DEFAULT_METHOD
from lpik.naming import lookup
from lpik.paper.setup import Setup
from lpik.robots.arm import Arm, as_arm
from lpik.robots.base import TaskModel
from lpik.robots.planar import planar_arm
from lpik.robots.registry import robot_names
from lpik.types import FloatArray

if TYPE_CHECKING:
    from lpik.control.log import SimulationLog
    from lpik.control.simulate import Progress

#: The robot name of the paper's planar 4-link arm.
PLANAR = "planar"
#: The 3-D pull-in target lies this far past the base's vertical axis [m].
PULL_BEYOND = 0.3
#: The 3-D edge-singularity target lies this far beyond the start, away from the base axis [m].
STRETCH_BEYOND = 1.0
#: The ``obstacle`` scenario's circle: centre x, y and radius [m], and its scene's
#: safety and influence distances [m].
OBSTACLE = (0.8, 2.0, 0.15)
OBSTACLE_DISTANCES = (0.05, 0.3)


def _deg(*values: float) -> tuple[float, ...]:
    return tuple(float(v) for v in np.deg2rad(values))


@dataclass(frozen=True)
class PaperArm:
    """A scenario on the paper's planar arm (sec. 4, Fig. 2).

    Attributes:
        q_min: Lower end-stops [rad].
        q_max: Upper end-stops [rad].
        target: End-effector target (x, y) [m].
        link_lengths: Link lengths [m].
        q0: Start configuration [rad].
        qd_max: Joint velocity limit [rad/s].
        v_max: Largest commanded end-effector speed [m/s].
        obstacle: A circle (x, y, radius) [m] in the way, or None.
    """

    q_min: tuple[float, ...]
    q_max: tuple[float, ...]
    target: tuple[float, float]
    link_lengths: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)
    q0: tuple[float, ...] = _deg(60, -30, -30, -30)
    qd_max: float = 1.0
    v_max: float = 0.5
    obstacle: tuple[float, float, float] | None = None

    @property
    def reach(self) -> float:
        """Largest distance of the end effector from the base [m]."""
        return float(sum(self.link_lengths))


@dataclass(frozen=True)
class ArmRun:
    """A scenario on a bundled 3-D arm, from its home configuration.

    Attributes:
        task: ``"pose"`` or ``"position"``.
        reach: Signed distance [m] of the target from the start along the
            horizontal radial direction (negative pulls in); or None with
            ``through_axis`` set.
        through_axis: Put the target this far [m] past the base axis instead.
        v_max: Largest commanded linear speed [m/s].
    """

    task: str
    reach: float | None = None
    through_axis: float | None = None
    v_max: float = 0.25

    def __post_init__(self) -> None:
        if (self.reach is None) == (self.through_axis is None):
            raise ValueError("ArmRun: give exactly one of reach, through_axis")

    def target(self, model: TaskModel, q0: FloatArray) -> FloatArray:
        """The task value to move to: a 4 x 4 pose (pose task) or a position [m]."""
        pose = np.array(model.kinematics.fk(q0), dtype=float)  # type: ignore[attr-defined]
        position = pose[:3, 3]
        radial = np.array([position[0], position[1], 0.0])
        length = float(np.linalg.norm(radial))
        direction = radial / length if length > 1e-9 else np.array([1.0, 0.0, 0.0])
        if self.through_axis is not None:
            goal = position - (float(direction @ position) + self.through_axis) * direction
        else:
            goal = position + float(self.reach or 0.0) * direction
        if self.task == "position":
            return goal
        pose[:3, 3] = goal
        return pose


@dataclass(frozen=True, eq=False)
class Scenario:
    """One closed-loop experiment, on the paper's planar arm or a bundled 3-D arm.

    Attributes:
        name: Name used on the command line.
        description: One line saying what it shows.
        steps: Number of control steps.
        paper: The run on the paper's planar arm.
        arm: The same experiment on a bundled 3-D arm (None: planar only).
        dt: Control period [s].
        figures: The paper's figures the planar run reproduces.
    """

    name: str
    description: str
    steps: int
    paper: PaperArm
    arm: ArmRun | None
    dt: float = 0.01
    figures: str = ""

    def describe(self) -> str:
        """What the scenario does on the planar arm and on a 3-D arm, with its defaults."""
        paper, arm = self.paper, self.arm
        stops = ", ".join(f"{np.rad2deg(lo):g}..{np.rad2deg(hi):g}"
                          for lo, hi in zip(paper.q_min, paper.q_max))  # fmt: skip
        start = ", ".join(f"{np.rad2deg(v):g}" for v in paper.q0)
        planar = (
            f"{self.name}: {self.description}. Planar (--robot {PLANAR}): "
            f"{len(paper.link_lengths)} links of {paper.link_lengths[0]:g} m from q0 = ({start}) "
            f"deg to x, y = ({paper.target[0]:g}, {paper.target[1]:g}) m at "
            f"{paper.v_max:g} m/s; end-stops ({stops}) deg, velocity limits "
            f"{paper.qd_max:g} rad/s."
        )
        if paper.obstacle is not None:
            x, y, radius = paper.obstacle
            planar += f" A circle of radius {radius:g} m at ({x:g}, {y:g}) m is the obstacle."
        defaults = f" Default {self.steps} steps at dt = {self.dt:g} s."
        if arm is None:
            return planar + " The planar arm only." + defaults
        if arm.through_axis is not None:
            goal = f"{arm.through_axis:g} m past the base's vertical axis"
        else:
            goal = f"{arm.reach:g} m further out along the horizontal radial direction"
        held = "orientation held (pose task)" if arm.task == "pose" else "position task"
        return (
            f"{planar} 3-D (--robot NAME): from the arm's home configuration to a point {goal} "
            f"at {arm.v_max:g} m/s, {held}; the URDF's end-stops and velocity limits.{defaults}"
        )

    def setup(self, robot: str | Arm = PLANAR) -> Setup:
        """This scenario on ``robot`` (:data:`PLANAR`, a bundled robot's name or an ``Arm``).

        Raises:
            ValueError: For an unknown robot (the message lists the names).
        """
        if robot == PLANAR:
            arm = self.paper
            n = len(arm.link_lengths)
            model = planar_arm(
                arm.link_lengths, arm.q_min, arm.q_max, arm.qd_max, name=f"planar-{self.name}"
            )
            return Setup(
                name=self.name, robot=robot, model=model, q0=np.array(arm.q0),
                target=np.array([*arm.target, 0.0]), v_max=arm.v_max, w_max=DEFAULT_W_MAX,
                dt=self.dt, steps=self.steps,
                weights={"M": np.ones(n), "f": np.zeros(n), "Lambda": np.zeros(n)},
                scene=None if arm.obstacle is None else _circle_scene(arm.obstacle),
            )  # fmt: skip
        if not isinstance(robot, Arm):
            lookup(dict.fromkeys((PLANAR, *robot_names())), robot, "robot: unknown robot")
        if self.arm is None:
            raise ValueError(
                f"robot: scenario '{self.name}' runs on the '{PLANAR}' arm only; on a 3-D arm "
                "use lpik simulate reach --robot NAME --target X,Y,Z --scene SCENE.json"
            )
        arm = as_arm(robot)
        model, q0 = arm.task(self.arm.task), arm.home.copy()
        n = model.n_joints
        return Setup(
            name=f"{self.name} {arm.name}", robot=arm.name, model=model, q0=q0,
            target=self.arm.target(model, q0), v_max=self.arm.v_max, w_max=DEFAULT_W_MAX,
            dt=self.dt, steps=self.steps, weights={"M": np.ones(n), "f": np.zeros(n)},
        )  # fmt: skip

    def run(
        self,
        method: str = DEFAULT_METHOD,
        *,
        robot: str | Arm = PLANAR,
        lambda_bound: float | str | None = "auto",
        steps: int | None = None,
        dt: float | None = None,
        warm_start: bool = True,
        progress: Progress | None = None,
        on_stall: int | None = DEFAULT_ON_STALL,
        qdd_max: float | None = None,
        second_order: bool = True,
        mode: str = DEFAULT_MODE,
    ) -> SimulationLog:
        """Simulate this scenario on ``robot`` with one method (see :meth:`Setup.run`)."""
        return self.setup(robot).run(
            method, lambda_bound=lambda_bound, steps=steps, dt=dt, warm_start=warm_start,
            progress=progress, on_stall=on_stall, qdd_max=qdd_max, second_order=second_order,
            mode=mode,
        )  # fmt: skip


#: The scenarios by name.
SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario(
            "pull-in",
            "pull the end effector in horizontally until a joint end-stop (planar: joint 1 at "
            "95 deg, paper Figs. 3-6) or a singularity stops it",
            steps=400,
            paper=PaperArm(
                q_min=_deg(-180, -180, -180, -180),
                q_max=_deg(95, 180, 180, 180),
                target=(0.2, 0.8660),
            ),  # fmt: skip
            arm=ArmRun("pose", through_axis=PULL_BEYOND),
            figures="3, 4, 5, 6",
        ),
        Scenario(
            "edge-singularity",
            "reach beyond the workspace into the edge singularity (planar: paper Figs. 7-9)",
            steps=600,
            paper=PaperArm(
                q_min=_deg(-180, -180, -180, -180),
                q_max=_deg(180, 180, 180, 180),
                target=(4.5, 0.3),
            ),  # fmt: skip
            arm=ArmRun("position", reach=STRETCH_BEYOND),
            figures="7, 8, 9",
        ),
        Scenario(
            "obstacle",
            "the pull-in past a circular obstacle beside the elbow's path (planar only; "
            "beyond the paper: its abstract's collision avoidance)",
            steps=700,
            paper=PaperArm(
                q_min=_deg(-180, -180, -180, -180),
                q_max=_deg(180, 180, 180, 180),
                target=(0.2, 0.8660),
                obstacle=OBSTACLE,
            ),  # fmt: skip
            arm=None,
        ),
    )
}


def _circle_scene(circle: tuple[float, float, float]) -> Any:
    """A planar scene with one circle, named ``"obstacle"``, and :data:`OBSTACLE_DISTANCES`."""
    from lpik.collision import scene_from_dict

    x, y, radius = circle
    d_s, d_i = OBSTACLE_DISTANCES
    obstacle = {"name": "obstacle", "type": "sphere", "center": [x, y], "radius": radius}
    return scene_from_dict(
        {"obstacles": [obstacle], "safety_distance": d_s, "influence_distance": d_i}
    )


def scenario_names() -> Sequence[str]:
    """Names of the available scenarios."""
    return tuple(SCENARIOS)


def get_scenario(name: str) -> Scenario:
    """The scenario called ``name``.

    Raises:
        ValueError: For an unknown name; the message lists the available names.
    """
    return lookup(SCENARIOS, name, "scenario: unknown scenario")
