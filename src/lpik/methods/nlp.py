"""Schlemmer's nonlinear program with respect to affine manipulability (sec. 2.2).

The slow, exact baseline the LPs are compared with: the forward kinematics
(eq. 1) is used as it is, not linearised (eq. 2), so the end effector lands on
``w0 + p dw`` exactly (eq. 10), and the quadratic criterion resolves the
redundancy.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from scipy.optimize import OptimizeResult, minimize

from lpik.check import clip_to_bounds, worst_violation
from lpik.labels import SINGULARITY
from lpik.methods.assembly import criterion
from lpik.problem import Problem
from lpik.result import (
    CHECK_FAILED,
    INFEASIBLE,
    OPTIMAL,
    RECOVERING,
    SOLVER_ERROR,
    Result,
    safe_step,
)
from lpik.robots.base import TaskModel
from lpik.tolerances import FEASIBILITY_TOL, FULL_P, NONLINEAR_TOL, SLSQP_TOL
from lpik.types import FloatArray


def nlp(problem: Problem, model: TaskModel, *, max_iterations: int = 200) -> Result:
    """Maximise ``p`` subject to ``phi(q) - w0 = p (w_desired - w0)`` and the bounds (sec. 2.2).

    Solved by SQP (scipy's SLSQP) in two stages, lexicographically: first the
    largest ``p*`` in [0, 1] such that the nonlinear forward kinematics puts the
    end effector at ``w0 + p dw`` (eq. 10) within the end-stops (eq. 13), step
    bounds (eq. 14) and extra rows; then, with ``p >= p*``, the configuration
    that minimises the quadratic criterion (eq. 3 plus sec. 3.1's term).

    Args:
        problem: The step; ``problem.J`` is not used, ``problem.dw`` is the command.
        model: The task model whose ``pose``/``difference`` give ``phi`` and ``w - w0``.
        max_iterations: SLSQP iteration limit per stage.

    Returns:
        The step; ``lam`` is ``None``; ``residual`` is the nonlinear residual
        ``max |phi(q) - w0 - p dw|``; ``binding`` is the active limit with the
        largest multiplier when ``p < 1``.
    """
    start = time.perf_counter()
    if model.n_joints != problem.n or model.task_dim != problem.m:
        raise ValueError(
            f"model: {model.name} has {model.n_joints} joints and {model.task_dim} task "
            f"coordinates, the problem {problem.n} and {problem.m}"
        )
    n = problem.n
    w0 = model.pose(problem.q0)
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    g_rhs = problem.h - problem.G @ problem.q0
    lin_rows, lin_rhs, lin_labels = _inequalities(
        problem, lower, upper, lower_labels, upper_labels, g_rhs
    )
    constraints = [
        _task_constraint(problem, model, w0),
        {"type": "ineq", "fun": lambda x: lin_rhs - lin_rows @ x, "jac": lambda x: -lin_rows},
    ]
    box = [
        (lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None)
        for lo, hi in zip(lower, upper)
    ]
    options = {"maxiter": max_iterations, "ftol": SLSQP_TOL}
    first = minimize(
        lambda x: -x[n],
        np.zeros(n + 1),
        jac=lambda x: -np.eye(n + 1)[n],
        method="SLSQP",
        bounds=box + [(0.0, 1.0)],
        constraints=constraints,
        options=options,
    )
    if not first.success:
        # from a state outside its limits the program is often infeasible: recover
        return safe_step(
            problem,
            "nlp",
            INFEASIBLE if problem.recovering() else SOLVER_ERROR,
            str(first.message),
            solve_time=time.perf_counter() - start,
            path="slsqp",
        )
    p_star = float(np.clip(first.x[n], 0.0, 1.0))
    binding = None
    if p_star < FULL_P:  # no active limit: the kinematics itself stops p (a singularity)
        binding = _binding(first, lin_rows, lin_rhs, lin_labels, problem.m) or SINGULARITY
    second = _least_criterion(
        problem, first.x, box + [(_p_floor(p_star), 1.0)], constraints, options
    )
    x = second.x if second.success else first.x
    return _checked_result(problem, model, w0, x, binding, start)


def _task_constraint(problem: Problem, model: TaskModel, w0: FloatArray) -> dict[str, Any]:
    """Eq. 10 as SLSQP's equality: ``difference(w0, phi(q0 + dq)) - p dw = 0`` in ``(dq, p)``."""
    n, q0, dw = problem.n, problem.q0, problem.dw

    def task_eq(x: FloatArray) -> FloatArray:
        return model.difference(w0, model.pose(q0 + x[:n])) - x[n] * dw

    # The exact derivative of difference(w0, pose(q)) when the model offers it (orientation
    # rows: the inverse left Jacobian of SO(3)); J(q) is exact for vector tasks.
    exact = getattr(model, "difference_jacobian", None)

    def task_eq_jac(x: FloatArray) -> FloatArray:
        q = q0 + x[:n]
        jac = exact(w0, q) if exact is not None else model.jacobian(q)
        return np.hstack([jac, -dw[:, None]])

    return {"type": "eq", "fun": task_eq, "jac": task_eq_jac}


def _p_floor(p_star: float) -> float:
    """The second stage's lower bound on ``p``: ``p*``, less a margin below a full step."""
    return p_star if p_star >= FULL_P else max(0.0, p_star - 1e-9)


def _least_criterion(
    problem: Problem,
    x0: FloatArray,
    bounds: list[tuple[float | None, float | None]],
    constraints: list[dict[str, Any]],
    options: dict[str, Any],
) -> OptimizeResult:
    """The second stage: the least criterion (eq. 3 plus sec. 3.1's term) with ``p >= p*``."""
    n = problem.n
    H, c = criterion(problem)
    return minimize(
        lambda x: 0.5 * x[:n] @ H @ x[:n] - c @ x[:n],
        x0,
        jac=lambda x: np.append(H @ x[:n] - c, 0.0),
        method="SLSQP",
        bounds=bounds,
        constraints=constraints,
        options=options,
    )


def _checked_result(
    problem: Problem,
    model: TaskModel,
    w0: FloatArray,
    x: FloatArray,
    binding: str | None,
    start: float,
) -> Result:
    """The step ``x = (dq, p)``, clipped to its bounds and checked against eq. 10 and the limits."""
    n, q0, dw = problem.n, problem.q0, problem.dw
    dq = clip_to_bounds(problem, x[:n])
    p = float(np.clip(x[n], 0.0, 1.0))
    residual = float(np.abs(model.difference(w0, model.pose(q0 + dq)) - p * dw).max())
    violation = worst_violation(problem, dq)
    elapsed = time.perf_counter() - start
    if residual > NONLINEAR_TOL or violation.amount > FEASIBILITY_TOL:
        reason = violation.label if violation.amount > FEASIBILITY_TOL else "phi(q) - w0 != p dw"
        return safe_step(problem, "nlp", CHECK_FAILED, reason, solve_time=elapsed, path="slsqp")
    status, outside = OPTIMAL, problem.recovering()
    if outside:
        status, binding = RECOVERING, outside[0]
    return Result(
        q=q0 + dq,
        dq=dq,
        p=p,
        lam=None,
        status=status,
        binding=binding if p < FULL_P or outside else None,
        method="nlp",
        solve_time=elapsed,
        residual=residual,
        path="slsqp",
    )


def _inequalities(
    problem: Problem,
    lower: FloatArray,
    upper: FloatArray,
    lower_labels: tuple[str, ...],
    upper_labels: tuple[str, ...],
    g_rhs: FloatArray,
) -> tuple[FloatArray, FloatArray, list[str]]:
    """Finite bounds and extra rows as ``rows @ (dq, p) <= rhs`` (so SLSQP reports multipliers)."""
    n = problem.n
    rows, rhs, labels = [], [], []
    for i in range(n):
        e = np.zeros(n + 1)
        e[i] = 1.0
        if np.isfinite(upper[i]):
            rows.append(e)
            rhs.append(upper[i])
            labels.append(upper_labels[i])
        if np.isfinite(lower[i]):
            rows.append(-e)
            rhs.append(-lower[i])
            labels.append(lower_labels[i])
    for i in range(problem.G.shape[0]):
        rows.append(np.append(problem.G[i], 0.0))
        rhs.append(g_rhs[i])
        labels.append(problem.row_labels[i])
    if not rows:
        return np.zeros((0, n + 1)), np.zeros(0), []
    return np.array(rows), np.array(rhs), labels


def _binding(
    res: object, rows: FloatArray, rhs: FloatArray, labels: list[str], m: int
) -> str | None:
    """The active inequality with the largest SLSQP multiplier."""
    if not labels:
        return None
    x = res.x  # type: ignore[attr-defined]
    slack = rhs - rows @ x
    active = slack <= 1e-7 * np.maximum(1.0, np.abs(rhs))
    if not active.any():
        return None
    multipliers = np.asarray(getattr(res, "multipliers", np.zeros(m + len(labels))))
    ineq = (
        multipliers[m : m + len(labels)]
        if multipliers.size >= m + len(labels)
        else np.zeros(len(labels))
    )
    score = np.where(active, np.abs(ineq), -1.0)
    return labels[int(np.argmax(score))]
