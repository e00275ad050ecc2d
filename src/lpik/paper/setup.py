"""One scenario on one robot as a value: :class:`Setup`.

:meth:`lpik.paper.scenarios.Scenario.setup` builds it; :mod:`lpik.paper.scenarios`
re-exports it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from lpik.command import ClampedTarget
from lpik.defaults import DEFAULT_MODE, DEFAULT_ON_STALL
from lpik.limits import AccelerationLimits, Limit, standard_limits
from lpik.methods.registry import DEFAULT_METHOD
from lpik.robots.base import TaskModel
from lpik.types import FloatArray

if TYPE_CHECKING:
    from lpik.control.controller import Lp2Controller
    from lpik.control.log import SimulationLog
    from lpik.control.simulate import Progress


#: The paper's runs' settings: the command law of sec. 4 alone, without lpik's
#: second-order term (:func:`lpik.command.second_order_term`), and the paper's strict
#: steps, which keep the commanded direction or stand still (``on_stall=None``: no
#: progress step, :mod:`lpik.methods.progress`). Every run of the paper names it, so
#: that ``lpik reproduce`` gives the paper's numbers whatever lpik's defaults are.
PAPER_COMMAND: dict[str, Any] = {"second_order": False, "on_stall": None}


@dataclass(frozen=True, eq=False)
class Setup:
    """One scenario on one robot: everything a run needs.

    Attributes:
        name: Name of the run (scenario, and robot when not planar).
        robot: The robot's name.
        model: The task model.
        q0: Start configuration [rad].
        target: Task value to move to (xyz point or 4 x 4 pose).
        v_max: Largest commanded linear speed [m/s].
        w_max: Largest commanded angular speed [rad/s].
        dt: Control period [s].
        steps: Number of control steps.
        weights: ``M``, ``f``, ``Lambda`` of the criterion (eq. 3, sec. 3.1).
        scene: The obstacles of the run (:class:`lpik.collision.Scene`), or None.
    """

    name: str
    robot: str
    model: TaskModel
    q0: FloatArray
    target: FloatArray
    v_max: float
    w_max: float
    dt: float
    steps: int
    weights: Mapping[str, Any] = field(default_factory=dict)
    scene: Any = None

    def command(self) -> ClampedTarget:
        """The command law: toward ``target`` at most ``v_max`` and ``w_max`` fast."""
        return ClampedTarget(self.target, self.v_max, self.w_max)

    def limits(
        self, lambda_bound: float | str | None = "auto", qdd_max: float | None = None
    ) -> list[Limit]:
        """End-stops, velocity limits and, when given, multiplier and acceleration limits.

        ``|lam_i| <= lambda_bound`` (sec. 3.2), ``|qdd_i| <= qdd_max`` [rad/s^2].
        """
        limits = standard_limits(self.model, lambda_bound=lambda_bound)
        return limits if qdd_max is None else [*limits, AccelerationLimits(qdd_max)]

    def run(
        self,
        method: str = DEFAULT_METHOD,
        *,
        lambda_bound: float | str | None = "auto",
        steps: int | None = None,
        dt: float | None = None,
        warm_start: bool = True,
        progress: Progress | None = None,
        on_stall: int | None = DEFAULT_ON_STALL,
        qdd_max: float | None = None,
        scene: Any = None,
        second_order: bool = True,
        mode: str = DEFAULT_MODE,
    ) -> SimulationLog:
        """Simulate this setup with one method (:func:`lpik.control.simulate.simulate`).

        Args:
            method: A name from :data:`lpik.methods.METHODS`.
            lambda_bound: ``"auto"`` (default): the automatic bound
                (:mod:`lpik.methods.autobound`); a number: symmetric bound on every
                multiplier (sec. 3.2); ``None``: unbounded (the paper's runs).
            qdd_max: Acceleration limit of every joint [rad/s^2]; ``None``: none.
            second_order: Take off each command the last step's second-order term
                (the default of every way to take a step); ``False``: the paper's
                command law alone (:data:`PAPER_COMMAND`).
            steps: Number of steps; default the scenario's.
            dt: Control period [s]; default the scenario's.
            warm_start: Reuse one HiGHS instance across steps.
            progress: Called after every step with ``(done, steps)``.
            on_stall: The progress step after this many stalled steps in a row,
                opt-in (``1`` turns it on); ``None``, the default
                (:data:`lpik.defaults.DEFAULT_ON_STALL`): never (the paper's runs,
                :data:`PAPER_COMMAND`).
            mode: ``"exact"`` (default) or ``"progress"`` (:data:`lpik.defaults.MODES`).
            scene: Obstacles to avoid (a :class:`~lpik.collision.Scene` or
                :class:`~lpik.collision.CollisionAvoidance`); default the setup's.

        Raises:
            ValueError: For a bad method, step count, period or bound.
        """
        from lpik.control.simulate import simulate

        label = self.name if lambda_bound in (None, "auto") else (
            f"{self.name} |lam|<={lambda_bound:g}")  # fmt: skip
        return simulate(
            self.model,
            self.command(),
            self.q0,
            self.steps if steps is None else steps,
            method=method,
            dt=self.dt if dt is None else dt,
            limits=self.limits(lambda_bound, qdd_max),
            lambda_bound=None,  # (the limits hold lambda_bound's)
            weights=self.weights,
            name=label,
            warm_start=warm_start,
            progress=progress,
            on_stall=on_stall,
            scene=self.scene if scene is None else scene,
            second_order=second_order,
            mode=mode,
        )

    def controller(
        self,
        lambda_bound: float | str | None = "auto",
        *,
        saturate: bool = True,
        second_order: bool = True,
        on_stall: int | None = DEFAULT_ON_STALL,
        mode: str = DEFAULT_MODE,
    ) -> Lp2Controller:
        """The compiled LP2 controller with this setup's limits, command law and weights.

        ``saturate``: LP2 with saturation in the null space (``lp2s``, the default);
        ``second_order``, ``on_stall``, ``mode``: as for :meth:`run`
        (:data:`PAPER_COMMAND`: the paper's).
        """
        from lpik.control.controller import Lp2Controller

        return Lp2Controller(
            self.model, dt=self.dt, v_max=self.v_max, w_max=self.w_max,
            lambda_bound=lambda_bound, saturate=saturate, second_order=second_order,
            on_stall=on_stall, mode=mode, **dict(self.weights),
        )  # fmt: skip
