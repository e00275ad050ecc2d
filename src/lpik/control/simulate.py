"""Closed-loop simulation: the stepping loop over a task model, a command law and a method.

One control step::

    dw = command(model, q, dt) - rho(q_prev, q)     # lpik.command
    problem = build_problem(J(q), dw, q, limits, dt=dt, q_prev=q_prev, **weights)
    result = method(problem)                        # lpik.methods
    q_prev, q = q, applied(result)

``rho`` is the last step's second-order term
(:func:`lpik.command.second_order_term`; 0 on the first step), which
``Lp2Controller`` takes off its command too; ``second_order=False`` commands
the law alone, as the paper's runs do.

What the loop applies, and why:

* A step of a limit-aware method (``lp1``, ``l1``, ``lp2``, ``nlp``) keeps
  every limit by construction and is applied as it is.
* A classical step (``pinv``, ``weighted``, ``robust``) knows no limits. When it
  breaks one, its status is ``"violates_limits"`` and ``binding`` names the
  limit. The machine cannot pass a mechanical end-stop, so the applied ``q``
  is the method's ``q`` clamped to the end-stops; the step is logged with its
  status, its binding and ``clamped = True`` (never silently). Step bounds
  (velocity, acceleration) are *not* clamped: the log shows what the
  classical law demands of the drives.
* A safe step (``infeasible``, ``singular``, ``check_failed``, ...) is applied
  as it is: ``p = 0``, the multipliers are NaN, and each joint comes to rest as
  fast as its limits allow (:func:`lpik.result.safe_step`; no motion at rest).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.collision.model import as_avoidance
from lpik.command import CommandLaw, second_order_term, task_rows
from lpik.control.log import SimulationLog
from lpik.highs import HighsSolver
from lpik.limits import AutomaticMultiplierBounds, Limit, build_problem, standard_limits
from lpik.methods.autobound import bound_for_step
from lpik.methods.progress import StallWatch
from lpik.methods.registry import get_method
from lpik.problem import Problem
from lpik.result import VIOLATES_LIMITS, Result
from lpik.robots.base import TaskModel
from lpik.robots.tasks import as_task_model
from lpik.types import FloatArray

#: Called after every step with ``(steps done, steps in all)``.
Progress = Callable[[int, int], None]


def _nan_if_none(values: FloatArray | None, size: int) -> FloatArray:
    return np.full(size, np.nan) if values is None else np.asarray(values, dtype=np.float64)


def _method_function(
    method: str, model: TaskModel, solver: HighsSolver | None
) -> Callable[[Problem], Result]:
    spec = get_method(method)
    if spec.needs_model:
        return partial(spec.function, model=model)
    if spec.takes_solver:
        return partial(spec.function, solver=solver)
    return spec.function


def simulate(
    model: TaskModel,
    command: CommandLaw,
    q0: Sequence[float] | FloatArray,
    steps: int,
    *,
    method: str = "lp2",
    dt: float,
    limits: Sequence[Limit] | None = None,
    weights: Mapping[str, Any] | None = None,
    name: str = "",
    warm_start: bool = True,
    progress: Progress | None = None,
    on_stall: int | None = None,
    scene: Any = None,
    second_order: bool = True,
) -> SimulationLog:
    """Run the closed loop for ``steps`` control steps and return the log.

    Args:
        model: The task model (pose, difference, jacobian, position), or a chain
            alone (its pose task: :func:`lpik.robots.tasks.as_task_model`).
        command: The command law (e.g. :class:`~lpik.command.ClampedTarget`).
        q0: Start configuration, shape (n,) [rad or m].
        steps: Number of control steps (> 0).
        method: A name from :data:`lpik.methods.METHODS`.
        dt: Control period [s] (> 0).
        limits: Limits in force (:mod:`lpik.limits`); default the model's end-stops and
            velocity limits. Acceleration limits receive the previous configuration.
        weights: ``M``, ``f``, ``Lambda``, ``q_ref``, ``k`` of every step's problem.
        name: Name recorded in the log.
        warm_start: For ``lp1``, ``l1``, ``lp2``: reuse one HiGHS instance across the
            steps, so each solve starts from the previous basis. ``False`` solves every
            step's LP on its own (a fresh instance per step). Where the LP's optimum is
            not unique (LP1: any vertex with the largest p), the two may pick different
            optimal vertices.
        progress: Called after every step with ``(done, steps)``.
        on_stall: Opt-in: after this many steps with ``p = 0`` in a row, take the
            progress step (:func:`lpik.methods.progress.progress_step`: least task
            error within every limit, status ``off_direction``) while ``p`` stays 0.
            ``None`` (default): the method's steps only.
        scene: Obstacles to avoid: a :class:`~lpik.collision.Scene` (the velocity
            damper's rows, self-collision included) or a
            :class:`~lpik.collision.CollisionAvoidance` (rows, field or both). The log
            then records each step's smallest distance and its pair.
        second_order: Take off each step's command the second-order term of the
            last step's task motion (:func:`lpik.command.second_order_term`),
            as :class:`~lpik.control.controller.Lp2Controller` does by default.
            ``False``: the command law alone (the paper's runs).

    Returns:
        The :class:`SimulationLog` of the run.

    Raises:
        ValueError: For a bad method, step count, period or start configuration.
    """
    if not (isinstance(steps, int | np.integer) and steps > 0):
        raise ValueError(f"steps: must be a whole number > 0, got {steps!r}")
    if not (isinstance(dt, int | float) and np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt: must be a finite number > 0, got {dt!r}")
    model = as_task_model(model)  # a chain alone: its pose task
    q = np.array(q0, dtype=np.float64)
    n = model.n_joints
    if q.shape != (n,) or not np.isfinite(q).all():
        raise ValueError(f"q0: must be {n} finite joint coordinates, got {q0!r}")
    step_fn = _method_function(method, model, HighsSolver() if warm_start else None)
    stall = StallWatch(on_stall)
    limits = list(standard_limits(model) if limits is None else limits)
    auto = next((lim for lim in limits if isinstance(lim, AutomaticMultiplierBounds)), None)
    auto = auto if get_method(method).bounds_multipliers else None
    task = task_rows(model) if auto is not None else None
    weights = dict(weights or {})
    weights.setdefault("joint_names", model.joint_names)
    m = model.task_dim
    rows: dict[str, list[Any]] = {k: [] for k in ("q", "pos", "p", "lam", "st", "bd", "pa", "cl")}
    avoid, closest = as_avoidance(model, scene, q), []
    times = np.empty(steps)
    q_prev: FloatArray | None = None
    for k in range(steps):
        dw = command(model, q, float(dt))
        if second_order and q_prev is not None:
            dw = dw - second_order_term(model, q_prev, q)
        J, step_limits, step_weights = model.jacobian(q), limits, weights
        if avoid is not None:
            closest.append(avoid.closest(q))
            step_limits = [*limits, *avoid.limits()]
            step_weights = avoid.weights(weights, q, float(dt), J)
        problem = build_problem(J, dw, q, step_limits, dt=dt, q_prev=q_prev, **step_weights)
        start = time.perf_counter()
        result = step_fn(problem)
        if auto is not None:  # the automatic multiplier bound (lpik.methods.autobound)
            bound = bound_for_step(auto, model.jacobian, q, J, task, float(dt), result)
            if bound is not None:
                problem = problem.replace(lam_min=np.maximum(problem.lam_min, -bound),
                                          lam_max=np.minimum(problem.lam_max, bound))  # fmt: skip
                result = step_fn(problem)
        result = stall.check(result, lambda problem=problem: problem)
        times[k] = time.perf_counter() - start
        q_next, clamped = _applied(problem, result)
        rows["q"].append(q)
        rows["pos"].append(np.asarray(model.position(q), dtype=np.float64))
        rows["p"].append(result.p if result.moved else 0.0)
        rows["lam"].append(_nan_if_none(result.lam if result.moved else None, m))
        rows["st"].append(result.status)
        rows["bd"].append(result.binding)
        rows["pa"].append(result.path)
        rows["cl"].append(clamped)
        q_prev, q = q, q_next
        if progress is not None:
            progress(k + 1, steps)
    return SimulationLog(
        method=method,
        dt=float(dt),
        t=np.arange(steps) * float(dt),
        q=np.array(rows["q"]),
        position=np.array(rows["pos"]),
        p=np.array(rows["p"], dtype=np.float64),
        lam=np.array(rows["lam"]).reshape(steps, m),
        status=np.array(rows["st"], dtype=str),
        binding=_object_array(rows["bd"]),
        path=np.array(rows["pa"], dtype=str),
        clamped=np.array(rows["cl"], dtype=bool),
        solve_time=times,
        q_end=q,
        position_end=np.asarray(model.position(q), dtype=np.float64),
        joint_names=tuple(model.joint_names),
        name=name,
        warm_start=warm_start,
        min_distance=None if avoid is None else np.array([d for d, _ in closest]),
        closest=None if avoid is None else np.array([c for _, c in closest], dtype=str),
    )


def _object_array(values: list[Any]) -> NDArray[np.object_]:
    """``values`` as a 1-D object array (each a :class:`~lpik.labels.Binding` or ``None``)."""
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


def _applied(problem: Problem, result: Result) -> tuple[FloatArray, bool]:
    """The configuration the machine reaches, and whether it was clamped to the end-stops."""
    if result.status == VIOLATES_LIMITS:
        q = np.clip(result.q, problem.q_min, problem.q_max)
        return q, bool(np.any(q != result.q))
    return np.asarray(result.q, dtype=np.float64).copy(), False
