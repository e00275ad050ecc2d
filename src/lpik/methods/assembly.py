"""What the LP methods share: the criterion, the LP's assembly, the finish of a step.

- :func:`criterion`: eq. 3 plus sec. 3.1's term as ``H``, ``c`` over ``dq``;
- :func:`lp_over`: a method's equality rows, the problem's extra rows and bounds
  as one :class:`~lpik.highs.LinearProgram`;
- :func:`finish`: clip, re-check independently (:mod:`lpik.check`), build the
  :class:`~lpik.result.Result`;
- :func:`unsolved_step`: the safe step of a solve that did not end optimal.
"""

from __future__ import annotations

import time

import numpy as np

from lpik import check
from lpik.highs import HighsSolver, LinearProgram
from lpik.methods.duals import conflict_label, extra_rows
from lpik.problem import Problem
from lpik.result import CHECK_FAILED, INFEASIBLE, OPTIMAL, RECOVERING, Result, safe_step
from lpik.types import FloatArray


def criterion(problem: Problem) -> tuple[FloatArray, FloatArray]:
    """``H = M + Lambda`` and ``c = f + Lambda (q_ref - q0)``: the criterion in ``dq``.

    Minimising eq. 3 plus sec. 3.1's ``Z2`` over ``dq = q - q0`` is minimising
    ``1/2 dq^T H dq - c^T dq``; eqs. 7, 16 and 18 are its optimality conditions.
    """
    H = problem.M + problem.Lambda
    c = problem.f + reference_pull(problem)
    return H, c


def reference_pull(problem: Problem) -> FloatArray:
    """``Lambda (q_ref - q0)``: sec. 3.1's part of ``c``, the pull towards ``q_ref``."""
    return problem.Lambda @ (problem.q_ref - problem.q0)


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


def finish(
    problem: Problem,
    method: str,
    dq: FloatArray,
    p: float,
    lam: FloatArray | None,
    binding: str | None,
    start: float,
    path: str,
    status: str = OPTIMAL,
    *,
    name_outside: bool = True,
) -> Result:
    """Clip solver-tolerance excursions, re-check independently, and build the result.

    A step that fails :func:`lpik.check.check_step` is never returned: the
    result is the safe step with status ``check_failed``. A step from a state
    outside its limits has status ``recovering`` and names the first such limit
    (:meth:`lpik.problem.Problem.recovering`); with ``name_outside=False`` it
    keeps ``binding``, the limit that stops ``p`` (what LP2 with saturation
    needs from each pass).
    """
    dq = check.clip_to_bounds(problem, dq)
    p = float(min(1.0, max(0.0, p)))
    failure = check.check_step(problem, dq, p, lam)
    elapsed = time.perf_counter() - start
    if failure is not None:
        return safe_step(problem, method, CHECK_FAILED, failure, solve_time=elapsed, path=path)
    outside = problem.recovering()
    if outside:
        status = RECOVERING
        binding = outside[0] if name_outside else binding
    return Result(
        q=problem.q0 + dq,
        dq=dq,
        p=p,
        lam=lam,
        status=status,
        binding=binding,
        method=method,
        solve_time=elapsed,
        residual=check.task_residual(problem, dq, p),
        path=path,
    )


def solver_for(solver: HighsSolver | None) -> HighsSolver:
    """The given reusable solver, or a fresh one."""
    return solver if solver is not None else HighsSolver()


def unsolved_step(
    problem: Problem,
    method: str,
    status: str,
    A_eq: FloatArray,
    b_eq: FloatArray,
    n_lam: int,
    start: float,
    name_outside: bool = True,
) -> Result:
    """The safe step of a HiGHS answer that is not optimal, naming the conflict if infeasible.

    Args:
        problem: The step.
        method: ``"lp1"`` or ``"lp2"``.
        status: The solver's status (an lpik status word).
        A_eq: The method's equality rows over ``(dq, lam, p)``, for :func:`conflict_label`.
        b_eq: Their right-hand side.
        n_lam: The number of multiplier columns in ``A_eq`` (0 for LP1).
        start: ``time.perf_counter()`` when the method started.
        name_outside: As for :func:`~lpik.result.safe_step`.
    """
    conflict = conflict_label(problem, A_eq, b_eq, n_lam) if status == INFEASIBLE else None
    elapsed = time.perf_counter() - start
    return safe_step(
        problem, method, status, conflict, solve_time=elapsed, path="highs",
        name_outside=name_outside,
    )  # fmt: skip


def is_diagonal(H: FloatArray) -> bool:
    """Whether ``H`` is diagonal, so that the kernels need not factorise it."""
    return bool(np.count_nonzero(H - np.diag(np.diagonal(H))) == 0)


def kernel_args(problem: Problem) -> tuple:
    """The arguments of the LP2 kernel for ``problem``, up to its outputs ``dq`` and ``lam``.

    ``(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max, G, g)`` with
    ``H`` and ``c = f`` the criterion (eq. 3), ``c_ref = Lambda (q_ref - q0)``
    sec. 3.1's pull, the bounds on ``dq`` (eqs. 13-14) and the rows ``G dq <= g``.
    """
    H, c = criterion(problem)
    c_ref = reference_pull(problem)
    lower, upper = problem.step_bounds()[:2]
    h_diag = is_diagonal(H)
    g = problem.h - problem.G @ problem.q0
    return (
        problem.J,
        problem.dw,
        H,
        h_diag,
        c - c_ref,
        c_ref,
        lower,
        upper,
        problem.lam_min,
        problem.lam_max,
        problem.G,
        g,
    )
