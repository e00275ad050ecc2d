"""The classical closed-form steps of sec. 2.1: pseudo-inverse, weighted, robust inverse.

These methods know no bounds. lpik never clamps their step (clamping would
break ``J dq = dw`` silently): it returns the method's own step and, when that
step breaks an end-stop, step bound or extra row, the status
``"violates_limits"`` with ``binding`` naming the limit broken worst. The
simulation layer decides what to do with such a step.

All three use ``H = M + Lambda`` and ``c = f + Lambda (q_ref - q0)``; with the
default ``Lambda = 0`` that is exactly the paper's ``M`` and ``f``.
"""

from __future__ import annotations

import time

import numpy as np

from lpik.check import task_residual, worst_violation
from lpik.methods.assembly import criterion
from lpik.problem import Problem
from lpik.result import OPTIMAL, SINGULAR, VIOLATES_LIMITS, Result, safe_step
from lpik.tolerances import FEASIBILITY_TOL, MAX_CONDITION, SINGULAR_FLOOR
from lpik.types import FloatArray


def pinv(problem: Problem) -> Result:
    """Moore-Penrose step ``dq = J^+ dw`` with ``J^+ = J^T (J J^T)^-1`` (eqs. 8-9).

    ``M``, ``f`` and ``Lambda`` are ignored (eq. 8 is eq. 7 with ``M = I``,
    ``f = 0``). ``lam = -(J J^T)^-1 dw`` is eq. 7's multiplier. ``p = 1``.
    Status ``"singular"`` (safe step) when ``J J^T`` is singular.
    """
    start = time.perf_counter()
    J = problem.J
    if _jjt_singular(J):
        return safe_step(
            problem,
            "pinv",
            SINGULAR,
            "J J^T",
            solve_time=time.perf_counter() - start,
            path="closed-form",
        )
    y = np.linalg.solve(J @ J.T, problem.dw)
    return _closed(problem, "pinv", J.T @ y, -y, 1.0, start)


def _jjt_singular(J: FloatArray) -> bool:
    """Whether ``J J^T`` is singular, from one SVD of ``J``.

    Its condition ``(sigma_max / sigma_min)^2`` above ``MAX_CONDITION``, or a singular
    value of ``J`` at or below ``SINGULAR_FLOOR`` (``J J^T`` would be subnormal, its
    solve inf); a ``J`` with more rows than columns (or none) has a singular ``J J^T``.
    """
    m, n = J.shape
    if m == 0 or m > n:
        return True
    sigma = np.linalg.svd(J, compute_uv=False)
    smallest = float(sigma.min())
    return smallest <= SINGULAR_FLOOR or not (float(sigma.max()) / smallest) ** 2 <= MAX_CONDITION


def weighted(problem: Problem) -> Result:
    """Weighted step from eq. 7: ``[[M, J^T], [J, 0]] [q; lam] = [M q0 + f; J q0 + dw]``.

    With sec. 3.1's smoothing term, ``M`` becomes ``M + Lambda`` and the first
    right-hand side gains ``Lambda q_ref`` (the paper's matrix of sec. 3.1 at
    ``p = 1``). This is LP2's step whenever no limit is active. ``p = 1``.
    Status ``"singular"`` (safe step) when the KKT matrix is singular.
    """
    start = time.perf_counter()
    H, c = criterion(problem)
    n, m = problem.n, problem.m
    K = np.block([[H, problem.J.T], [problem.J, np.zeros((m, m))]])
    if np.linalg.cond(K) > MAX_CONDITION:
        return safe_step(
            problem,
            "weighted",
            SINGULAR,
            "KKT matrix",
            solve_time=time.perf_counter() - start,
            path="closed-form",
        )
    x = np.linalg.solve(K, np.concatenate([c, problem.dw]))
    return _closed(problem, "weighted", x[:n], x[n:], 1.0, start)


def yoshikawa_manipulability(J: FloatArray) -> float:
    """Yoshikawa's manipulability measure ``sqrt(det(J J^T))`` (paper ref. [12]).

    0 at a singular configuration, without the RuntimeWarning numpy's LU raises
    there (a zero pivot).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        determinant = np.linalg.det(J @ J.T)
    return float(np.sqrt(max(0.0, determinant)))


def robust(problem: Problem) -> Result:
    """Komainda's robust inverse (eq. 19): eq. 7 with ``k I`` in the multiplier block.

    Eq. 19 as printed has ``+k I``. With the multiplier sign of eq. 5, the
    matrix that cannot become singular for ``k != 0`` is the quasi-definite
    ``[[M, J^T], [J, -k I]]``; for ``M = I``, ``f = 0`` it gives the damped
    least-squares step ``dq = J^T (J J^T + k I)^-1 dw``. The printed ``+k I``
    would make the matrix singular whenever ``k`` equals an eigenvalue of
    ``J M^-1 J^T``, so lpik implements the quasi-definite form.

    ``k`` is ``problem.k`` or, when ``None``, Yoshikawa's ``sqrt(det(J J^T))``
    (which is 0 at a singularity: then the step is ``"singular"``).
    The damped step does not achieve ``dw`` exactly: ``p`` is the achieved
    fraction along the command, ``(dw . J dq) / |dw|^2`` clipped to [0, 1],
    and ``residual`` reports ``max |J dq - p dw|``.
    """
    start = time.perf_counter()
    H, c = criterion(problem)
    n, m = problem.n, problem.m
    k = yoshikawa_manipulability(problem.J) if problem.k is None else float(problem.k)
    K = np.block([[H, problem.J.T], [problem.J, -k * np.eye(m)]])
    if np.linalg.cond(K) > MAX_CONDITION:
        return safe_step(
            problem,
            "robust",
            SINGULAR,
            f"robust KKT matrix (k = {k:.3g})",
            solve_time=time.perf_counter() - start,
            path="closed-form",
        )
    x = np.linalg.solve(K, np.concatenate([c, problem.dw]))
    dq = x[:n]
    dw2 = float(problem.dw @ problem.dw)
    p = 1.0 if dw2 == 0 else float(np.clip(problem.dw @ (problem.J @ dq) / dw2, 0.0, 1.0))
    return _closed(problem, "robust", dq, x[n:], p, start)


def _closed(
    problem: Problem, method: str, dq: FloatArray, lam: FloatArray, p: float, start: float
) -> Result:
    violation = worst_violation(problem, dq)
    status, binding = OPTIMAL, None
    if violation.amount > FEASIBILITY_TOL:
        status, binding = VIOLATES_LIMITS, violation.label
    return Result(
        q=problem.q0 + dq,
        dq=dq,
        p=p,
        lam=lam,
        status=status,
        binding=binding,
        method=method,
        solve_time=time.perf_counter() - start,
        residual=task_residual(problem, dq, p),
        path="closed-form",
    )
