"""The independent check of a step: every bound, row and equation, with lpik's own tolerance.

After every solve, the answer is re-checked here (the idea of scipy's
``_check_result``): ``0 <= p <= 1``, the bounds on ``dq`` (eqs. 13-14), the
multiplier bounds (sec. 3.2), the extra rows and ``J dq = p dw`` (eq. 12).
A claimed success that fails the check is not returned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lpik.problem import Problem
from lpik.tolerances import EQUALITY_RTOL, FEASIBILITY_TOL
from lpik.types import FloatArray


@dataclass(frozen=True)
class Violation:
    """The worst limit a step breaks, by how much, and its label."""

    amount: float
    label: str | None


def worst_violation(problem: Problem, dq: FloatArray, lam: FloatArray | None = None) -> Violation:
    """The largest scaled violation of any bound or row by a step (eqs. 13-14, sec. 3.2, G q <= h).

    Each violation is divided by ``max(1, |bound|)`` so that one tolerance fits
    bounds of any size.
    """
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    worst = Violation(0.0, None)
    checks: list[tuple[FloatArray, FloatArray, tuple[str, ...]]] = [
        (lower - dq, lower, lower_labels),
        (dq - upper, upper, upper_labels),
    ]
    if lam is not None:
        lam_lo, lam_hi = problem.multiplier_labels()
        checks.append((problem.lam_min - lam, problem.lam_min, lam_lo))
        checks.append((lam - problem.lam_max, problem.lam_max, lam_hi))
    if problem.G.shape[0]:
        rhs = problem.h - problem.G @ problem.q0
        checks.append((problem.G @ dq - rhs, rhs, tuple(problem.row_labels)))
    for excess, bound, labels in checks:
        if excess.size == 0:
            continue
        with np.errstate(invalid="ignore"):
            scaled = excess / np.maximum(1.0, np.where(np.isfinite(bound), np.abs(bound), 1.0))
        scaled = np.where(np.isnan(scaled), -np.inf, scaled)
        i = int(np.argmax(scaled))
        if scaled[i] > worst.amount:
            worst = Violation(float(scaled[i]), labels[i])
    return worst


def task_residual(problem: Problem, dq: FloatArray, p: float) -> float:
    """``max |J dq - p dw|``: how far a step is from the linearised task (eqs. 12, 15).

    For a step of a moving arm (``problem.last``, :mod:`lpik.continuation`) the smaller
    of the residuals of its two lines: around the current motion,
    ``max |J (dq - last) - p (dw - J last)|`` with ``last`` as the bounds clip it, and,
    where no step around the motion exists, through rest
    (:func:`lpik.continuation.through_rest`), ``max |J dq - p dw|``.
    """
    through_rest = float(np.abs(problem.J @ dq - p * problem.dw).max())
    motion = problem.motion
    if motion is None:
        return through_rest
    kept = problem.J @ motion
    return min(through_rest, float(np.abs(problem.J @ dq - kept - p * (problem.dw - kept)).max()))


def check_step(problem: Problem, dq: FloatArray, p: float, lam: FloatArray | None) -> str | None:
    """Independent re-check of an LP answer; ``None`` when it holds, else what fails.

    Checks ``0 <= p <= 1``, every bound and row (:func:`worst_violation`) within
    :data:`FEASIBILITY_TOL`, and ``J dq = p dw`` within :data:`EQUALITY_RTOL`.
    """
    if not (math.isfinite(p) and -FEASIBILITY_TOL <= p <= 1 + FEASIBILITY_TOL):
        return f"p = {p} outside [0, 1]"
    if not np.isfinite(dq).all() or (lam is not None and not np.isfinite(lam).all()):
        return "non-finite step"
    violation = worst_violation(problem, dq, lam)
    if violation.amount > FEASIBILITY_TOL:
        return f"{violation.label} violated by {violation.amount:.3g}"
    scale = float(np.abs(problem.J).max() * np.abs(dq).max() + np.abs(problem.dw).max())
    if task_residual(problem, dq, p) > EQUALITY_RTOL * max(1.0, scale):
        return "J dq != p dw"
    return None


def clip_to_bounds(problem: Problem, dq: FloatArray) -> FloatArray:
    """Remove solver-tolerance excursions (below :data:`FEASIBILITY_TOL`) past the bounds."""
    lower, upper, _, _ = problem.step_bounds()
    return np.clip(dq, lower, upper)


def loop_check(J, dw, p, dq, lam, lam_min, lam_max, G, g):
    """:func:`check_step` as plain loops, for the loop-level LP2 solvers and their kernels.

    The multiplier bounds and the rows ``G dq <= g`` within :data:`FEASIBILITY_TOL`
    (relative to ``max(1, |bound|)``), ``J dq = p dw`` within :data:`EQUALITY_RTOL`
    (relative to ``max(1, |J| |dq| + |dw|)``); ``dq`` is already within its bounds.
    :func:`lpik.fast.lp2_kernel.lp2_core` and :func:`lpik.methods.singular.singular_core`
    call it on their answers (compiled there). Returns ``(ok, max |J dq - p dw|)``.
    """
    m, n = J.shape
    worst = 0.0
    for k in range(m):
        if lam[k] < lam_min[k]:
            worst = max(worst, (lam_min[k] - lam[k]) / max(1.0, abs(lam_min[k])))
        if lam[k] > lam_max[k]:
            worst = max(worst, (lam[k] - lam_max[k]) / max(1.0, abs(lam_max[k])))
    for j in range(G.shape[0]):
        s = 0.0
        for i in range(n):
            s += G[j, i] * dq[i]
        if s > g[j]:
            worst = max(worst, (s - g[j]) / max(1.0, abs(g[j])))
    jmax, qmax, wmax, res = 0.0, 0.0, 0.0, 0.0
    for a in range(m):
        s = -p * dw[a]
        for i in range(n):
            s += J[a, i] * dq[i]
            jmax = max(jmax, abs(J[a, i]))
        res = max(res, abs(s))
        wmax = max(wmax, abs(dw[a]))
    for i in range(n):
        qmax = max(qmax, abs(dq[i]))
    ok = worst <= FEASIBILITY_TOL and res <= EQUALITY_RTOL * max(1.0, jmax * qmax + wmax)
    return ok, res
