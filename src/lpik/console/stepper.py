"""The operator's settings and the one control step they select.

:class:`Settings` holds what the page can change (method, ``v_max``, ``w_max``,
the multiplier bound, acceleration limits); :func:`make_stepper` turns a robot
and its settings into a function ``step(q, target, q_prev) -> Result``:

* ``lp2`` and ``lp2s`` run the compiled controller
  (:class:`~lpik.control.controller.Lp2Controller`, or
  :class:`~lpik.control.avoiding_controller.AvoidingLp2Controller` with a scene),
  the path a 1 kHz loop is made for;
* every other method of :data:`lpik.methods.registry.METHODS` runs the numpy
  path of :func:`lpik.control.simulate.simulate` (build the problem, solve it,
  clamp a classical step to the end-stops), slower than real time at 1 kHz for
  the LP methods on some machines: the console shows the real-time factor.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np

from lpik.collision.model import as_avoidance
from lpik.command import commanded_displacement, second_order_term
from lpik.console.robot import ConsoleRobot
from lpik.highs import HighsSolver
from lpik.limits import AccelerationLimits, Limit, build_problem, standard_limits
from lpik.methods.registry import METHODS, get_method
from lpik.result import VIOLATES_LIMITS, Result
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
    """

    method: str = "lp2s"
    v_max: float = 0.5
    w_max: float = 1.0
    lambda_bound: float | str | None = "auto"
    qdd_max: float | None = None

    def __post_init__(self) -> None:
        spec = get_method(self.method)
        for key, (low, high) in (("v_max", V_RANGE), ("w_max", W_RANGE)):
            _in_range(key, getattr(self, key), low, high)
        if isinstance(self.lambda_bound, str):
            if self.lambda_bound != "auto":
                raise ValueError(
                    f"lambda_bound: 'auto', None or a number, got {self.lambda_bound!r}"
                )
        elif self.lambda_bound is not None:
            _in_range("lambda_bound", self.lambda_bound, *LAMBDA_RANGE)
            if not spec.bounds_multipliers:
                bounded = ", ".join(n for n, s in METHODS.items() if s.bounds_multipliers)
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

    Raises:
        ValueError: For settings or a scene the robot cannot take.
    """
    if settings.method in COMPILED:
        return _compiled(robot, settings)
    return _numpy(robot, settings)


def _compiled(robot: ConsoleRobot, settings: Settings) -> Stepper:
    from lpik.control.avoiding_controller import AvoidingLp2Controller
    from lpik.control.controller import Lp2Controller

    options = {
        "v_max": settings.v_max,
        "w_max": settings.w_max,
        "lambda_bound": settings.lambda_bound,
        "qdd_max": settings.qdd_max,
        "saturate": settings.method == "lp2s",
    }
    if robot.scene is None:
        return Lp2Controller(robot.model, dt=robot.dt, **options).step
    return AvoidingLp2Controller(robot.model, robot.scene, robot.q0, dt=robot.dt, **options).step


def _numpy(robot: ConsoleRobot, settings: Settings) -> Stepper:
    model, dt = robot.model, robot.dt
    spec = get_method(settings.method)
    solve: Callable[..., Result] = spec.function
    if spec.needs_model:
        solve = partial(spec.function, model=model)
    elif spec.takes_solver:
        solve = partial(spec.function, solver=HighsSolver())
    bound = settings.lambda_bound
    if bound == "auto" or not spec.bounds_multipliers:  # the closed loop applies "auto"
        bound = None
    limits: list[Limit] = list(standard_limits(model, lambda_bound=bound))
    if settings.qdd_max is not None:
        limits.append(AccelerationLimits(settings.qdd_max))
    avoid = as_avoidance(model, robot.scene, robot.q0)
    weights = {"joint_names": model.joint_names}

    def step(q: FloatArray, target: Any, q_prev: FloatArray | None) -> Result:
        dw = commanded_displacement(model, model.pose(q), target, settings.v_max,
                                    settings.w_max, dt)  # fmt: skip
        if q_prev is not None:  # as Lp2Controller and simulate command it
            dw -= second_order_term(model, q_prev, q)
        J, step_limits, step_weights = model.jacobian(q), limits, weights
        if avoid is not None:
            step_limits = [*limits, *avoid.limits()]
            step_weights = avoid.weights(weights, q, dt, J)
        problem = build_problem(J, dw, q, step_limits, dt=dt, q_prev=q_prev, **step_weights)
        result = solve(problem)
        if result.status == VIOLATES_LIMITS:  # the machine cannot pass its end-stops
            q_next = np.clip(result.q, problem.q_min, problem.q_max)
            result = replace(result, q=q_next, dq=q_next - q)
        return result

    return step
