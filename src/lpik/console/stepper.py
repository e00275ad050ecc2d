"""The operator's settings and the one control step they select.

:class:`Settings` holds what the page can change (method, ``v_max``, ``w_max``,
the multiplier bound, acceleration limits); :func:`make_stepper` turns a robot
and its settings into a function ``step(q, target, q_prev) -> Result``:

* ``lp2`` and ``lp2s`` run the compiled controller
  (:class:`~lpik.control.controller.Lp2Controller`, or
  :class:`~lpik.control.avoiding_controller.AvoidingLp2Controller` with a scene),
  the path a 1 kHz loop is made for;
* every other method of :data:`lpik.methods.registry.METHODS` runs the numpy
  engine, :class:`lpik.control.stepper.Stepper` (the stages ``simulate`` runs:
  build the problem, solve it, clamp a classical step to the end-stops),
  slower than real time at 1 kHz for the LP methods on some machines: the
  console shows the real-time factor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX
from lpik.console.robot import ConsoleRobot
from lpik.control.stepper import Stepper as PipelineStepper
from lpik.defaults import DEFAULT_ON_STALL
from lpik.limits import MultiplierBounds, multiplier_limit
from lpik.methods.registry import DEFAULT_METHOD, get_method, methods_with
from lpik.result import Result
from lpik.types import FloatArray

#: A control step: ``step(q, target, q_prev) -> Result``.
Stepper = Callable[[FloatArray, Any, "FloatArray | None"], Result]
#: The methods the compiled controller runs.
COMPILED = ("lp2", "lp2s")
#: Ranges the page offers for the speeds [m/s], [rad/s] and the acceleration limit [rad/s^2].
V_RANGE, W_RANGE, QDD_RANGE = (0.01, 2.0), (0.05, 4.0), (0.1, 1000.0)
#: Range of the multiplier bound.
LAMBDA_RANGE = (1e-3, 1e6)


@dataclass(frozen=True)
class Settings:
    """What the operator can change while the controller runs.

    Attributes:
        method: A name of :data:`lpik.methods.registry.METHODS`.
        v_max: Largest commanded linear speed [m/s].
        w_max: Largest commanded angular speed [rad/s].
        lambda_bound: ``"auto"`` (LP2's default: bounds chosen per step where the arm
            would race towards a singularity), a bound ``B`` on every multiplier
            (``|lam_i| <= B``, sec. 3.2, only for methods that bound their
            multipliers) or None (unbounded, the paper's LP2). Methods without
            multipliers ignore ``"auto"``.
        qdd_max: Acceleration limit of every joint [rad/s^2], or None (off).
        on_stall: The stall stage (:mod:`lpik.methods.progress`): the progress step
            after this many stalled steps in a row; None: the paper's strict steps.
    """

    method: str = DEFAULT_METHOD
    v_max: float = DEFAULT_V_MAX
    w_max: float = DEFAULT_W_MAX
    lambda_bound: float | str | None = "auto"
    qdd_max: float | None = None
    on_stall: int | None = DEFAULT_ON_STALL

    def __post_init__(self) -> None:
        spec = get_method(self.method)
        for key, (low, high) in (("v_max", V_RANGE), ("w_max", W_RANGE)):
            _in_range(key, getattr(self, key), low, high)
        bound = multiplier_limit(self.lambda_bound)
        if isinstance(bound, MultiplierBounds):  # a number: within the page's range
            _in_range("lambda_bound", self.lambda_bound, *LAMBDA_RANGE)
            if not spec.bounds_multipliers:
                bounded = methods_with("bounds_multipliers")
                raise ValueError(
                    f"lambda_bound: method {self.method!r} does not bound its multipliers "
                    f"(only {bounded} do)"
                )
        if self.qdd_max is not None:
            _in_range("qdd_max", self.qdd_max, *QDD_RANGE)

    def changed(self, **values: Any) -> Settings:
        """A copy with ``values`` changed (checked as a new one)."""
        return replace(self, **values)


def _in_range(key: str, value: Any, low: float, high: float) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and low <= value <= high):
        raise ValueError(f"{key}: must be a number in [{low:g}, {high:g}], got {value!r}")


def make_stepper(robot: ConsoleRobot, settings: Settings) -> Stepper:
    """The control step that ``settings`` select for ``robot``.

    ``lp2`` and ``lp2s`` run the compiled engine, every other method the
    numpy engine (:class:`lpik.control.stepper.Stepper`): the same stages and
    defaults either way.

    Raises:
        ValueError: For settings or a scene the robot cannot take.
    """
    options: dict[str, Any] = {
        "v_max": settings.v_max,
        "w_max": settings.w_max,
        "lambda_bound": settings.lambda_bound,
        "qdd_max": settings.qdd_max,
        "on_stall": settings.on_stall,
    }
    if settings.method not in COMPILED:
        return PipelineStepper(robot.model, dt=robot.dt, method=settings.method,
                               scene=robot.scene, home=robot.q0, **options).step  # fmt: skip
    from lpik.control.avoiding_controller import AvoidingLp2Controller
    from lpik.control.controller import Lp2Controller

    options["saturate"] = settings.method == "lp2s"
    if robot.scene is None:
        return Lp2Controller(robot.model, dt=robot.dt, **options).step
    return AvoidingLp2Controller(robot.model, robot.scene, robot.q0, dt=robot.dt, **options).step
