"""Pieces shared by the methods: the quadratic criterion, the LP assembly, the finish."""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from lpik import result as st
from lpik.lp import HighsSolver, LinearProgram, LpSolution
from lpik.problem import Problem
from lpik.result import Result

FloatArray = NDArray[np.float64]

#: p at or above this counts as the full displacement (no binding limit).
FULL_P = 1.0 - 1e-9
#: A dual value (sensitivity of p to a limit) below this does not make a limit binding.
DUAL_TOL = 1e-9


def criterion(problem: Problem) -> tuple[FloatArray, FloatArray]:
    """``H = M + Lambda`` and ``c = f + Lambda (q_ref - q0)``: the criterion in ``dq``.

    Minimising eq. 3 plus sec. 3.1's ``Z2`` over ``dq = q - q0`` is minimising
    ``1/2 dq^T H dq - c^T dq``; eqs. 7, 16 and 18 are its optimality conditions.
    """
    H = problem.M + problem.Lambda
    c = problem.f + problem.Lambda @ (problem.q_ref - problem.q0)
    return H, c


def extra_rows(problem: Problem, n_cols: int) -> tuple[FloatArray, FloatArray]:
    """``G dq <= h - G q0`` padded with zero columns up to ``n_cols``."""
    G = problem.G
    rows = np.zeros((G.shape[0], n_cols))
    rows[:, : problem.n] = G
    return rows, problem.h - G @ problem.q0


def lp_over(
    problem: Problem,
    c: FloatArray,
    A_eq: FloatArray,
    b_eq: FloatArray,
    col_lower: FloatArray,
    col_upper: FloatArray,
    A_ub: FloatArray | None = None,
    b_ub: FloatArray | None = None,
) -> LinearProgram:
    """Stack equality rows, the problem's extra rows and optional ``A_ub x <= b_ub`` rows."""
    G, g = extra_rows(problem, c.size)
    blocks_A = [A_eq, G]
    lower = [b_eq, np.full(g.size, -np.inf)]
    upper = [b_eq, g]
    if A_ub is not None and b_ub is not None:
        blocks_A.append(A_ub)
        lower.append(np.full(b_ub.size, -np.inf))
        upper.append(b_ub)
    return LinearProgram(
        c=c,
        A=np.vstack(blocks_A),
        row_lower=np.concatenate(lower),
        row_upper=np.concatenate(upper),
        col_lower=col_lower,
        col_upper=col_upper,
    )


def binding_from_duals(
    problem: Problem,
    sol: LpSolution,
    lp: LinearProgram,
    p: float,
    n_eq: int,
    lam_slice: slice | None = None,
) -> str | None:
    """Name the limit that keeps ``p`` below 1, from the solver's duals.

    Among the bounds of ``dq`` (and of the multipliers) that are active, and the
    extra rows that are active, the one with the largest dual value (the largest
    sensitivity of the optimum to that limit) is binding.
    """
    if p >= FULL_P:
        return None
    n = problem.n
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    candidates: list[tuple[float, str]] = []
    x = sol.x

    def add_columns(
        sl: slice,
        lo: FloatArray,
        hi: FloatArray,
        lo_labels: tuple[str, ...],
        hi_labels: tuple[str, ...],
    ) -> None:
        values, duals = x[sl], sol.col_dual[sl]
        for i in range(values.size):
            at_lo = np.isfinite(lo[i]) and abs(values[i] - lo[i]) <= 1e-9 * max(1.0, abs(lo[i]))
            at_hi = np.isfinite(hi[i]) and abs(values[i] - hi[i]) <= 1e-9 * max(1.0, abs(hi[i]))
            if at_hi and (not at_lo or duals[i] <= 0):
                candidates.append((abs(duals[i]), hi_labels[i]))
            elif at_lo:
                candidates.append((abs(duals[i]), lo_labels[i]))

    add_columns(slice(0, n), lower, upper, lower_labels, upper_labels)
    if lam_slice is not None:
        lam_lo, lam_hi = problem.multiplier_labels()
        add_columns(lam_slice, problem.lam_min, problem.lam_max, lam_lo, lam_hi)
    r = problem.G.shape[0]
    if r:
        activity = lp.A[n_eq : n_eq + r] @ x
        rhs = lp.row_upper[n_eq : n_eq + r]
        for i in range(r):
            if abs(activity[i] - rhs[i]) <= 1e-9 * max(1.0, abs(rhs[i])):
                candidates.append((abs(sol.row_dual[n_eq + i]), problem.row_labels[i]))
    if not candidates:
        return None
    best = max(candidates, key=lambda item: item[0])
    return best[1]


def finish(
    problem: Problem,
    method: str,
    dq: FloatArray,
    p: float,
    lam: FloatArray | None,
    binding: str | None,
    start: float,
    path: str,
    status: str = st.OPTIMAL,
) -> Result:
    """Clip solver-tolerance excursions, re-check independently, and build the result.

    A step that fails :func:`lpik.result.check_step` is never returned: the
    result is the safe no-motion step with status ``check_failed``.
    """
    dq = st.clip_to_bounds(problem, dq)
    p = float(min(1.0, max(0.0, p)))
    failure = st.check_step(problem, dq, p, lam)
    elapsed = time.perf_counter() - start
    if failure is not None:
        return st.safe_step(
            problem, method, st.CHECK_FAILED, failure, solve_time=elapsed, path=path
        )
    return Result(
        q=problem.q0 + dq,
        dq=dq,
        p=p,
        lam=lam,
        status=status,
        binding=binding,
        method=method,
        solve_time=elapsed,
        residual=st.task_residual(problem, dq, p),
        path=path,
    )


def crossed_label(problem: Problem) -> str | None:
    """Label of the first joint whose lower step bound lies above its upper one, if any.

    That happens when ``q0`` is outside its end-stops by more than one step can
    repair: no step, not even ``p = 0``, is feasible.
    """
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    crossed = lower > upper
    if not crossed.any():
        return None
    i = int(np.argmax(crossed))
    return f"{lower_labels[i]} / {upper_labels[i]}"


def solver_for(solver: HighsSolver | None) -> HighsSolver:
    """The given reusable solver, or a fresh one."""
    return solver if solver is not None else HighsSolver()
