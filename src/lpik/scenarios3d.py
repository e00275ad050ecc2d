"""The paper's two experiments on the bundled 3-D arms, as data.

The planar scenarios of :mod:`lpik.scenarios` carried over to real arms
(``lpik simulate SCENARIO --robot NAME``). Every arm starts at its home
configuration (:func:`lpik.robots.registry.home_configuration`) with its own
end-stops and velocity limits; ``dt = 0.01`` s; command law
:class:`~lpik.simulate.ClampedTarget` at ``v_max = 0.25`` m/s; criterion
``M = I``, ``f = 0``, ``Lambda = 0``.

* ``pull-in`` (pose task, 6 rows): pull the tool in horizontally along the
  line through its start and the base's vertical axis, toward a point
  :data:`PULL_BEYOND` past that axis, holding the tool's orientation. A joint
  end-stop stops it (Panda: joint 2; iiwa 14: joint A4); on the UR5e, whose
  shoulder offset keeps the wrist off the base axis, the shoulder singularity
  does (p -> 0 with the pan joint at its velocity limit).
* ``edge-singularity`` (position task, 3 rows): stretch the tool horizontally
  away from the base axis toward a point :data:`STRETCH_BEYOND` further out,
  beyond the reach: the arm stretches into the edge singularity and p -> 0.

The CSV of a run has the columns ``t, q1..qn, x, y, z, p, lam1..lamm``
(:meth:`lpik.simulate.SimulationLog.to_csv`), with m = 6 or 3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.limits import Limit, standard_limits
from lpik.naming import lookup
from lpik.robots.registry import home_configuration, load_robot
from lpik.robots.tasks import OrientationTask, PoseTask, PositionTask
from lpik.simulate import ClampedTarget, Progress, SimulationLog, simulate

FloatArray = NDArray[np.float64]

#: The pull-in target lies this far past the base's vertical axis [m].
PULL_BEYOND = 0.3
#: The edge-singularity target lies this far beyond the start, away from the base axis [m].
STRETCH_BEYOND = 1.0


def _horizontal_direction(position: FloatArray) -> FloatArray:
    """Unit vector from the base's vertical axis to ``position``, in the x-y plane."""
    radial = np.array([position[0], position[1], 0.0])
    length = float(np.linalg.norm(radial))
    return radial / length if length > 1e-9 else np.array([1.0, 0.0, 0.0])


@dataclass(frozen=True, eq=False)
class Scenario3D:
    """One closed-loop experiment on a bundled arm.

    Attributes:
        name: Name used on the command line (as the planar scenario's).
        description: One line saying what it shows.
        task: ``"pose"`` or ``"position"``.
        reach: Signed distance [m] of the target from the start along the
            horizontal radial direction: negative pulls in, positive stretches;
            or None with ``through_axis`` set.
        through_axis: Put the target this far [m] past the base axis instead.
        v_max: Largest commanded task speed [m/s].
        dt: Control period [s].
        steps: Number of control steps.
        weights: ``M``, ``f``, ``Lambda`` of the criterion (eq. 3, sec. 3.1).
    """

    name: str
    description: str
    task: str
    reach: float | None = None
    through_axis: float | None = None
    v_max: float = 0.25
    dt: float = 0.01
    steps: int = 400
    weights: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if (self.reach is None) == (self.through_axis is None):
            raise ValueError(f"scenario {self.name!r}: give exactly one of reach, through_axis")

    def model(self, robot: str) -> PositionTask | OrientationTask | PoseTask:
        """The bundled arm ``robot`` with this scenario's task."""
        return load_robot(robot, task=self.task)

    def start(self, robot: str) -> FloatArray:
        """Start configuration: the arm's home configuration [rad]."""
        return home_configuration(robot)

    def target(self, robot: str) -> FloatArray:
        """The task value to move to: a 4 x 4 pose (pose task) or a position [m]."""
        model = self.model(robot)
        q0 = self.start(robot)
        pose = np.array(model.kinematics.fk(q0), dtype=float)
        position = pose[:3, 3]
        direction = _horizontal_direction(position)
        if self.through_axis is not None:
            radial = float(direction @ position)
            goal = position - (radial + self.through_axis) * direction
        else:
            goal = position + float(self.reach or 0.0) * direction
        if self.task == "position":
            return goal
        pose[:3, 3] = goal
        return pose

    def limits(self, robot: str, lambda_bound: float | None = None) -> list[Limit]:
        """End-stops, velocity limits and, when given, ``|lam_i| <= lambda_bound``."""
        return standard_limits(self.model(robot), lambda_bound=lambda_bound)

    def run(
        self,
        robot: str = "panda",
        method: str = "lp2",
        *,
        lambda_bound: float | None = None,
        steps: int | None = None,
        dt: float | None = None,
        warm_start: bool = True,
        progress: Progress | None = None,
    ) -> SimulationLog:
        """Simulate this scenario on one bundled arm with one method.

        Args:
            robot: Bundled robot name (:func:`lpik.robots.registry.robot_names`).
            method: One of :data:`lpik.methods.ALL_METHODS`.
            lambda_bound: Symmetric bound on every multiplier (sec. 3.2); ``None``: unbounded.
            steps: Number of steps; default the scenario's.
            dt: Control period [s]; default the scenario's.
            warm_start: Reuse one HiGHS instance across steps.
            progress: Called after every step with ``(done, steps)``.

        Raises:
            ValueError: For an unknown robot or method, or a bad step count,
                period or bound.
        """
        model = self.model(robot)
        label = f"{self.name} {robot}"
        if lambda_bound is not None:
            label += f" |lam|<={lambda_bound:g}"
        weights = {"M": np.ones(model.n_joints), "f": np.zeros(model.n_joints)}
        weights.update(self.weights)
        return simulate(
            model,
            ClampedTarget(self.target(robot), self.v_max),
            self.start(robot),
            self.steps if steps is None else steps,
            method=method,
            dt=self.dt if dt is None else dt,
            limits=self.limits(robot, lambda_bound),
            weights=weights,
            name=label,
            warm_start=warm_start,
            progress=progress,
        )


#: The 3-D scenarios by name (the same names as the planar ones).
SCENARIOS_3D: dict[str, Scenario3D] = {
    s.name: s
    for s in (
        Scenario3D(
            "pull-in",
            "pull the tool in horizontally across the base axis, holding its orientation, "
            "until a joint limit (or the shoulder singularity) stops it",
            task="pose",
            through_axis=PULL_BEYOND,
            steps=400,
        ),
        Scenario3D(
            "edge-singularity",
            "stretch the tool horizontally beyond its reach into the edge singularity",
            task="position",
            reach=STRETCH_BEYOND,
            steps=600,
        ),
    )
}


def scenario_3d_names() -> Sequence[str]:
    """Names of the 3-D scenarios."""
    return tuple(SCENARIOS_3D)


def get_scenario_3d(name: str) -> Scenario3D:
    """The 3-D scenario called ``name``.

    Raises:
        ValueError: For an unknown name; the message lists the available names.
    """
    return lookup(SCENARIOS_3D, name, "scenario: unknown 3-D scenario")
