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
``J``), or the ratio test's answer fails its check, the singular path
(:mod:`lpik.methods.singular`) solves the LP through ``J``'s singular value
decomposition; the general LP (HiGHS) takes what that path cannot (more than
two free multiplier directions under finite multiplier bounds).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from lpik.continuation import around_motion
from lpik.highs import HighsSolver
from lpik.labels import code_labels
from lpik.methods.assembly import (
    criterion,
    finish,
    kernel_args,
    lp_over,
    reference_pull,
    solver_for,
    unsolved_step,
)
from lpik.methods.duals import binding_from_duals
from lpik.methods.engines import compiled_step
from lpik.methods.kkt import AffineSolution, affine_solution, smoothing
from lpik.methods.ratio import limit_code
from lpik.methods.singular import INFEASIBLE as SINGULAR_INFEASIBLE
from lpik.methods.singular import OK as SINGULAR_OK
from lpik.methods.singular import singular_core
from lpik.problem import Problem
from lpik.result import CHECK_FAILED, INFEASIBLE, OPTIMAL, Result, safe_step
from lpik.tolerances import (
    EQUALITY_RTOL,
    FULL_P,
    INTERVAL_TOL,
    RATE_TOL,
    SLACK_TOL,
)
from lpik.types import FloatArray

#: The ways :func:`lp2` can solve a step (its ``path`` argument).
PATHS = ("auto", "ratio-test", "singular", "highs", "compiled")


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

    Ties go to the first entry in order (joint bounds, then multipliers, then rows),
    upper bounds before lower ones; limits within :data:`INTERVAL_TOL` of each
    other in ``p`` tie (the rule of :mod:`lpik.methods.ratio`, which the compiled
    ratio test compiles as it is), so that two paths cannot name two limits.
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
        # Divide only where the rate counts: a rate below ``eps`` may overflow.
        up_hi = np.divide(s_hi, b, out=np.full_like(b, np.inf), where=pos)
        up_lo = np.divide(s_lo, -b, out=np.full_like(b, np.inf), where=neg)
        low_hi = np.divide(s_hi, b, out=np.full_like(b, -np.inf), where=neg)
        low_lo = np.divide(-s_lo, b, out=np.full_like(b, -np.inf), where=pos)
    first_hi, first_lo = float(up_hi.min(initial=np.inf)), float(up_lo.min(initial=np.inf))
    last_hi, last_lo = float(low_hi.max(initial=-np.inf)), float(low_lo.max(initial=-np.inf))
    p_hi = min(1.0, first_hi, first_lo)
    p_lo = max(0.0, last_hi, last_lo)

    def label(upper_side: bool, by_hi: float, by_lo: float) -> str:  # the tie rule's choice
        code = limit_code(a, b, lo, hi, a.size, eps, upper_side, by_hi, by_lo)
        return (hi_labels if code % 2 else lo_labels)[code // 2]

    if p_hi < p_lo - INTERVAL_TOL:
        if p_lo > 1.0:
            return RatioTest(False, 0.0, label(False, last_hi, last_lo))
        return RatioTest(False, 0.0, label(True, first_hi, first_lo))
    p = max(p_hi, p_lo)
    return RatioTest(True, p, label(True, first_hi, first_lo) if p < FULL_P else None)


@around_motion
def lp2(
    problem: Problem,
    *,
    path: str = "auto",
    solver: HighsSolver | None = None,
    name_outside: bool = True,
) -> Result:
    """Solve LP2 (eqs. 15-18) with the smoothing term (sec. 3.1) and multiplier bounds (sec. 3.2).

    Joints outside their end-stops, and joints whose bounds coincide, are
    pinned (:func:`pinned_system`): the criterion is resolved over the others,
    which carry the command as far as they can.

    Args:
        problem: The step to solve. ``M``, ``f``, ``Lambda``, ``q_ref`` weight the
            criterion; ``lam_min``/``lam_max`` bound the multipliers.
        path: ``"auto"`` (ratio test when valid, else the singular path, else
            HiGHS; ``"ratio-test"`` is the same), ``"singular"`` (the singular
            path first, :mod:`lpik.methods.singular`), ``"highs"`` (the general
            LP, the reference) or ``"compiled"`` (the same order compiled by
            numba, :mod:`lpik.fast`).
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across steps.
        name_outside: From a state outside its limits (status ``recovering``),
            name the first limit it is outside of (the default), or, ``False``,
            the limit that stops ``p`` (:func:`lpik.methods.lp2s.lp2s`'s passes).

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
    if path == "compiled":  # the compiled engine (lpik.methods.engines)
        return compiled_step("lp2")(problem, solver)
    # the HiGHS path needs the affine solution only to weigh sec. 3.1's pull
    ratio = path in ("auto", "ratio-test")
    affine = affine_solution(problem) if ratio or problem.Lambda.any() else None
    if ratio and affine is not None:
        result = _ratio_path(problem, affine, start, name_outside)
        if result.status != CHECK_FAILED:
            return result
    if path != "highs":
        result = _singular_path(problem, start, name_outside)
        if result is not None:
            return result
    return _highs_path(problem, solver, start, smoothing(problem, affine), name_outside)


def _singular_path(problem: Problem, start: float, name_outside: bool) -> Result | None:
    """LP2 by :func:`~lpik.methods.singular.singular_core`; ``None`` where HiGHS must decide."""
    J, dw, H, _, c, c_ref, lower, upper, lam_min, lam_max, G, g = kernel_args(problem)
    dq, lam = np.empty(problem.n), np.empty(problem.m)
    pull = np.ones(1)
    code, p, binding, _ = singular_core(J, dw, H, c, c_ref, lower, upper, lam_min, lam_max, G,
                                        g, dq, lam, pull)  # fmt: skip
    if code not in (SINGULAR_OK, SINGULAR_INFEASIBLE):
        return None
    labels = code_labels(*problem.step_bounds()[2:], problem.m, problem.row_labels)
    label = None if binding < 0 else labels[binding]
    if code == SINGULAR_INFEASIBLE:
        return safe_step(problem, "lp2", INFEASIBLE, label, solve_time=time.perf_counter() - start,
                         path="singular", name_outside=name_outside)  # fmt: skip
    result = finish(problem, "lp2", dq, p, lam, label, start, "singular", name_outside=name_outside)
    return pulled(result, float(pull[0]))


def pulled(result: Result, scale: float) -> Result:
    """``result`` reporting the share ``scale`` of sec. 3.1's pull its step took.

    A safe step takes no pull and keeps :attr:`~lpik.result.Result.pull_scale` 1.
    """
    return replace(result, pull_scale=scale) if result.moved and scale != 1.0 else result


def _ratio_path(problem: Problem, aff: AffineSolution, start: float, name_outside: bool) -> Result:
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
            name_outside=name_outside,
        )
    p = test.p
    result = finish(
        problem,
        "lp2",
        aff.a_q + p * aff.b_q,
        p,
        aff.a_l + p * aff.b_l,
        test.binding,
        start,
        "ratio-test",
        name_outside=name_outside,
    )
    return pulled(result, aff.smoothing)


def _highs_path(
    problem: Problem,
    solver: HighsSolver | None,
    start: float,
    scale: float = 1.0,
    name_outside: bool = True,
) -> Result:
    n, m = problem.n, problem.m
    H, c = criterion(problem)
    c = c - (1.0 - scale) * reference_pull(problem)  # sec. 3.1's pull, scaled
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
        return unsolved_step(problem, "lp2", sol.status, A_eq, b_eq, m, start, name_outside)
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
    binding = binding_from_duals(
        problem, sol, lp, p, A_eq.shape[0], lam_slice=slice(n, n + m), pinned=pinned
    )
    result = finish(problem, "lp2", dq, p, lam, binding, start, "highs", name_outside=name_outside)
    return pulled(result, scale)


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
