"""The paper's experiments (sec. 4) as data, selectable by name.

Both scenarios use the planar 4-link arm of Fig. 2 (links 1 m, relative joint
angles) starting at ``q0 = (60, -30, -30, -30)`` deg, so that the end effector
starts at (3.2321, 0.8660) m; joint velocity limit 1 rad/s, ``dt = 0.01`` s,
command law :class:`~lpik.simulate.ClampedTarget` with ``v_max = 0.5`` m/s and
the criterion ``M = I``, ``f = 0``, ``Lambda = 0`` (DESIGN.md, "Scenarios").

* ``pull-in``: pull the end effector in horizontally to (0.2, 0.8660) m with
  joint 1 limited to ``q1 <= 95`` deg (Figs. 3-6).
* ``edge-singularity``: move toward (4.5, 0.3) m, beyond the 4 m reach, so that
  the arm stretches into the edge singularity (Figs. 7-9).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from lpik.limits import Limit, standard_limits
from lpik.naming import lookup
from lpik.robots.planar import PlanarArm

if TYPE_CHECKING:  # lpik.simulate imports the methods (scipy, HiGHS): only when a run starts
    from lpik.simulate import ClampedTarget, Progress, SimulationLog

FloatArray = NDArray[np.float64]


def _deg(*values: float) -> tuple[float, ...]:
    return tuple(float(v) for v in np.deg2rad(values))


@dataclass(frozen=True, eq=False)
class Scenario:
    """One closed-loop experiment: robot, start, limits, command and criterion.

    Attributes:
        name: Name used on the command line.
        description: One line saying what it shows.
        link_lengths: Link lengths of the planar arm [m].
        q0: Start configuration [rad].
        q_min: Lower end-stops [rad].
        q_max: Upper end-stops [rad].
        qd_max: Joint velocity limits [rad/s].
        target: End-effector target (x, y) [m].
        v_max: Largest commanded end-effector speed [m/s].
        dt: Control period [s].
        steps: Number of control steps.
        weights: ``M``, ``f``, ``Lambda`` (``q_ref``) of the criterion (eq. 3, sec. 3.1);
            missing ones take the defaults of :class:`~lpik.problem.Problem`.
        figures: The paper's figures this scenario reproduces.
    """

    name: str
    description: str
    link_lengths: tuple[float, ...]
    q0: tuple[float, ...]
    q_min: tuple[float, ...]
    q_max: tuple[float, ...]
    qd_max: tuple[float, ...]
    target: tuple[float, ...]
    v_max: float
    dt: float
    steps: int
    weights: dict[str, Any] = field(default_factory=dict)
    figures: str = ""

    def model(self) -> PlanarArm:
        """The planar arm with this scenario's end-stops and velocity limits."""
        return PlanarArm(
            self.link_lengths, self.q_min, self.q_max, self.qd_max, name=f"planar-{self.name}"
        )

    def command(self) -> ClampedTarget:
        """The command law: toward ``target`` at most ``v_max`` fast."""
        from lpik.simulate import ClampedTarget

        return ClampedTarget(np.array(self.target), self.v_max)

    def limits(self, lambda_bound: float | None = None) -> list[Limit]:
        """End-stops, velocity limits and, when given, ``|lam_i| <= lambda_bound`` (sec. 3.2)."""
        return standard_limits(self.model(), lambda_bound=lambda_bound)

    def run(
        self,
        method: str = "lp2",
        *,
        lambda_bound: float | None = None,
        steps: int | None = None,
        dt: float | None = None,
        warm_start: bool = True,
        progress: Progress | None = None,
    ) -> SimulationLog:
        """Simulate this scenario with one method.

        Args:
            method: One of :data:`lpik.methods.ALL_METHODS`.
            lambda_bound: Symmetric bound on every multiplier (sec. 3.2); ``None``: unbounded.
            steps: Number of steps; default the scenario's.
            dt: Control period [s]; default the scenario's.
            warm_start: Reuse one HiGHS instance across steps (see :func:`~lpik.simulate.simulate`).
            progress: Called after every step with ``(done, steps)``.

        Raises:
            ValueError: For a bad method, step count, period or bound.
        """
        from lpik.simulate import simulate

        label = self.name if lambda_bound is None else f"{self.name} |lam|<={lambda_bound:g}"
        return simulate(
            self.model(),
            self.command(),
            self.q0,
            self.steps if steps is None else steps,
            method=method,
            dt=self.dt if dt is None else dt,
            limits=self.limits(lambda_bound),
            weights=self.weights,
            name=label,
            warm_start=warm_start,
            progress=progress,
        )


def _paper_arm(name: str, description: str, **kw: Any) -> Scenario:
    """The paper's 4-link arm (Fig. 2) with the settings both scenarios share."""
    return Scenario(
        name=name,
        description=description,
        link_lengths=(1.0, 1.0, 1.0, 1.0),
        q0=_deg(60, -30, -30, -30),
        qd_max=(1.0, 1.0, 1.0, 1.0),
        v_max=0.5,
        dt=0.01,
        weights={"M": np.ones(4), "f": np.zeros(4), "Lambda": np.zeros(4)},
        **kw,
    )


#: The scenarios by name.
SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        _paper_arm(
            "pull-in",
            "pull the end effector in horizontally; joint 1 stops at 95 deg (paper Figs. 3-6)",
            q_min=_deg(-180, -180, -180, -180),
            q_max=_deg(95, 180, 180, 180),
            target=(0.2, 0.8660),
            steps=400,
            figures="3, 4, 5, 6",
        ),
        _paper_arm(
            "edge-singularity",
            "reach beyond the 4 m workspace into the edge singularity (paper Figs. 7-9)",
            q_min=_deg(-180, -180, -180, -180),
            q_max=_deg(180, 180, 180, 180),
            target=(4.5, 0.3),
            steps=600,
            figures="7, 8, 9",
        ),
    )
}


def scenario_names() -> Sequence[str]:
    """Names of the available scenarios."""
    return tuple(SCENARIOS)


def get_scenario(name: str) -> Scenario:
    """The scenario called ``name``.

    Raises:
        ValueError: For an unknown name; the message lists the available names.
    """
    return lookup(SCENARIOS, name, "scenario: unknown scenario")
