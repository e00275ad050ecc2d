"""One control step, one pipeline: the stages every way of taking a step runs.

A step goes through named stages, each written once::

    kinematics   w0 = phi(q0), J(q0)                       (eqs. 1-2; the task model)
    command      dw = law(q0) - rho(q_prev, q0)            (lpik.command; rho: second-order term)
    limits       problem = build_problem(J, dw, q0, ...)   (eqs. 13-14, sec. 3.2; scene rows too)
    method       result = method(problem)                  (lpik.methods, eqs. 7-19)
    bound policy result under the automatic multiplier bound where it applies (sec. 3.2)
    stall        the progress step once the step has stalled (on_stall; mode="progress": after
                 every exact step with p < 1, the least error the limits leave)
    through rest a moving arm's safe step again on the paper's line through rest, within the
                 same bands (lpik.continuation.through_rest)
    criterion    where LP2's conditions still admit no step but LP1 has one: Ho's LP past
                 the full displacement, LP1's largest p, least change of motion (lpik.methods.l1)
    recovery     from inside a scene's safety distance, the distance grows back (lpik.collision)
    rows         a stop that breaks a row (the safe step knows the joints' bands only) moved
                 within the rows (lpik.collision.recovery.kept_within_rows)
    applied      a classical step clamped to the end-stops the machine cannot pass

:class:`Stepper` runs them with the numpy layers (the *numpy engine*).
:class:`~lpik.control.controller.Lp2Controller` is the *compiled engine*: it
fuses kinematics, command, limits, method and bound policy into one compiled
call over the same limits and weights, and hands every step the kernel does
not answer to this stepper's stages (tests hold the two engines equal).
``simulate``, ``lpik simulate``, the console and the batch are users of one
or the other. The defaults (:data:`DEFAULT_METHOD`, the automatic multiplier
bound, the second-order command) are the same for every user; the paper's
runs name the paper's settings explicitly.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.collision.model import as_avoidance
from lpik.collision.recovery import highs_largest_share, is_stop, kept_within_rows, rows_kept
from lpik.command import (
    DEFAULT_V_MAX,
    DEFAULT_W_MAX,
    ClampedTarget,
    TargetMotion,
    commanded_displacement,
    made_by_drives,
    second_order_term,
    task_rows,
)
from lpik.continuation import through_rest
from lpik.control.commanded import CommandedMotion
from lpik.control.inputs import (
    STATE_FREE_LIMITS,
    numbers_of,
    positive_number,
    rate_limits,
    step_limits,
    task_value,
)
from lpik.defaults import DEFAULT_MODE, DEFAULT_ON_STALL, MODES
from lpik.highs import HighsSolver
from lpik.labels import SINGULARITY
from lpik.limits import (
    AutomaticMultiplierBounds,
    LambdaBound,
    Limit,
    build_problem,
    control_period,
)
from lpik.methods.autobound import bound_for_step, floor_row, singular_memo, singular_steps
from lpik.methods.l1 import changes_motion, l1, past_criterion
from lpik.methods.progress import StallWatch, further_step, least_error_lp
from lpik.methods.registry import DEFAULT_METHOD, MethodSpec, get_method, methods_with
from lpik.problem import Problem
from lpik.result import INFEASIBLE, MOVING, VIOLATES_LIMITS, Result
from lpik.robots.base import TaskModel
from lpik.robots.tasks import as_task_model
from lpik.types import FloatArray

__all__ = ["DEFAULT_METHOD", "Stepper"]


def _under_bound(problem: Problem, bound: FloatArray) -> Problem:
    """``problem`` with ``|lam_k| <= bound_k`` added to its multiplier bounds (sec. 3.2)."""
    return problem.replace(lam_min=np.maximum(problem.lam_min, -bound),
                           lam_max=np.minimum(problem.lam_max, bound))  # fmt: skip


def _rates(limits: Sequence[Limit], n: int) -> FloatArray:
    """The joints' velocity and acceleration limits (:func:`lpik.control.inputs.rate_limits`).

    Read as the compiled step reads them, from the limits whose bounds do not depend
    on the state.
    """
    return rate_limits([lim for lim in limits if isinstance(lim, STATE_FREE_LIMITS)], n)


def _stop_rates(rates: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """Each joint's smaller acceleration and velocity limit (of :func:`_rates`); None: no qdd."""
    qdd = np.minimum(rates[3], -rates[2])
    if not np.isfinite(qdd).any():
        return None
    return qdd, np.minimum(rates[1], -rates[0])


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{name}: must be True or False, got {value!r}")
    return bool(value)


class Stepper:
    """One control step of a task model through the stages of the module docstring.

    Args:
        model: A task model (or a chain alone: its pose task).
        dt: Control period [s].
        method: A name of :data:`lpik.methods.registry.METHODS` (default ``lp2s``).
        limits: The limits as :func:`~lpik.limits.build_problem` takes them; default
            the model's end-stops and (``velocity_limits``) velocity limits. The
            keywords ``qdd_max``, ``lambda_bound`` and ``rows`` add to them.
        weights: ``M``, ``f``, ``Lambda``, ``q_ref``, ``k`` of every step's problem.
        v_max: Largest commanded linear speed [m/s] of a target's command.
        w_max: Largest commanded angular speed [rad/s] of a target's command.
        lambda_bound: ``"auto"`` (default): the automatic multiplier bound
            (:mod:`lpik.methods.autobound`) unless ``limits`` bound the multipliers;
            a number ``B`` (``|lam_i| <= B``) or a :class:`~lpik.limits.MultiplierBounds`
            (sec. 3.2); ``None``: unbounded. Only for methods that bound their
            multipliers; the others ignore ``"auto"``.
        qdd_max: Symmetric joint acceleration limits [rad/s^2] (scalar or (n,)).
        velocity_limits: Without ``limits``: whether the model's ``qd_max`` bounds each step.
        rows: Extra rows ``(G, h, row_labels)`` of ``G q <= h``, or None.
        scene: Obstacles to keep clear of: a :class:`~lpik.collision.Scene` (the
            velocity damper's rows) or a :class:`~lpik.collision.CollisionAvoidance`.
        home: Configuration at which touching self-collision pairs are dropped (beyond
            those that touch everywhere, :func:`lpik.collision.distance.robot_bodies`).
        second_order: Take off each command the last step's second-order term
            (:func:`lpik.command.second_order_term`); ``False``: the law alone.
        on_stall: The progress step (:mod:`lpik.methods.progress`) after this many
            stalled steps in a row (:func:`lpik.methods.progress.is_stall`); default
            :data:`lpik.defaults.DEFAULT_ON_STALL` (1); ``None``: never, the paper's
            strict steps.
        mode: ``"exact"`` (default): the method's step; ``"progress"``: after every
            exact step with ``p < 1``, the least task error the limits leave
            (:func:`lpik.methods.progress.further_step`).
        warm_start: Reuse one HiGHS instance across the steps of the LP methods.
        continuation: Under acceleration limits, solve LP1 and LP2's steps around the
            current motion (:mod:`lpik.continuation`) and slow the command down in
            time to stop on its target (:func:`lpik.command.braking_scale`);
            ``False``: the paper's step through ``dq = 0`` and the law alone.

    Raises:
        ValueError: Naming the argument that is wrong.
    """

    #: While the through-rest stage builds its problem (:meth:`rested`): the limits
    #: stage gives the problem of the step around the motion without ``last``.
    _through_rest = False

    def __init__(
        self,
        model: TaskModel,
        *,
        dt: float,
        method: str = DEFAULT_METHOD,
        limits: Sequence[Limit] | None = None,
        weights: Mapping[str, Any] | None = None,
        v_max: float = DEFAULT_V_MAX,
        w_max: float = DEFAULT_W_MAX,
        lambda_bound: LambdaBound = "auto",
        qdd_max: ArrayLike | None = None,
        velocity_limits: bool = True,
        rows: tuple[Any, Any, Any] = (None, None, None),
        scene: Any = None,
        home: ArrayLike | None = None,
        second_order: bool = True,
        on_stall: int | None = DEFAULT_ON_STALL,
        warm_start: bool = True,
        continuation: bool = True,
        mode: str = DEFAULT_MODE,
    ) -> None:
        self.model = model = as_task_model(model)
        self.dt = control_period(dt)
        self.v_max, self.w_max = positive_number("v_max", v_max), positive_number("w_max", w_max)
        self.spec: MethodSpec = get_method(method)
        self.method = self.spec.name
        self.second_order = _flag("second_order", second_order)
        velocity_limits = _flag("velocity_limits", velocity_limits)
        if not self.spec.bounds_multipliers and lambda_bound == "auto":
            lambda_bound = None
        #: The limits every step holds (the scene's rows come on top, per step).
        self.limits = tuple(
            lim
            for lim in step_limits(model, limits, velocity_limits=velocity_limits,
                                         qdd_max=qdd_max, lambda_bound=lambda_bound, rows=rows)
            if self.spec.bounds_multipliers or not isinstance(lim, AutomaticMultiplierBounds)
        )  # fmt: skip
        #: The joints' acceleration and velocity limits (smaller side) that the command
        #: brakes within, or None (no acceleration limits, or ``continuation=False``).
        rates = _rates(self.limits, model.n_joints)
        self.stop_rates = _stop_rates(rates) if _flag("continuation", continuation) else None
        #: The joints' ``(qd_min, qd_max)`` [rad/s]: a last step beyond them is no motion
        #: whose second-order term the command takes off (:func:`lpik.command.made_by_drives`).
        self.velocities = (rates[0], rates[1])
        #: The joints' ``(qdd_min, qdd_max)`` that the scene's stops ahead of ``d_i`` brake
        #: within (:func:`lpik.collision.avoidance.braking_row`), or None (no acceleration limits).
        self.accelerations = (rates[2], rates[3]) if np.isfinite(rates[2:]).any() else None
        #: The last step answered, against which the next state's implied motion is
        #: checked under acceleration limits (:mod:`lpik.control.commanded`), or None.
        self.motion = CommandedMotion.for_rates(rates, self.dt, model.joint_names)
        #: Whether the method's steps are solved around the current motion.
        self.continues = self.stop_rates is not None and self.spec.continuable
        #: The automatic multiplier bound in force, or None.
        self.automatic_bound = next(
            (lim for lim in self.limits if isinstance(lim, AutomaticMultiplierBounds)), None
        )
        self.weights = dict(weights or {})
        self.weights.setdefault("joint_names", model.joint_names)
        home_q = None if home is None else np.asarray(home, dtype=np.float64)
        #: The scene's collision avoidance, or None.
        self.avoidance = as_avoidance(model, scene, home_q)
        _check_field_method(self.avoidance, self.spec)
        self.stall_watch = StallWatch(on_stall)
        #: Where the last step's motion reached the automatic bound's floor (the stop
        #: ahead 0 steps away): what :meth:`on_floor` rebuilds its problem from, else None.
        self.floor_reached: tuple[FloatArray | None, FloatArray, FloatArray | None] | None = None
        if mode not in MODES:
            raise ValueError(f"mode: must be one of {', '.join(MODES)}, got {mode!r}")
        #: ``"exact"`` or ``"progress"`` (:data:`lpik.defaults.MODES`).
        self.mode = mode
        self._solver = HighsSolver() if _flag("warm_start", warm_start) else None
        #: Each task row's index in x, y, z, rx, ry, rz.
        self.task_rows = task_rows(model)
        #: Whether the last :meth:`step` clamped a classical step to the end-stops.
        self.clamped = False
        #: Wall time [s] of the last :meth:`step`'s method, bound policy and stall stages.
        self.solve_time = 0.0
        #: The target's motion between consecutive steps, fed forward under acceleration limits.
        self.target_motion = TargetMotion()

    # -- the stages ---------------------------------------------------------------------

    def command(
        self,
        q0: FloatArray,
        target: Any,
        q_prev: FloatArray | None,
        J: FloatArray | None = None,
        before: FloatArray | None = None,
    ) -> FloatArray:
        """The step's commanded displacement ``dw`` (eq. 2, :mod:`lpik.command`).

        ``target`` is a task value (moved to at ``v_max``, ``w_max``, and under
        acceleration limits slowed down in time to stop on it, given ``J``) or a
        command law (:class:`~lpik.command.CommandLaw`); less the second-order
        term of the motion ``q_prev -> q0`` where ``second_order`` is on
        (``before``: that motion, ``J(q_prev) (q0 - q_prev)``, where the caller has it).
        """
        model = self.model
        v_max, w_max = self.v_max, self.w_max
        if isinstance(target, ClampedTarget):  # the law itself: brakes as a target does
            target, v_max, w_max = target.target, target.v_max, target.w_max
        if callable(target):
            dw = np.array(target(model, q0, self.dt), dtype=np.float64)
        else:
            stop = (
                None
                if J is None or self.stop_rates is None
                else (J, *self.stop_rates, self._turn(q0, q_prev, J, before))
            )
            value = task_value(model, target)
            motion = None if stop is None else self.target_motion.motion(model, q0, q_prev, value)
            dw = commanded_displacement(model, model.pose(q0), value, v_max, w_max, self.dt,
                                        stop, motion)  # fmt: skip
        if (self.second_order and q_prev is not None
                and made_by_drives(q0, q_prev, *self.velocities, self.dt)):  # fmt: skip
            dw -= second_order_term(model, q_prev, q0, before)
        return dw

    def _turn(
        self, q0: FloatArray, q_prev: FloatArray | None, J: FloatArray, before: FloatArray | None
    ) -> FloatArray:
        """``J(q_prev) last - J last`` (``last = q0 - q_prev``): the brake's turn (zeros at rest).

        Its least motion is the hold of :func:`lpik.command.braking_scale`; ``before`` is
        ``J(q_prev) last`` where the caller has it.
        """
        if q_prev is None or np.array_equal(q0, q_prev):
            return np.zeros(J.shape[0])
        last = np.asarray(q0, dtype=np.float64) - q_prev
        if before is None:
            before = np.asarray(self.model.jacobian(q_prev), dtype=np.float64) @ last
        return before - J @ last

    def previous_jacobian(self, q0: FloatArray, q_prev: FloatArray | None) -> FloatArray | None:
        """``J(q_prev)``, where a stage reads the last step's motion ``q_prev -> q0``.

        The second-order term, the fading motion's stop and the stop before a
        singular configuration read it (once a step, as the fused step's
        ``prev_jacobian6`` block holds it); None at rest, without ``q_prev`` or where
        none of them is on.
        """
        if q_prev is None or not (self.second_order or self.continues):
            return None
        if np.array_equal(q0, q_prev):
            return None
        return np.asarray(self.model.jacobian(q_prev), dtype=np.float64)

    def singular_steps(
        self, J: FloatArray, J_before: FloatArray | None, bound: FloatArray | None
    ) -> float:
        """The stop before a singular configuration (:func:`lpik.methods.autobound.singular_steps`).

        In the step solved again under the automatic multiplier bound (``bound``
        given), solved around the motion; ``inf`` otherwise.
        """
        limit = self.automatic_bound
        if limit is None or bound is None or J_before is None or not self.continues:
            return math.inf
        return float(singular_steps(np.atleast_2d(J), J_before, limit.activation, limit.floor,
                                    singular_memo()))  # fmt: skip

    def problem(
        self,
        q0: ArrayLike,
        target: Any,
        q_prev: ArrayLike | None = None,
        *,
        bound: FloatArray | None = None,
    ) -> Problem:
        """Kinematics, command and limits: the step's validated :class:`~lpik.problem.Problem`.

        ``bound``: multiplier bounds ``|lam_k| <= bound_k`` to add (the automatic
        bound's second solve).
        """
        q = np.asarray(q0, dtype=np.float64)
        prev = None if q_prev is None else np.asarray(q_prev, dtype=np.float64)
        J = self.model.jacobian(q)
        J_before = self.previous_jacobian(q, prev)
        before = None if J_before is None else J_before @ (q - prev)
        dw = self.command(q, target, prev, J, before)
        return self.limited(q, dw, prev, J, bound=bound, jacobian_before=J_before)

    def limited(
        self,
        q0: FloatArray,
        dw: FloatArray,
        q_prev: FloatArray | None,
        J: FloatArray,
        *,
        bound: FloatArray | None = None,
        jacobian_before: FloatArray | None = None,
        singular_stop: bool = True,
        brake_rows: bool = True,
        stops_ahead: bool = True,
    ) -> Problem:
        """The limits stage: ``build_problem`` with the scene's rows and field on top.

        ``jacobian_before``: :meth:`previous_jacobian` where the caller has it (None:
        computed where the stops ahead need it). ``singular_stop=False``: without the
        stop before a singular configuration (:meth:`on_floor`). ``brake_rows=False``:
        the rows as given, without their stops ahead (``build_problem``'s).
        ``stops_ahead=False``: the joints' own bands, without the stops ahead of the
        motion (a motion that stops paying, a singular configuration ahead).
        """
        limits = self.limits
        if self.avoidance is not None:
            limits = (*limits, *self.avoidance.limits(self.accelerations))
        if not stops_ahead:
            jacobian_before = None
        elif jacobian_before is None and self.continues:  # the stops ahead read it
            jacobian_before = self.previous_jacobian(q0, q_prev)
        before = None if jacobian_before is None else jacobian_before @ (q0 - q_prev)
        P = build_problem(J, dw, q0, limits, dt=self.dt, q_prev=q_prev,
                          continuation=self.continues, motion_before=before,
                          singular_steps=self.singular_steps(
                              J, jacobian_before, bound if singular_stop else None),
                          brake_rows=brake_rows, **self.weights)  # fmt: skip
        if self.avoidance is not None:  # the field's force, within the step's own room
            P = self.avoidance.with_field(P, self.dt)
        if self._through_rest and P.last is not None:  # the stops ahead kept, through rest
            P = P.replace(last=None)
        return P if bound is None else _under_bound(P, bound)

    def solve(self, problem: Problem, *, path: str | None = None) -> Result:
        """The method stage: the method on the problem (``path``: LP2's path, if it has one)."""
        return self._method(path)(problem)

    def bounded(
        self, problem: Problem, result: Result, q_prev: FloatArray | None = None,
        *, path: str | None = None,
    ) -> tuple[Problem, Result]:  # fmt: skip
        """The bound policy: the step again under the automatic multiplier bound where it applies.

        The rule is :func:`lpik.methods.autobound.bound_for_step` (sec. 3.2 chosen
        per step: bounded only where the unbounded step races towards a singularity).
        Under acceleration limits, where the stop before the singular configuration
        (:meth:`singular_steps`) lies ahead, the problem solved again is the limits
        stage's under that bound (:meth:`limited`, which narrows the bands for it);
        elsewhere it is ``problem`` with the bound added.

        Returns:
            The step's problem and result: ``problem`` and ``result`` where the step
            stays unbounded.
        """
        self.floor_reached = None
        bound = self.bound_of(problem.q0, problem.J, result)
        if bound is None:
            return problem, result
        J_before = None if q_prev is None else self.previous_jacobian(problem.q0, q_prev)
        steps = self.singular_steps(problem.J, J_before, bound)
        if steps == 0.0:
            self.floor_reached = (q_prev, bound, J_before)
        if steps < math.inf:
            problem = self.limited(problem.q0, problem.dw, q_prev, problem.J, bound=bound,
                                   jacobian_before=J_before)  # fmt: skip
        else:
            problem = _under_bound(problem, bound)
        return problem, self.solve(problem, path=path)

    def bound_of(self, q0: FloatArray, J: FloatArray, result: Result) -> FloatArray | None:
        """The automatic bound's ``B`` for this step, or None where the step stays unbounded."""
        if self.automatic_bound is None:
            return None
        return bound_for_step(self.automatic_bound, self.model.jacobian, q0, J, self.task_rows,
                              self.dt, result)  # fmt: skip

    def on_floor(self, problem: Problem) -> Problem:
        """The stall stage's problem: where the motion reached the bound's floor, its row.

        Where :meth:`bounded` found the floor 0 steps ahead, the progress step takes
        :func:`lpik.methods.autobound.floor_row` instead of the stop ahead's band
        (its docstring says why); else ``problem`` as it is.
        """
        limit = self.automatic_bound
        if self.floor_reached is None or limit is None:
            return problem
        q_prev, bound, J_before = self.floor_reached
        n = problem.J.shape[1]
        row = np.empty(n)
        rhs = floor_row(problem.J, self.model.jacobian, problem.q0, limit.activation, limit.floor,
                        limit.probe, self.dt, row)  # fmt: skip
        if not rhs < math.inf:
            return problem
        rebuilt = self.limited(problem.q0, problem.dw, q_prev, problem.J, bound=bound,
                               jacobian_before=J_before, singular_stop=False)  # fmt: skip
        return replace(rebuilt, G=np.vstack([rebuilt.G, row]),
                       h=np.append(rebuilt.h, rhs + row @ problem.q0),
                       row_labels=(*rebuilt.row_labels, SINGULARITY))  # fmt: skip

    def scaled(self, problem: Problem, result: Result) -> Result:
        """The criterion stage: where LP2's conditions admit no step, Ho's LP past the full one.

        LP2 (with saturation or not) keeps the criterion's optimality conditions
        (eqs. 15-18) as rows; where they admit no step within the limits (``result``
        the safe step, :func:`lpik.methods.l1.past_criterion`) a step along the command
        may still exist: LP1's (eqs. 11-14, no criterion). :func:`lpik.methods.l1.l1`
        takes LP1's largest ``p`` and, among those steps, the least-L1 one (the least
        change of the motion, around it), status ``scaled``, method ``l1``, no
        multipliers; where it changes the motion toward the command by rounding only
        (:func:`lpik.methods.l1.changes_motion`), ``result`` stands. After the
        through-rest stage (:meth:`rested`): LP2's step through rest, where it has one,
        keeps the criterion; taken before it, the step with LP1's largest ``p`` (a
        vertex of the acceleration band) replaced it on 150 to 420 steps of most of
        the iiwa14's random goals and more than doubled the acceleration reversals
        (778 to 1,867; ``benchmarks/random_goals.py``). With the stall stage only (the
        strict step is the method's own), from within the limits (a state outside them
        has its own step, ``recovering``). The fused step's stage is
        :func:`lpik.fast.progress.least_l1_in_state`.
        """
        if (not past_criterion(result) or self.stall_watch.after is None
                or problem.recovering()):  # fmt: skip
            return result
        step = l1(problem, solver=self._solver)
        return step if step.status in MOVING and changes_motion(step.p) else result

    def stalled(
        self, result: Result, problem_of: Callable[[], Problem],
        last_motion: FloatArray | None = None,
    ) -> Result:  # fmt: skip
        """The stall stage: the progress step once the step has stalled ``on_stall`` times.

        Its problem is :meth:`on_floor`'s; ``last_motion`` is the arm's last step
        ``q0 - q_prev`` (None: at rest). In ``mode="progress"`` a step that did not
        stall gets the second stage, :func:`lpik.methods.progress.further_step`, where
        ``p < 1``.
        """
        checked = self.stall_watch.check(result, lambda: self.on_floor(problem_of()),
                                         last_motion)  # fmt: skip
        if self.mode != "progress" or checked is not result or result.p >= 1.0:
            return checked
        return further_step(problem_of(), result, solver=self._solver)

    def rested(
        self, problem: Problem, result: Result, q_prev: FloatArray | None
    ) -> tuple[Problem, Result]:
        """The through-rest stage: a moving arm's safe step, solved through rest where it can be.

        Where the step around the motion (``problem.last``) is still the safe step
        after the stall stage, the limits, method and bound policy stages again with
        the same command, on the paper's line through rest within the same bounds
        (the stops ahead kept: :meth:`limited` drops ``last`` while the stage builds
        its problem); :func:`lpik.continuation.through_rest` chooses. With
        the stall stage only: the strict step (``on_stall=None``) is the method's own.
        Returns the step's problem and result.
        """
        if result.status != INFEASIBLE or problem.last is None or self.stall_watch.after is None:
            return problem, result
        rest_problem = self.rest_problem(problem, q_prev)
        with self._resting():  # (the bound policy builds the problem again under its bound)
            rest_problem, rest = self.bounded(rest_problem, self.solve(rest_problem), q_prev)
        chosen = through_rest(result, rest)
        return (rest_problem, rest) if chosen is rest else (problem, result)

    def rest_problem(self, problem: Problem, q_prev: FloatArray | None) -> Problem:
        """The through-rest stage's problem (:meth:`rested`) after the step ``problem``.

        The limits stage again with ``problem``'s command: the paper's line through
        rest within the same bounds, the stops ahead of the motion kept (:meth:`limited`
        drops ``last`` while the stage builds its problem).
        """
        with self._resting():
            return self.limited(problem.q0, problem.dw, q_prev, problem.J)

    @contextmanager
    def _resting(self) -> Iterator[None]:
        """Within: :meth:`limited` builds the through-rest stage's problems."""
        self._through_rest = True
        try:
            yield
        finally:
            self._through_rest = False

    def recovered(self, problem: Problem, result: Result) -> Result:
        """The recovery stage: from inside a scene's safety distance, the distance grows back.

        :meth:`lpik.collision.CollisionAvoidance.recovered` (the rule of
        :mod:`lpik.collision.recovery`), its LP :func:`lpik.methods.progress.least_error_lp`.
        """
        if self.avoidance is None:
            return result
        least_error = partial(least_error_lp, solver=self._solver)
        return self.avoidance.recovered(problem, result, self.dt, least_error)

    def within_rows(
        self, problem: Problem, result: Result, q_prev: FloatArray | None = None
    ) -> Result:
        """The rows stage: a stop that breaks one of ``problem``'s rows, moved within them.

        :func:`lpik.collision.recovery.kept_within_rows` on the problem's rows, its LPs
        HiGHS's, within the joints' own bands: a row is a hard limit, and the stops
        ahead of the motion (:meth:`limited` with ``stops_ahead=False``, the step
        after ``q_prev``) are the continuation's, which pinned the joints of a braking
        arm and left it no step within a user's row.
        """
        if not problem.G.shape[0] or not is_stop(result):  # (no bounds built for a step)
            return result
        G = problem.G
        g = problem.h - G @ problem.q0
        if rows_kept(G, g, result.dq):
            return result
        own = problem
        if problem.last is not None:  # solved around the motion: the bands without its stops
            own = self.limited(problem.q0, problem.dw, q_prev, problem.J, stops_ahead=False)
        lower, upper = own.step_bounds()[:2]
        return kept_within_rows(result, problem.q0, problem.J, lower, upper, G, g,
                                partial(least_error_lp, solver=self._solver),
                                highs_largest_share)  # fmt: skip

    def applied(self, problem: Problem, result: Result) -> Result:
        """The applied stage: a classical step that breaks an end-stop, clamped to it.

        Sets :attr:`clamped`. The status (``violates_limits``) and binding stay.
        """
        self.clamped = False
        if result.status != VIOLATES_LIMITS:
            return result
        q = np.clip(result.q, problem.q_min, problem.q_max)
        self.clamped = bool(np.any(q != result.q))
        return replace(result, q=q, dq=q - problem.q0) if self.clamped else result

    # -- the whole step -----------------------------------------------------------------

    def step(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Result:
        """One control step from ``q0`` towards ``target``: every stage in turn.

        Args:
            q0: Joint coordinates now, (n,).
            target: The commanded task value (xyz (3,), a rotation (3, 3) or a pose
                (4, 4)) or a command law.
            q_prev: Joint coordinates one period ago; ``None``: at rest.

        Raises:
            ValueError: For a ``q0``, ``q_prev`` or ``target`` of the wrong shape or
                with values that are not finite.
        """
        q = self._joints("q0", q0)
        prev = None if q_prev is None else self._joints("q_prev", q_prev)
        if self.motion is not None:  # a measured loop's noise; the loop's feeding watched
            taken = self.motion.admit(q, prev)
            if taken is not prev:  # the step still follows the last one
                self.target_motion.follow(q, prev, taken)
            prev = taken
        result = self._step_as_given(q, target, prev)
        if self.motion is not None:
            result = self.motion.reported(result)
            self.motion.hold(q, result.q)
        return result

    def _step_as_given(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Result:
        """:meth:`step` on the state as given: no check against the last step answered.

        Nothing is remembered either: for a controller that checks the state itself
        (:meth:`lpik.control.controller.Lp2Controller.step`) and a batch's independent rows.
        """
        q = self._joints("q0", q0)
        prev = None if q_prev is None else self._joints("q_prev", q_prev)
        problem = self.problem(q, target, prev)
        start = time.perf_counter()
        problem, result = self.bounded(problem, self.solve(problem), prev)
        last = None if prev is None else q - prev
        problem, result = self.rested(problem, self.stalled(result, lambda: problem, last), prev)
        result = self.scaled(problem, result)
        result = self.within_rows(problem, self.recovered(problem, result), prev)
        self.solve_time = time.perf_counter() - start
        return self.applied(problem, result)

    def _joints(self, name: str, value: ArrayLike) -> FloatArray:
        n = self.model.n_joints
        q = numbers_of(name, value, f"{n} numbers")
        if q.shape != (n,) or not np.isfinite(q).all():
            raise ValueError(f"{name}: must be {n} finite joint coordinates, got {value!r}")
        return q

    def _method(self, path: str | None) -> Callable[[Problem], Result]:
        spec = self.spec
        if spec.needs_model:
            return partial(spec.function, model=self.model)
        options: dict[str, Any] = {}
        if spec.takes_solver:
            options["solver"] = self._solver
        if path is not None:
            options["path"] = path
        return partial(spec.function, **options) if options else spec.function


def _check_field_method(avoidance: Any, spec: MethodSpec) -> None:
    """A potential field only with a method that takes its force (``f`` of eq. 3).

    Any other method would drop the field without a word and leave the arm
    unguarded (``lp1`` with the field on the planar obstacle: pairs 5 mm inside
    ``d_s``).
    """
    if avoidance is None or avoidance.mechanism == "rows" or spec.takes_criterion:
        return
    takers = methods_with("takes_criterion")
    raise ValueError(
        f"scene: method {spec.name!r} does not take the potential field's force "
        f"(f of eq. 3; {takers} do): avoid with mechanism 'rows', got {avoidance.mechanism!r}"
    )
