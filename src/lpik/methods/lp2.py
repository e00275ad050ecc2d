"""LP2: affine dexterity with a quadratic criterion (eqs. 15-18, secs. 3.1 and 3.2).

LP2 maximises ``p`` over ``(q, lam, p)`` subject to the optimality conditions
of the quadratic criterion (eq. 18, with sec. 3.1's smoothing term)::

    [[M + Lambda, J^T,  0 ],     [q  ]     [M q0 + Lambda q_ref + f]
     [J,          0,   -dw]]  @  [lam]  =  [J q0                   ]
                                 [p  ]

and the bounds on ``q`` (end-stops, eq. 13; step bounds, eq. 14), on ``lam``
(sec. 3.2), on ``p`` (0 <= p <= 1) and the extra rows ``G q <= h``.

When the KKT matrix ``K = [[M + Lambda, J^T], [J, 0]]`` is nonsingular, the
equality rows fix ``q`` and ``lam`` as affine functions of ``p``:
``q(p) = q0 + a_q + p b_q`` and ``lam(p) = a_l + p b_l``. Every bound then
limits ``p`` to an interval, and the LP's optimum is the largest ``p`` in the
intersection of these intervals with [0, 1]: a ratio test. That is an exact
solution of the LP, not an approximation. When ``K`` is singular or
ill-conditioned (the Schur complement ``S = J (M + Lambda)^-1 J^T`` has a
condition number above :data:`MAX_SCHUR_CONDITION`, e.g. at a singularity of
``J``), the general LP is solved by HiGHS instead.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from lpik.highs import HighsSolver
from lpik.methods.assembly import criterion, finish, lp_over, solver_for, unsolved_step
from lpik.methods.duals import binding_from_duals
from lpik.problem import Problem
from lpik.result import CHECK_FAILED, INFEASIBLE, OPTIMAL, Result, safe_step
from lpik.tolerances import (
    EQUALITY_RTOL,
    FULL_P,
    INTERVAL_TOL,
    MAX_SCHUR_CONDITION,
    RATE_TOL,
    SLACK_TOL,
)
from lpik.types import FloatArray

#: The ways :func:`lp2` can solve a step (its ``path`` argument).
PATHS = ("auto", "ratio-test", "highs", "compiled")


@dataclass(frozen=True, eq=False)
class AffineSolution:
    """``dq(p) = a_q + p b_q`` and ``lam(p) = a_l + p b_l``: eq. 18's equality rows solved."""

    a_q: FloatArray
    b_q: FloatArray
    a_l: FloatArray
    b_l: FloatArray


def pinned_system(problem: Problem) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Eq. 18's data with the pinned joints fixed: ``(J', H', c', w_fixed)``.

    A pinned joint (:meth:`~lpik.problem.Problem.pinned`: outside its end-stops,
    or with coinciding bounds) moves by its fixed ``d``; the criterion is
    minimised over the free joints ``F`` alone (its rows for pinned joints are
    dropped), subject to ``J_F dq_F = p dw - J_P d``. Written over all joints:
    ``J'`` is ``J`` with the pinned columns zeroed, ``H'`` is ``H`` with the
    pinned rows and columns replaced by the identity, ``c'`` is
    ``c_F - H_FP d`` on the free joints and ``d`` on the pinned ones, and
    ``w_fixed = J_P d``. Then ``H' dq + J'^T lam = c'`` and
    ``J' dq + w_fixed = p dw`` are eq. 18 over the free joints, and give
    ``dq_P = d``. Without pinned joints this is ``(J, H, c, 0)``.
    """
    H, c = criterion(problem)
    mask, d = problem.pinned()
    if not mask.any():
        return problem.J, H, c, np.zeros(problem.m)
    free = ~mask
    c = np.where(free, c - H @ d, d)
    H = np.where(free[:, None] & free[None, :], H, np.diag(mask.astype(np.float64)))
    J = np.where(free[None, :], problem.J, 0.0)
    return J, H, c, problem.J @ d


def affine_solution(problem: Problem) -> AffineSolution | None:
    """Solve eq. 18's equality rows for ``dq`` and ``lam`` as affine functions of ``p``.

    With ``H = M + Lambda`` (positive definite) and ``c = f + Lambda (q_ref - q0)``,
    the rows read ``H dq + J^T lam = c`` and ``J dq = p dw``. Eliminating ``dq``
    leaves the Schur complement ``S lam = J H^-1 c - p dw`` with
    ``S = J H^-1 J^T`` (one factorisation, two right-hand sides). Pinned joints
    enter through :func:`pinned_system` (``S lam = J' H'^-1 c' + w_fixed - p dw``).

    Returns:
        The affine solution, or ``None`` when ``S`` is singular or its condition
        number exceeds :data:`MAX_SCHUR_CONDITION`.
    """
    J, H, c, w_fixed = pinned_system(problem)
    H_factor = sla.cho_factor(H)
    HinvJt = sla.cho_solve(H_factor, J.T)
    Hinvc = sla.cho_solve(H_factor, c)
    S = J @ HinvJt
    S = 0.5 * (S + S.T)
    eig = np.linalg.eigvalsh(S)
    if eig[-1] <= 0 or eig[0] <= eig[-1] / MAX_SCHUR_CONDITION:
        return None
    S_factor = sla.cho_factor(S)
    rhs = np.column_stack([J @ Hinvc + w_fixed, -problem.dw])
    lam_ab = sla.cho_solve(S_factor, rhs)
    a_l, b_l = lam_ab[:, 0], lam_ab[:, 1]
    return AffineSolution(a_q=Hinvc - HinvJt @ a_l, b_q=-HinvJt @ b_l, a_l=a_l, b_l=b_l)


@dataclass(frozen=True)
class RatioTest:
    """Outcome of the ratio test: the largest feasible ``p`` and what limits it."""

    feasible: bool
    p: float
    binding: str | None


def ratio_test(
    a: FloatArray,
    b: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    lo_labels: tuple[str, ...],
    hi_labels: tuple[str, ...],
) -> RatioTest:
    """Largest ``p`` in [0, 1] with ``lo <= a + p b <= hi`` for every entry.

    Ties go to the first entry in order (joint bounds, then multipliers, then rows).
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        s_hi = hi - a
        s_lo = a - lo
        s_hi = np.where((s_hi < 0) & (s_hi >= -SLACK_TOL * np.maximum(1.0, np.abs(hi))), 0.0, s_hi)
        s_lo = np.where((s_lo < 0) & (s_lo >= -SLACK_TOL * np.maximum(1.0, np.abs(lo))), 0.0, s_lo)
        eps = RATE_TOL * max(1.0, float(np.abs(b).max(initial=0.0)))
        pos, neg = b > eps, b < -eps
        flat = ~(pos | neg)
        stuck_hi = flat & (s_hi < 0)
        stuck_lo = flat & (s_lo < 0)
        if stuck_hi.any():
            return RatioTest(False, 0.0, hi_labels[int(np.argmax(stuck_hi))])
        if stuck_lo.any():
            return RatioTest(False, 0.0, lo_labels[int(np.argmax(stuck_lo))])
        # a + p b <= hi: p <= s_hi / b for b > 0, p >= s_hi / b for b < 0.
        # a + p b >= lo: p <= s_lo / -b for b < 0, p >= -s_lo / b for b > 0.
        up_hi = np.where(pos, s_hi / b, np.inf)
        up_lo = np.where(neg, s_lo / -b, np.inf)
        low_hi = np.where(neg, s_hi / b, -np.inf)
        low_lo = np.where(pos, -s_lo / b, -np.inf)
    i_hi, i_lo = int(np.argmin(up_hi)), int(np.argmin(up_lo))
    if up_hi[i_hi] <= up_lo[i_lo]:
        p_up, up_label = float(up_hi[i_hi]), hi_labels[i_hi]
    else:
        p_up, up_label = float(up_lo[i_lo]), lo_labels[i_lo]
    j_hi, j_lo = int(np.argmax(low_hi)), int(np.argmax(low_lo))
    if low_hi[j_hi] >= low_lo[j_lo]:
        p_down, down_label = float(low_hi[j_hi]), hi_labels[j_hi]
    else:
        p_down, down_label = float(low_lo[j_lo]), lo_labels[j_lo]
    p_hi = min(1.0, p_up)
    p_lo = max(0.0, p_down)
    if p_hi < p_lo - INTERVAL_TOL:
        return RatioTest(False, 0.0, down_label if p_lo > 1.0 else up_label)
    p = max(p_hi, p_lo)
    return RatioTest(True, p, up_label if p < FULL_P else None)


def lp2(problem: Problem, *, path: str = "auto", solver: HighsSolver | None = None) -> Result:
    """Solve LP2 (eqs. 15-18) with the smoothing term (sec. 3.1) and multiplier bounds (sec. 3.2).

    Joints outside their end-stops, and joints whose bounds coincide, are
    pinned (:func:`pinned_system`): the criterion is resolved over the others,
    which carry the command as far as they can.

    Args:
        problem: The step to solve. ``M``, ``f``, ``Lambda``, ``q_ref`` weight the
            criterion; ``lam_min``/``lam_max`` bound the multipliers.
        path: ``"auto"`` (ratio test when valid, else HiGHS), ``"ratio-test"``
            (fails over to HiGHS all the same when ``K`` is singular), ``"highs"``
            (the general LP, the reference) or ``"compiled"`` (the ratio test
            compiled by numba, :mod:`lpik.fast`; HiGHS when ``K`` is singular).
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across steps.

    Returns:
        The step; ``binding`` names the limit that keeps ``p < 1`` (e.g.
        ``"joint 1 upper end-stop"``, ``"multiplier 2 upper bound"``), or the
        conflicting limit when the step is infeasible even at ``p = 0`` (on the
        HiGHS path: :func:`~lpik.methods.duals.conflict_label`).

    Raises:
        ValueError: For an unknown ``path``.
        MissingBackendError: For ``path="compiled"`` without numba installed.
    """
    if path not in PATHS:
        raise ValueError(f"path: unknown LP2 path {path!r}; available: {', '.join(PATHS)}")
    start = time.perf_counter()
    if path == "compiled":
        from lpik.fast.batch import solve_compiled  # numba is optional: import on use

        return solve_compiled(problem, solver)
    if path != "highs":
        affine = affine_solution(problem)
        if affine is not None:
            result = _ratio_path(problem, affine, start)
            if result.status != CHECK_FAILED:
                return result
    return _highs_path(problem, solver, start)


def _ratio_path(problem: Problem, aff: AffineSolution, start: float) -> Result:
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    lam_lo_labels, lam_hi_labels = problem.multiplier_labels()
    G = problem.G
    g = problem.h - G @ problem.q0
    a = np.concatenate([aff.a_q, aff.a_l, G @ aff.a_q])
    b = np.concatenate([aff.b_q, aff.b_l, G @ aff.b_q])
    lo = np.concatenate([lower, problem.lam_min, np.full(g.size, -np.inf)])
    hi = np.concatenate([upper, problem.lam_max, g])
    rows = tuple(problem.row_labels)
    test = ratio_test(
        a, b, lo, hi, lower_labels + lam_lo_labels + rows, upper_labels + lam_hi_labels + rows
    )
    if not test.feasible:
        return safe_step(
            problem,
            "lp2",
            INFEASIBLE,
            test.binding,
            solve_time=time.perf_counter() - start,
            path="ratio-test",
        )
    p = test.p
    return finish(
        problem,
        "lp2",
        aff.a_q + p * aff.b_q,
        p,
        aff.a_l + p * aff.b_l,
        test.binding,
        start,
        "ratio-test",
    )


def _highs_path(problem: Problem, solver: HighsSolver | None, start: float) -> Result:
    n, m = problem.n, problem.m
    H, c = criterion(problem)
    lower, upper = problem.step_bounds()[:2]
    pinned, d = problem.pinned()
    free = ~pinned
    lower, upper = np.where(pinned, d, lower), np.where(pinned, d, upper)
    # eq. 18's criterion rows for the free joints only (a pinned joint is fixed)
    A_eq = np.block(
        [
            [H[free], problem.J[:, free].T, np.zeros((int(free.sum()), 1))],
            [problem.J, np.zeros((m, m)), -problem.dw[:, None]],
        ]
    )
    b_eq = np.concatenate([c[free], np.zeros(m)])
    cost = np.zeros(n + m + 1)
    cost[-1] = -1.0
    col_lower = np.concatenate([lower, problem.lam_min, [0.0]])
    col_upper = np.concatenate([upper, problem.lam_max, [1.0]])
    lp = lp_over(problem, cost, A_eq, b_eq, col_lower, col_upper)
    sol = solver_for(solver).solve(lp)
    if sol.status != OPTIMAL:
        return unsolved_step(problem, "lp2", sol.status, A_eq, b_eq, m, start)
    dq, lam, p = sol.x[:n], sol.x[n : n + m], float(sol.x[-1])
    failure = _criterion_failure(problem, H[free], c[free], dq, lam, free)
    if failure is not None:
        return safe_step(
            problem,
            "lp2",
            CHECK_FAILED,
            failure,
            solve_time=time.perf_counter() - start,
            path="highs",
        )
    binding = binding_from_duals(problem, sol, lp, p, A_eq.shape[0], lam_slice=slice(n, n + m))
    return finish(problem, "lp2", dq, p, lam, binding, start, "highs")


def _criterion_failure(
    problem: Problem,
    H: FloatArray,
    c: FloatArray,
    dq: FloatArray,
    lam: FloatArray,
    free: FloatArray,
) -> str | None:
    """Re-check eq. 18's criterion rows ``H dq + J^T lam = c``, which :func:`finish` does not.

    Without them a solver's answer could be any LP1 step: the rows are what
    resolve the redundancy. ``H`` and ``c`` hold the free joints' rows only.
    Tolerance as for ``J dq = p dw`` (``EQUALITY_RTOL``).
    """
    if not (np.isfinite(dq).all() and np.isfinite(lam).all()):
        return "non-finite step"
    if not H.size:
        return None
    residual = float(np.abs(H @ dq + problem.J[:, free].T @ lam - c).max())
    scale = (
        np.abs(H).max() * np.abs(dq).max()
        + np.abs(problem.J).max() * np.abs(lam).max(initial=0.0)
        + np.abs(c).max()
    )
    if residual > EQUALITY_RTOL * max(1.0, float(scale)):
        return f"criterion rows of eq. 18 violated by {residual:.3g}"
    return None
