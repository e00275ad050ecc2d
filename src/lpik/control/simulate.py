"""Closed-loop simulation: the stepping loop over a task model, a command law and a method.

One control step is one :meth:`lpik.control.stepper.Stepper.step`::

    dw = command(model, q, dt) - rho(q_prev, q)     # lpik.command
    problem = build_problem(J(q), dw, q, limits, dt=dt, q_prev=q_prev, **weights)
    result = method(problem)                        # lpik.methods (+ bound policy, stall stage)
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

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.command import CommandLaw
from lpik.control.log import SimulationLog
from lpik.control.stepper import DEFAULT_METHOD, Stepper
from lpik.defaults import DEFAULT_MODE, DEFAULT_ON_STALL
from lpik.limits import LambdaBound, Limit, control_period
from lpik.result import Result
from lpik.robots.base import TaskModel
from lpik.robots.tasks import as_task_model
from lpik.types import FloatArray

#: Called after every step with ``(steps done, steps in all)``.
Progress = Callable[[int, int], None]


def _nan_if_none(values: FloatArray | None, size: int) -> FloatArray:
    return np.full(size, np.nan) if values is None else np.asarray(values, dtype=np.float64)


def simulate(
    model: TaskModel,
    command: CommandLaw,
    q0: Sequence[float] | FloatArray,
    steps: int,
    *,
    method: str = DEFAULT_METHOD,
    dt: float,
    limits: Sequence[Limit] | None = None,
    lambda_bound: LambdaBound = "auto",
    qdd_max: Any = None,
    weights: Mapping[str, Any] | None = None,
    name: str = "",
    warm_start: bool = True,
    progress: Progress | None = None,
    on_stall: int | None = DEFAULT_ON_STALL,
    scene: Any = None,
    second_order: bool = True,
    continuation: bool = True,
    mode: str = DEFAULT_MODE,
) -> SimulationLog:
    """Run the closed loop for ``steps`` control steps and return the log.

    Each step is one :meth:`lpik.control.stepper.Stepper.step` (the numpy
    engine); ``Lp2Controller`` runs the same stages compiled.

    Args:
        model: The task model (pose, difference, jacobian, position), or a chain
            alone (its pose task: :func:`lpik.robots.tasks.as_task_model`).
        command: The command law (e.g. :class:`~lpik.command.ClampedTarget`).
        q0: Start configuration, shape (n,) [rad or m].
        steps: Number of control steps (> 0).
        method: A name from :data:`lpik.methods.METHODS` (default ``lp2s``).
        dt: Control period [s] (> 0).
        limits: Limits in force (:mod:`lpik.limits`); default the model's end-stops and
            velocity limits. Acceleration limits receive the previous configuration.
        lambda_bound: ``"auto"`` (default): the automatic multiplier bound unless
            ``limits`` bound the multipliers; a number ``B`` (``|lam_i| <= B``, sec.
            3.2); ``None``: unbounded (the paper's LP2). Methods without
            multipliers ignore ``"auto"``.
        qdd_max: Symmetric joint acceleration limits [rad/s^2]; None: none (beyond ``limits``).
        weights: ``M``, ``f``, ``Lambda``, ``q_ref``, ``k`` of every step's problem.
        name: Name recorded in the log.
        warm_start: For ``lp1``, ``l1``, ``lp2``: reuse one HiGHS instance across the
            steps, so each solve starts from the previous basis. ``False`` solves every
            step's LP on its own (a fresh instance per step). Where the LP's optimum is
            not unique (LP1: any vertex with the largest p), the two may pick different
            optimal vertices.
        progress: Called after every step with ``(done, steps)``.
        on_stall: After this many stalled steps in a row (``p`` near 0 and no motion
            along the command, :data:`lpik.tolerances.STALL_P`), take the progress step
            (:func:`lpik.methods.progress.progress_step`: least task error within every
            limit, status ``off_direction``, ``p = 0``) while the arm stays stalled.
            Opt-in (``1`` turns it on); ``None``, the default
            (:data:`lpik.defaults.DEFAULT_ON_STALL`): the method's steps only (the
            paper's runs).
        scene: Obstacles to avoid: a :class:`~lpik.collision.Scene` (the velocity
            damper's rows, self-collision included) or a
            :class:`~lpik.collision.CollisionAvoidance` (rows, field or both). The log
            then records each step's smallest distance and its pair.
        second_order: Take off each step's command the second-order term of the
            last step's task motion (:func:`lpik.command.second_order_term`),
            the default of every way to take a step. ``False``: the command law
            alone (the paper's runs).
        continuation: Under acceleration limits, solve each step around the current
            motion and brake the command in time (:mod:`lpik.continuation`; the
            default of every way to take a step). ``False``: the paper's step.
        mode: ``"exact"`` (default): the method's steps keep the commanded direction;
            ``"progress"``: after every exact step with ``p < 1``, the least task error
            the limits leave (:func:`lpik.methods.progress.further_step`).

    Returns:
        The :class:`SimulationLog` of the run.

    Raises:
        ValueError: For a bad method, step count, period or start configuration.
    """
    if not (isinstance(steps, int | np.integer) and steps > 0):
        raise ValueError(f"steps: must be a whole number > 0, got {steps!r}")
    dt = control_period(dt)
    model = as_task_model(model)  # a chain alone: its pose task
    q = np.array(q0, dtype=np.float64)
    n = model.n_joints
    if q.shape != (n,) or not np.isfinite(q).all():
        raise ValueError(f"q0: must be {n} finite joint coordinates, got {q0!r}")
    stepper = Stepper(
        model,
        dt=float(dt),
        method=method,
        limits=limits,
        weights=weights,
        lambda_bound=lambda_bound,
        qdd_max=qdd_max,
        scene=scene,
        home=q,
        second_order=second_order,
        on_stall=on_stall,
        warm_start=warm_start,
        continuation=continuation,
        mode=mode,
    )
    log = _LogRows(model, stepper)
    q_prev: FloatArray | None = None
    for k in range(steps):
        result = stepper.step(q, command, q_prev)
        log.add(q, result, stepper.clamped, stepper.solve_time)  # the method's time
        q_prev, q = q, np.asarray(result.q, dtype=np.float64).copy()
        if progress is not None:
            progress(k + 1, steps)
    return log.finished(q, name=name, dt=float(dt), warm_start=warm_start)


class _LogRows:
    """The rows of a run's log, one per step: the state before it and the step's answer."""

    def __init__(self, model: TaskModel, stepper: Stepper) -> None:
        self.model, self.stepper = model, stepper
        self.rows: dict[str, list[Any]] = {
            k: [] for k in ("q", "pos", "p", "lam", "st", "bd", "pa", "cl", "t", "near", "pull")
        }

    def add(self, q: FloatArray, result: Result, clamped: bool, seconds: float) -> None:
        rows, avoid = self.rows, self.stepper.avoidance
        if avoid is not None:
            rows["near"].append(avoid.closest(q))
        rows["q"].append(q)
        rows["pos"].append(np.asarray(self.model.position(q), dtype=np.float64))
        rows["p"].append(result.p if result.moved else 0.0)
        rows["lam"].append(_nan_if_none(result.lam if result.moved else None,
                                        self.model.task_dim))  # fmt: skip
        rows["st"].append(result.status)
        rows["bd"].append(result.binding)
        rows["pa"].append(result.path)
        rows["cl"].append(clamped)
        rows["t"].append(seconds)
        rows["pull"].append(result.pull_scale if result.moved else 1.0)

    def finished(self, q: FloatArray, *, name: str, dt: float, warm_start: bool) -> SimulationLog:
        rows, model, steps = self.rows, self.model, len(self.rows["q"])
        near = rows["near"] if self.stepper.avoidance is not None else None
        return SimulationLog(
            method=self.stepper.method,
            dt=dt,
            t=np.arange(steps) * dt,
            q=np.array(rows["q"]),
            position=np.array(rows["pos"]),
            p=np.array(rows["p"], dtype=np.float64),
            lam=np.array(rows["lam"]).reshape(steps, model.task_dim),
            status=np.array(rows["st"], dtype=str),
            binding=_object_array(rows["bd"]),
            path=np.array(rows["pa"], dtype=str),
            clamped=np.array(rows["cl"], dtype=bool),
            solve_time=np.array(rows["t"]),
            pull_scale=np.array(rows["pull"], dtype=np.float64),
            q_end=q,
            position_end=np.asarray(model.position(q), dtype=np.float64),
            joint_names=tuple(model.joint_names),
            name=name,
            warm_start=warm_start,
            min_distance=None if near is None else np.array([d for d, _ in near]),
            closest=None if near is None else np.array([c for _, c in near], dtype=str),
        )


def _object_array(values: list[Any]) -> NDArray[np.object_]:
    """``values`` as a 1-D object array (each a :class:`~lpik.labels.Binding` or ``None``)."""
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out
