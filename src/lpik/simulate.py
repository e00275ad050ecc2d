"""Closed-loop simulation: the command law, the stepping loop and the log it returns.

One control step (DESIGN.md, "The flow of one step")::

    dw = command(model, q, dt)                      # e.g. ClampedTarget: toward a target
    problem = build_problem(J(q), dw, q, limits, dt=dt, q_prev=q_prev, **weights)
    result = method(problem)                        # lpik.methods
    q_prev, q = q, applied(result)

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
* A safe step (``infeasible``, ``singular``, ``check_failed``, ...) does not
  move the robot: ``q`` stays, ``p = 0`` and the multipliers are NaN.
"""

from __future__ import annotations

import csv
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from lpik import result as st
from lpik.limits import Limit, build_problem, standard_limits
from lpik.lp import HighsSolver
from lpik.methods import ALL_METHODS, METHODS, solve
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import TaskModel

FloatArray = NDArray[np.float64]

#: Methods that take a reusable ``solver=`` (one HiGHS instance per run, warm-started).
SOLVER_METHODS = frozenset({"lp1", "l1", "lp2"})

#: p at or above this counts as the command followed in full.
FULL_COMMAND_P = 1.0 - 1e-9

#: Called after every step with ``(steps done, steps in all)``.
Progress = Callable[[int, int], None]


class CommandLaw(Protocol):
    """Turns the state of the robot into one step's commanded task displacement ``dw``."""

    def __call__(self, model: TaskModel, q: FloatArray, dt: float) -> FloatArray:
        """The displacement ``dw`` (shape (m,)) commanded for the step from ``q``."""
        ...


def clamp_length(dw: FloatArray, max_length: float) -> FloatArray:
    """``dw`` scaled down to Euclidean length ``max_length`` when it is longer."""
    length = float(np.linalg.norm(dw))
    if length > max_length:
        return dw * (max_length / length)
    return dw


@dataclass(frozen=True, eq=False)
class ClampedTarget:
    """DESIGN.md's command law: straight toward a target at most ``v_max`` fast.

    ``dw = model.difference(model.pose(q), target)``, scaled down to length
    ``v_max * dt`` when it is longer. Tasks that mix metres and radians (3-D
    poses) may want separate linear and angular speeds: they plug in their own
    :class:`CommandLaw`.

    Args:
        target: Task-space value to move to (what ``model.pose`` returns) [m or rad].
        v_max: Largest commanded task speed [m/s].
    """

    target: Any
    v_max: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.v_max) and self.v_max > 0):
            raise ValueError(f"v_max: must be a finite number > 0, got {self.v_max!r}")

    def __call__(self, model: TaskModel, q: FloatArray, dt: float) -> FloatArray:
        """The clamped displacement toward the target for one step of ``dt`` [s]."""
        dw = np.asarray(model.difference(model.pose(q), self.target), dtype=np.float64)
        return clamp_length(dw, self.v_max * dt)


def _nan_if_none(values: FloatArray | None, size: int) -> FloatArray:
    return np.full(size, np.nan) if values is None else np.asarray(values, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class RunMetrics:
    """Numbers that summarise one run (see :meth:`SimulationLog.metrics`).

    Attributes:
        steps: Number of steps.
        jitter: Total variation of the joint velocities [rad/s]: the sum over
            steps and joints of ``|qdot(k+1) - qdot(k)|``.
        max_q: Largest value of each joint over the run, final state included, shape (n,) [rad].
        final_p: Affine dexterity of the last step.
        final_position: End-effector position after the last step [m].
        max_abs_lambda: Largest ``|lam_i|`` over the run (NaN when the method has none).
        median_solve_time: Median solve time of a step [s].
        p99_solve_time: 99th percentile of the solve time [s].
        statuses: How many steps ended with each status.
    """

    steps: int
    jitter: float
    max_q: FloatArray
    final_p: float
    final_position: FloatArray
    max_abs_lambda: float
    median_solve_time: float
    p99_solve_time: float
    statuses: Mapping[str, int]


@dataclass(frozen=True, eq=False)
class SimulationLog:
    """Everything one closed-loop run recorded, one row per step.

    Row ``k`` holds the state *before* step ``k`` and that step's outcome
    (the CSV contract of DESIGN.md). The state after the last step is
    ``q_end`` / ``position_end``.

    Attributes:
        method: Name of the method that ran.
        dt: Control period [s].
        t: Time of each step, shape (N,) [s].
        q: Joint coordinates before each step, shape (N, n) [rad or m].
        position: End-effector position before each step, shape (N, 2 or 3) [m].
        p: Affine dexterity of each step, shape (N,).
        lam: Lagrange multipliers of each step, shape (N, m); NaN when the
            method has none or the step was a safe step.
        status: Status word of each step, shape (N,).
        binding: Binding (or broken) limit of each step, ``""`` when none, shape (N,).
        path: How each step was computed (``"ratio-test"``, ``"highs"``, ...), shape (N,).
        clamped: True where a classical step was clamped to the end-stops, shape (N,).
        solve_time: Wall time of each step's method [s], shape (N,).
        q_end: Joint coordinates after the last step, shape (n,).
        position_end: End-effector position after the last step [m].
        joint_names: One name per joint.
        name: Name of the run (e.g. the scenario's).
        warm_start: Whether the LP solver was warm-started across steps.
    """

    method: str
    dt: float
    t: FloatArray
    q: FloatArray
    position: FloatArray
    p: FloatArray
    lam: FloatArray
    status: NDArray[np.str_]
    binding: NDArray[np.str_]
    path: NDArray[np.str_]
    clamped: NDArray[np.bool_]
    solve_time: FloatArray
    q_end: FloatArray
    position_end: FloatArray
    joint_names: tuple[str, ...]
    name: str = ""
    warm_start: bool = True

    def __post_init__(self) -> None:
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False  # a log is a value: its arrays are read-only

    @property
    def steps(self) -> int:
        """Number of steps."""
        return int(self.t.size)

    def joint_velocities(self) -> FloatArray:
        """Applied joint velocity of each step, ``(q(k+1) - q(k)) / dt``, shape (N, n) [rad/s]."""
        q_all = np.vstack([self.q, self.q_end])
        return np.diff(q_all, axis=0) / self.dt

    def jitter(self) -> float:
        """Total variation of the joint velocities: ``sum_k sum_i |qdot_i(k+1) - qdot_i(k)|``.

        Returns:
            The jitter [rad/s]; 0 for a run of one step.
        """
        return float(np.abs(np.diff(self.joint_velocities(), axis=0)).sum())

    def metrics(self) -> RunMetrics:
        """The run's summary numbers (jitter, extremes, final state, solve times)."""
        lam = np.abs(self.lam)
        has_lam = bool(np.isfinite(lam).any())
        values, counts = np.unique(self.status, return_counts=True)
        return RunMetrics(
            steps=self.steps,
            jitter=self.jitter(),
            max_q=np.vstack([self.q, self.q_end]).max(axis=0),
            final_p=float(self.p[-1]) if self.steps else float("nan"),
            final_position=self.position_end.copy(),
            max_abs_lambda=float(np.nanmax(lam)) if has_lam else float("nan"),
            median_solve_time=float(np.median(self.solve_time)) if self.steps else 0.0,
            p99_solve_time=float(np.percentile(self.solve_time, 99)) if self.steps else 0.0,
            statuses={str(v): int(c) for v, c in zip(values, counts)},
        )

    def header(self) -> list[str]:
        """CSV header: ``t, q1..qn, x, y[, z], p, lam1..lamm`` then the extra columns."""
        n, m = self.q.shape[1], self.lam.shape[1]
        coords = ["x", "y", "z"][: self.position.shape[1]]
        return [
            "t",
            *(f"q{i + 1}" for i in range(n)),
            *coords,
            "p",
            *(f"lam{i + 1}" for i in range(m)),
            "status",
            "binding",
            "path",
            "clamped",
            "solve_time_us",
        ]

    def to_csv(self, path: str | Path) -> Path:
        """Write the log as CSV, one row per step (DESIGN.md's ``lpik simulate`` contract).

        Numbers are written with 12 significant digits; missing multipliers as ``nan``.

        Raises:
            ValueError: When the file cannot be written (names the path).
        """
        out = Path(path)
        try:
            handle = out.open("w", newline="", encoding="utf-8")
        except OSError as exc:
            raise ValueError(f"csv: cannot write {str(out)!r}: {exc.strerror or exc}") from None
        with handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(self.header())
            for k in range(self.steps):
                numbers = [self.t[k], *self.q[k], *self.position[k], self.p[k], *self.lam[k]]
                writer.writerow(
                    [
                        *(f"{v:.12g}" for v in numbers),
                        self.status[k],
                        self.binding[k],
                        self.path[k],
                        int(self.clamped[k]),
                        f"{self.solve_time[k] * 1e6:.1f}",
                    ]
                )
        return out


def _method_function(
    method: str, model: TaskModel, solver: HighsSolver | None
) -> Callable[[Problem], Result]:
    if method not in ALL_METHODS:
        raise ValueError(f"method: unknown method {method!r}; available: {', '.join(ALL_METHODS)}")
    if method in SOLVER_METHODS:
        return partial(METHODS[method], solver=solver)  # type: ignore[call-arg]
    return partial(solve, method=method, model=model)


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
) -> SimulationLog:
    """Run the closed loop for ``steps`` control steps and return the log.

    Args:
        model: The task model (pose, difference, jacobian, position).
        command: The command law (e.g. :class:`ClampedTarget`).
        q0: Start configuration, shape (n,) [rad or m].
        steps: Number of control steps (> 0).
        method: One of :data:`lpik.methods.ALL_METHODS`.
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

    Returns:
        The :class:`SimulationLog` of the run.

    Raises:
        ValueError: For a bad method, step count, period or start configuration.
    """
    if not (isinstance(steps, int | np.integer) and steps > 0):
        raise ValueError(f"steps: must be a whole number > 0, got {steps!r}")
    if not (isinstance(dt, int | float) and np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt: must be a finite number > 0, got {dt!r}")
    q = np.array(q0, dtype=np.float64)
    n = model.n_joints
    if q.shape != (n,) or not np.isfinite(q).all():
        raise ValueError(f"q0: must be {n} finite joint coordinates, got {q0!r}")
    step_fn = _method_function(method, model, HighsSolver() if warm_start else None)
    limits = list(standard_limits(model) if limits is None else limits)
    weights = dict(weights or {})
    weights.setdefault("joint_names", model.joint_names)
    m = model.task_dim
    rows: dict[str, list[Any]] = {k: [] for k in ("q", "pos", "p", "lam", "st", "bd", "pa", "cl")}
    times = np.empty(steps)
    q_prev: FloatArray | None = None
    for k in range(steps):
        dw = command(model, q, float(dt))
        problem = build_problem(model.jacobian(q), dw, q, limits, dt=dt, q_prev=q_prev, **weights)
        start = time.perf_counter()
        result = step_fn(problem)
        times[k] = time.perf_counter() - start
        q_next, clamped = _applied(problem, result)
        rows["q"].append(q)
        rows["pos"].append(np.asarray(model.position(q), dtype=np.float64))
        rows["p"].append(result.p if result.moved else 0.0)
        rows["lam"].append(_nan_if_none(result.lam if result.moved else None, m))
        rows["st"].append(result.status)
        rows["bd"].append(result.binding or "")
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
        binding=np.array(rows["bd"], dtype=str),
        path=np.array(rows["pa"], dtype=str),
        clamped=np.array(rows["cl"], dtype=bool),
        solve_time=times,
        q_end=q,
        position_end=np.asarray(model.position(q), dtype=np.float64),
        joint_names=tuple(model.joint_names),
        name=name,
        warm_start=warm_start,
    )


def _applied(problem: Problem, result: Result) -> tuple[FloatArray, bool]:
    """The configuration the machine reaches, and whether it was clamped to the end-stops."""
    if not result.moved:
        return problem.q0.copy(), False
    if result.status == st.VIOLATES_LIMITS:
        q = np.clip(result.q, problem.q_min, problem.q_max)
        return q, bool(np.any(q != result.q))
    return np.asarray(result.q, dtype=np.float64).copy(), False
