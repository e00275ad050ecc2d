"""Eq. 18's equality rows solved for ``dq`` and ``lam`` as affine functions of ``p``.

LP2's rows ``H dq + J^T lam = c`` and ``J dq = p dw`` (eq. 18, with sec. 3.1's
term in ``H = M + Lambda`` and ``c = f + Lambda (q_ref - q0)``) fix ``dq`` and
``lam`` once ``p`` is chosen. This module solves them (:func:`affine_solution`),
fixes pinned joints (:func:`pinned_system`) and weighs the smoothing term
(:func:`smoothing_scale`): whole where its pull towards ``q_ref`` fits the
step at ``p = 0``, else scaled so that it takes no more of a joint's step band
than :data:`~lpik.tolerances.SMOOTHING_SHARE`: a pull that alone would exceed
one step made every step of LP2 infeasible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import EllipsisType

import numpy as np
import scipy.linalg as sla

from lpik.methods.assembly import criterion, reference_pull
from lpik.methods.pull import pull_scale
from lpik.problem import Problem
from lpik.tolerances import MAX_SCHUR_CONDITION, SINGULAR_FLOOR
from lpik.types import FloatArray


@dataclass(frozen=True, eq=False)
class AffineSolution:
    """``dq(p) = a_q + p b_q`` and ``lam(p) = a_l + p b_l``: eq. 18's equality rows solved.

    ``smoothing`` is the scale :func:`smoothing_scale` gave the smoothing term
    (1 when it is whole, or when there is none).
    """

    a_q: FloatArray
    b_q: FloatArray
    a_l: FloatArray
    b_l: FloatArray
    smoothing: float = 1.0


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


def affine_solution(
    problem: Problem, max_condition: float = MAX_SCHUR_CONDITION
) -> AffineSolution | None:
    """Solve eq. 18's equality rows for ``dq`` and ``lam`` as affine functions of ``p``.

    With ``H = M + Lambda`` (positive definite) and ``c = f + Lambda (q_ref - q0)``,
    the rows read ``H dq + J^T lam = c`` and ``J dq = p dw``. Eliminating ``dq``
    leaves the Schur complement ``S lam = J H^-1 c - p dw`` with
    ``S = J H^-1 J^T`` (one factorisation, two right-hand sides). Pinned joints
    enter through :func:`pinned_system` (``S lam = J' H'^-1 c' + w_fixed - p dw``).

    Returns:
        The affine solution, or ``None`` when ``S`` is singular or
        :func:`ill_conditioned` for ``max_condition`` (:data:`MAX_SCHUR_CONDITION`;
        lp2s's later passes give a stricter one).
    """
    J, H, c, w_fixed = pinned_system(problem)
    c_ref = smoothing_pull(problem)
    H_factor = sla.cho_factor(H)
    HinvJt = sla.cho_solve(H_factor, J.T)
    Hinvc = sla.cho_solve(H_factor, np.column_stack([c - c_ref, c_ref]))
    S = J @ HinvJt
    S = 0.5 * (S + S.T)
    try:
        S_factor = sla.cho_factor(S, lower=True)
    except np.linalg.LinAlgError:
        return None
    if ill_conditioned(S, S_factor[0], np.empty(len(S)), max_condition):
        return None
    rhs = np.column_stack([J @ Hinvc[:, 0] + w_fixed, J @ Hinvc[:, 1], -problem.dw])
    lam = sla.cho_solve(S_factor, rhs)
    X_l = lam[:, :2]
    X_q = Hinvc - HinvJt @ X_l
    # One pass of iterative refinement of the step at p = 0 and of the pull's share: their
    # residuals in the rows H' dq + J'^T lam = c' (resp. c_ref) and J' dq = -w_fixed
    # (resp. 0), solved with the same factors. Where S is ill-conditioned, rounding of
    # eps cond(S) |H^-1 c| would otherwise carry a joint that sits at its end-stop past it
    # by more than SLACK_TOL, and the ratio test would call a feasible step infeasible.
    T = sla.cho_solve(H_factor, np.column_stack([c - c_ref, c_ref]) - H @ X_q - J.T @ X_l)
    D = sla.cho_solve(S_factor, J @ (X_q + T) + np.column_stack([w_fixed, np.zeros_like(w_fixed)]))
    X_q, X_l = X_q + T - HinvJt @ D, X_l + D
    a_q, e_q, a_l, e_l, b_l = X_q[:, 0], X_q[:, 1], X_l[:, 0], X_l[:, 1], lam[:, 2]
    lower, upper = problem.step_bounds()[:2]
    s = smoothing_scale(a_q, e_q, lower, upper, (a_l, e_l, problem.lam_min, problem.lam_max))
    return AffineSolution(a_q=a_q + s * e_q, b_q=-HinvJt @ b_l, a_l=a_l + s * e_l, b_l=b_l,
                          smoothing=s)  # fmt: skip


def ill_conditioned(S, L, x, max_condition):  # type: ignore[no-untyped-def]
    """Whether ``S = L L^T`` counts as singular: the one test of every path.

    It does where a diagonal of ``L`` is at or below
    :data:`~lpik.tolerances.SINGULAR_FLOOR` (not positive, or so small that its
    square is not a normal double), or where :func:`condition_bound` is above
    ``max_condition`` or not a number.

    The bound, not the cheaper ``(max L_ii / min L_ii)^2``: where ``J`` loses rank
    with rows of different scale (rows 1000 times apart: a position row in m and
    one in mm), that ratio of a singular ``S`` is about ``1 / (1e6 eps)``, 4.5e9,
    just under :data:`MAX_SCHUR_CONDITION`, and rounding decided on which side of
    it each path's factor fell. The bound reads ``|S| / L_mm^2``, about ``1 / eps``
    there. ``x`` is a scratch vector of length ``m``; plain loops, compiled as they are.
    """
    for i in range(S.shape[0]):
        if not L[i, i] > SINGULAR_FLOOR:  # its inverse's square would overflow
            return True
    return not condition_bound(S, L, x) <= max_condition  # NaN: singular too


#: An entry of ``L^-1`` beyond this makes :func:`condition_bound` infinite: its square
#: would overflow (numpy's warning on the numpy path; a hypothesis draw of a fresh-clone run).
_ENTRY_BOUND = 1e150


def condition_bound(S, L, x):  # type: ignore[no-untyped-def]
    """``|S|_F |L^-1|_F^2`` for ``S = L L^T``: never below the condition of ``S``.

    The Cholesky estimate ``(max L_ii / min L_ii)^2`` can fall short of the
    condition by orders of magnitude; this bound (``|S^-1|_2 <= |L^-1|_2^2``) is
    at most ``m^2`` times it. Only ``L``'s lower triangle is read; ``x`` is a
    scratch vector of length ``m``. Plain loops: the compiled kernel
    (:mod:`lpik.fast.lp2_kernel`) runs this same code.
    """
    m = S.shape[0]
    norm_s, norm_inv = 0.0, 0.0
    for i in range(m):
        for j in range(m):
            norm_s += S[i, j] * S[i, j]
    for j in range(m):  # column j of L^-1: forward substitution on the unit vector e_j
        for i in range(j, m):
            s = 1.0 if i == j else 0.0
            for k in range(j, i):
                s -= L[i, k] * x[k]
            x[i] = s / L[i, i]
            if not abs(x[i]) <= _ENTRY_BOUND:  # its square would overflow: the bound is inf
                return math.inf
            norm_inv += x[i] * x[i]
    # Python floats: a product past the largest float is inf (singular), without numpy's warning
    return math.sqrt(norm_s) * float(norm_inv)


def smoothing_pull(problem: Problem) -> FloatArray:
    """``Lambda (q_ref - q0)`` on the free joints (0 on pinned ones): sec. 3.1's part of ``c``."""
    return np.where(problem.pinned()[0], 0.0, reference_pull(problem))


def smoothing_scale(
    a_q: FloatArray,
    e_q: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    multipliers: tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None = None,
) -> float:
    """The share ``s`` in [0, 1] of sec. 3.1's pull ``e_q`` the step takes (:func:`pull_scale`).

    ``a_q`` is the step at ``p = 0`` without the pull, ``e_q`` the pull's share
    of it (both resolved by eq. 18); ``multipliers`` ``(a_l, e_l, lam_min,
    lam_max)`` the same for the multipliers and their bounds (sec. 3.2). Where
    the whole pull keeps the step at ``p = 0`` within every bound, ``s = 1``:
    the paper's LP2. Only where it does not may ``s e_q`` take at most
    :data:`~lpik.tolerances.SMOOTHING_SHARE` of the room between ``a_q`` and
    its bounds on each joint (and of each multiplier's), so the rest of the
    band is left for the command (:func:`lpik.methods.pull.pull_room`) and the
    pull cannot make the step infeasible on its own account.
    """
    if multipliers is None:
        none = np.empty(0)
        multipliers = (none, none, none, none)
    return float(pull_scale(a_q, e_q, lower, upper, *multipliers))


def smoothing(problem: Problem, affine: AffineSolution | None | EllipsisType = ...) -> float:
    """The smoothing scale of ``problem``'s step (:func:`smoothing_scale`), on every path.

    From the affine solution when ``S`` is regular, else from the least-norm
    solution of the KKT rows at ``p = 0`` (a singular ``S``, solved by HiGHS), so
    that both paths weigh the pull alike. ``affine`` is
    :func:`affine_solution`'s answer when the caller has it (``None``: singular),
    ``...`` to compute it here.
    """
    if not problem.Lambda.any():
        return 1.0
    if affine is ...:
        affine = affine_solution(problem)
    if affine is not None:
        return affine.smoothing
    J, H, c, w_fixed = pinned_system(problem)
    c_ref = smoothing_pull(problem)
    n, m = problem.n, problem.m
    K = np.block([[H, J.T], [J, np.zeros((m, m))]])
    rhs = np.column_stack(
        [np.concatenate([c - c_ref, -w_fixed]), np.concatenate([c_ref, np.zeros(m)])]
    )
    x = np.linalg.lstsq(K, rhs, rcond=None)[0]
    lower, upper = problem.step_bounds()[:2]
    lam = (x[n:, 0], x[n:, 1], problem.lam_min, problem.lam_max)
    return smoothing_scale(x[:n, 0], x[:n, 1], lower, upper, lam)
