"""LP2's exact ratio test, compiled (numba, cached on disk): eqs. 15-18.

A loop-level re-write of :func:`lpik.methods.kkt.affine_solution` (pinned
joints, the scaled smoothing pull) and :func:`lpik.methods.lp2.ratio_test`:
the same algorithm, conditioning test, tie-breaking and tolerances (read from
:mod:`lpik.tolerances`), so it returns the numpy path's ``p``, ``dq``, ``lam``
and binding limit (tests hold them to 1e-12). It re-checks its own answer
(bounds, multiplier bounds, rows, ``J dq = p dw``) as :func:`lpik.check.check_step` does.

Binding limits are returned as codes: ``2 k`` is the lower side and
``2 k + 1`` the upper side of constraint ``k``, with constraints ordered as
joints ``0..n-1``, multipliers ``n..n+m-1``, extra rows ``n+m..``; ``-1``
means none (:func:`lpik.labels.code_labels` spells them).
"""

from __future__ import annotations

import numpy as np
from numba import float64, int64, njit, prange

from lpik.check import loop_check
from lpik.fast.jacobi import jacobi_svd
from lpik.fast.linalg import cho_solve, cho_solve2, cholesky, refine
from lpik.fast.ratio import limit_code, slacks
from lpik.fast.smoothing import add_smoothing, compiled_pull_scale
from lpik.fast.twins import compiled_twin
from lpik.fast.workspace import (
    A_L,
    A_Q,
    AV,
    B_L,
    B_Q,
    BV,
    COL,
    E_L,
    E_Q,
    H_FACTOR,
    HI,
    HINV_C,
    HINV_JT,
    HINV_R,
    LO,
    OUT,
    PULL_SCALE,
    RHS,
    RHS2,
    RHS3,
    SCHUR,
    SCHUR_FACTOR,
    matrix_at,
    vector,
    workspace_size,
)
from lpik.methods import kkt, singular
from lpik.methods.singular import CHECK_FAILED, INFEASIBLE, OK, SINGULAR
from lpik.tolerances import (
    FULL_P,
    INTERVAL_TOL,
    MAX_SCHUR_CONDITION,
    RATE_TOL,
)

__all__ = ["CHECK_FAILED", "INFEASIBLE", "OK", "SINGULAR", "compiled_loop_check",
           "lp2_core", "lp2_kernel", "pull_scale_of"]  # fmt: skip

#: LP2's singular path (:mod:`lpik.methods.singular`), compiled as it is.
_HELPERS = ("forward_substitution", "back_substitution", "regular_count", "_interval",
            "_eliminate", "_free_range", "_held", "_held_share", "_finite", "_facet_rows",
            "_basic_values", "_pinned_code", "singularity_code")  # fmt: skip
#: :func:`lpik.check.loop_check`, the answer's own check, compiled once for every kernel
#: (LP2's, and the criterion stage's :func:`lpik.fast.progress.least_l1_in_state`).
compiled_loop_check = njit(cache=True)(loop_check)
#: The singular path's helpers, compiled (the field's null-space motion takes three of them:
#: :data:`lpik.fast.step.null_space_motion`).
singular_helpers = {name: njit(cache=True)(getattr(singular, name)) for name in _HELPERS}
# the Schur complement's one test (lpik.methods.kkt.ill_conditioned)
ill_conditioned = compiled_twin(
    kkt.ill_conditioned, condition_bound=njit(cache=True)(kkt.condition_bound)
)
# the safe step, INFEASIBLE: one signature (the kernels pass -1 and a variable alike)
_stop = njit((float64[:], float64[:], float64[:], int64), cache=True)(singular._stop)
singular_core = compiled_twin(
    singular.singular_core, _svd=jacobi_svd, loop_check=compiled_loop_check, _stop=_stop,
    pull_scale=compiled_pull_scale,
    _within_bounds=compiled_twin(singular._within_bounds, loop_check=compiled_loop_check,
                                 forward_substitution=singular_helpers["forward_substitution"],
                                 back_substitution=singular_helpers["back_substitution"]),
    _vertex_multipliers=compiled_twin(singular._vertex_multipliers,
                                      _basic_values=singular_helpers["_basic_values"]),
    **singular_helpers,
)  # fmt: skip

#: :func:`lpik.fast.workspace.workspace_size` (compiled), by its former name.
_workspace_size = workspace_size

#: :func:`lp2_core`'s ``singular_path``: never, always (``True``), or only for a
#: ratio-test answer that fails its check. numpy integers, not Python ints: numba
#: types a Python int constant as its own literal type, and each call site with
#: another constant would compile :func:`lp2_core` once more.
SINGULAR_PATH_NEVER, SINGULAR_PATH_ALWAYS, SINGULAR_PATH_AFTER_CHECK = np.int64([0, 1, 2])


@njit(cache=True)
def lp2_kernel(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam):
    """:func:`lp2_core` with its own workspace; its outcome and the pull's share it took.

    Returns ``(code, p, binding, residual, pull_scale)``: :func:`lp2_core`'s answer and
    the share of sec. 3.1's pull it left in the workspace (:func:`pull_scale_of`).
    """
    m, n = J.shape
    r = G.shape[0]
    ws = np.empty(workspace_size(n, m, r))
    code, p, binding, res = lp2_core(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max,
                                     G, g, dq, lam, ws, SINGULAR_PATH_ALWAYS,
                                     MAX_SCHUR_CONDITION)  # fmt: skip
    return code, p, binding, res, pull_scale_of(ws, n, m, r)


@njit(cache=True)
def pull_scale_of(ws, n, m, r):
    """The share of sec. 3.1's pull the last :func:`lp2_core` on ``ws`` took (1: whole, none)."""
    return vector(ws, PULL_SCALE, n, m, r)[0]


@njit(cache=True)
def lp2_core(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam, ws,
             singular_path, max_condition):  # fmt: skip
    """LP2 by the ratio test (eqs. 15-18). Writes ``dq`` and ``lam``.

    The equality rows of eq. 18 give ``dq = a_q + p b_q`` and
    ``lam = a_l + p b_l`` through the Schur complement ``S = J H^-1 J^T``;
    every bound then limits ``p`` to an interval, and the largest ``p`` in
    their intersection with [0, 1] is the LP's optimum.

    Args:
        J: Jacobian, (m, n).
        dw: Commanded displacement, (m,).
        H: ``M + Lambda``, (n, n).
        h_diag: True when ``H`` is diagonal (no factorisation of ``H`` needed).
        c: ``f``, the criterion's part of ``c`` without sec. 3.1's term, (n,).
        c_ref: ``Lambda (q_ref - q0)``, sec. 3.1's pull, (n,); weighed as
            :func:`lpik.methods.kkt.smoothing_scale` weighs it (whole where it fits),
            the share taken left in ``ws``'s block ``PULL_SCALE`` (:func:`pull_scale_of`).
        lower: Lower bounds on ``dq``, (n,).
        upper: Upper bounds on ``dq``, (n,).
        lam_min: Lower multiplier bounds, (m,).
        lam_max: Upper multiplier bounds, (m,).
        G: Extra rows, (r, n).
        g: Their right-hand side in ``dq``: ``G dq <= g``, (r,).
        dq: Output step, (n,).
        lam: Output multipliers, (m,).
        ws: Float workspace of length :func:`workspace_size`, in the blocks of
            :mod:`lpik.fast.workspace` (no allocation inside).
        singular_path: Whether a singular or ill-conditioned Schur complement, or
            an answer that fails the check, goes to the singular path (True,
            :data:`SINGULAR_PATH_ALWAYS`; else the outcome is :data:`SINGULAR` or
            :data:`CHECK_FAILED`); :data:`SINGULAR_PATH_AFTER_CHECK`: only an
            answer that fails the check (:func:`lpik.methods.lp2s.lp2s`'s later
            passes: no well-conditioned affine solution ends the passes, while
            numpy's LP2 takes the singular path after a failed ratio test), and
            :data:`CHECK_FAILED` where the singular path would need HiGHS.
        max_condition: :data:`~lpik.tolerances.MAX_SCHUR_CONDITION`; or, for
            lp2s's later passes, :data:`~lpik.tolerances.SATURATION_MAX_CONDITION`;
            the Schur complement is tested by :func:`~lpik.methods.kkt.ill_conditioned`.

    Returns:
        ``(code, p, binding, residual)``: the outcome (:data:`OK`,
        :data:`INFEASIBLE`, :data:`SINGULAR` or :data:`CHECK_FAILED`), the
        affine dexterity, the binding code (``-1``: none) and
        ``max |J dq - p dw|`` (0 unless the step was computed). On
        :data:`INFEASIBLE`, ``dq`` holds the safe step. The singular path
        (:func:`lpik.methods.singular.singular_core`, compiled) returns
        :data:`SINGULAR` or :data:`CHECK_FAILED` where only HiGHS can decide.
    """
    m, n = J.shape
    r = G.shape[0]
    total = n + m + r
    HinvJt, LH = matrix_at(ws, HINV_JT, n, m, r), matrix_at(ws, H_FACTOR, n, m, r)
    S, LS = matrix_at(ws, SCHUR, n, m, r), matrix_at(ws, SCHUR_FACTOR, n, m, r)
    Hinvc, Hinvr = vector(ws, HINV_C, n, m, r), vector(ws, HINV_R, n, m, r)
    a_q, b_q, e_q = vector(ws, A_Q, n, m, r), vector(ws, B_Q, n, m, r), vector(ws, E_Q, n, m, r)
    a_l, b_l, e_l = vector(ws, A_L, n, m, r), vector(ws, B_L, n, m, r), vector(ws, E_L, n, m, r)
    col, out = vector(ws, COL, n, m, r), vector(ws, OUT, n, m, r)
    rhs, rhs2, rhs3 = vector(ws, RHS, n, m, r), vector(ws, RHS2, n, m, r), vector(ws, RHS3, n, m, r)
    av, bv = vector(ws, AV, n, m, r), vector(ws, BV, n, m, r)
    lo, hi = vector(ws, LO, n, m, r), vector(ws, HI, n, m, r)
    pull = vector(ws, PULL_SCALE, n, m, r)  # the share of sec. 3.1's pull taken: none yet
    pull[0] = 1.0
    # --- affine solution: dq = a_q + p b_q, lam = a_l + p b_l (Schur complement) ---
    # A pinned joint (lower == upper: lpik.methods.kkt.pinned_system) keeps dq = d: its
    # criterion row is dropped, its column of J leaves the Schur complement (H' is the
    # identity there), and c' = c - H_FP d on the free joints, d on the pinned ones.
    pins = False
    for i in range(n):
        if lower[i] == upper[i]:
            pins = True
    if h_diag:
        for i in range(n):
            if lower[i] == upper[i]:
                for k in range(m):
                    HinvJt[i, k] = 0.0
                Hinvc[i] = lower[i]
                continue
            if not H[i, i] > 0.0:
                return SINGULAR, 0.0, -1, 0.0
            for k in range(m):
                HinvJt[i, k] = J[k, i] / H[i, i]
            Hinvc[i] = c[i] / H[i, i]
    else:
        for i in range(n):  # LH = H', factorised in place
            for j in range(n):
                LH[i, j] = H[i, j]
                if pins and (lower[i] == upper[i] or lower[j] == upper[j]):
                    LH[i, j] = 1.0 if i == j else 0.0
        if not cholesky(LH, LH):
            return SINGULAR, 0.0, -1, 0.0
        for k in range(m):
            for i in range(n):
                col[i] = 0.0 if lower[i] == upper[i] else J[k, i]
            cho_solve(LH, col, out)
            for i in range(n):
                HinvJt[i, k] = out[i]
        for i in range(n):
            if lower[i] == upper[i]:
                col[i] = lower[i]
            else:
                s = c[i]
                if pins:
                    for j in range(n):
                        if lower[j] == upper[j]:
                            s -= H[i, j] * lower[j]
                col[i] = s
        cho_solve(LH, col, Hinvc)
    for a in range(m):
        for b in range(a, m):
            s = 0.0
            for i in range(n):
                s += J[a, i] * HinvJt[i, b]
            S[a, b] = s
            S[b, a] = s
    if not cholesky(S, LS):
        if singular_path != SINGULAR_PATH_ALWAYS:
            return SINGULAR, 0.0, -1, 0.0
        return singular_core(J, dw, H, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam,
                             pull)  # fmt: skip
    if ill_conditioned(S, LS, rhs, max_condition):
        if singular_path != SINGULAR_PATH_ALWAYS:
            return SINGULAR, 0.0, -1, 0.0
        return singular_core(J, dw, H, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam,
                             pull)  # fmt: skip
    for a in range(m):
        s = 0.0
        for i in range(n):
            s += J[a, i] * Hinvc[i]
        rhs[a] = s
    for a in range(m):
        rhs2[a] = -dw[a]
    cho_solve2(LS, rhs, rhs2, a_l, b_l)
    for i in range(n):
        sa, sb = Hinvc[i], 0.0
        for k in range(m):
            sa -= HinvJt[i, k] * a_l[k]
            sb -= HinvJt[i, k] * b_l[k]
        a_q[i] = sa
        b_q[i] = sb
    refine(J, H, h_diag, c, lower, upper, LH, LS, HinvJt, a_q, a_l, col, out, rhs, rhs2)
    # --- sec. 3.1's pull, whole where it fits (lpik.methods.kkt.smoothing_scale) ---
    smooth = False
    for i in range(n):
        if lower[i] != upper[i] and c_ref[i] != 0.0:
            smooth = True
    if smooth:
        pull[0] = add_smoothing(J, H, h_diag, LH, LS, HinvJt, c_ref, lower, upper, lam_min,
                                lam_max, a_q, a_l, (col, Hinvr, e_q, out),
                                (rhs3, e_l, rhs, rhs2))  # fmt: skip
    # --- ratio test over joints, multipliers, rows ---
    for i in range(n):
        av[i], bv[i], lo[i], hi[i] = a_q[i], b_q[i], lower[i], upper[i]
    for k in range(m):
        av[n + k], bv[n + k], lo[n + k], hi[n + k] = a_l[k], b_l[k], lam_min[k], lam_max[k]
    for j in range(r):
        sa, sb = 0.0, 0.0
        for i in range(n):
            sa += G[j, i] * a_q[i]
            sb += G[j, i] * b_q[i]
        av[n + m + j], bv[n + m + j], lo[n + m + j], hi[n + m + j] = sa, sb, -np.inf, g[j]
    bmax = 0.0
    for k in range(total):
        bmax = max(bmax, abs(bv[k]))
    eps = RATE_TOL * max(1.0, bmax)
    up_hi, up_lo, low_hi, low_lo = np.inf, np.inf, -np.inf, -np.inf
    stuck_hi, stuck_lo = -1, -1
    for k in range(total):
        s_hi, s_lo = slacks(av[k], lo[k], hi[k])
        b = bv[k]
        if b > eps:
            up_hi, low_lo = min(up_hi, s_hi / b), max(low_lo, -s_lo / b)
        elif b < -eps:
            up_lo, low_hi = min(up_lo, s_lo / -b), max(low_hi, s_hi / b)
        else:
            if stuck_hi < 0 and s_hi < 0:
                stuck_hi = 2 * k + 1
            if stuck_lo < 0 and s_lo < 0:
                stuck_lo = 2 * k
    if stuck_hi >= 0:
        return _stop(lower, upper, dq, stuck_hi)
    if stuck_lo >= 0:
        return _stop(lower, upper, dq, stuck_lo)
    # a limit is named only where one stops p (ties: lpik.fast.ratio.limit_code)
    p_hi = min(1.0, min(up_hi, up_lo))
    p_lo = max(0.0, max(low_hi, low_lo))
    if p_hi < p_lo - INTERVAL_TOL:
        if p_lo > 1.0:
            return _stop(lower, upper, dq, limit_code(av, bv, lo, hi, total, eps, False,
                                                      low_hi, low_lo))  # fmt: skip
        return _stop(lower, upper, dq, limit_code(av, bv, lo, hi, total, eps, True, up_hi, up_lo))
    p = max(p_hi, p_lo)
    binding = limit_code(av, bv, lo, hi, total, eps, True, up_hi, up_lo) if p < FULL_P else -1
    p = min(1.0, max(0.0, p))
    # --- the step, clipped to solver-tolerance excursions, and its own check ---
    for i in range(n):
        dq[i] = min(max(a_q[i] + p * b_q[i], lower[i]), upper[i])
    for k in range(m):
        lam[k] = a_l[k] + p * b_l[k]
    ok, res = compiled_loop_check(J, dw, p, dq, lam, lam_min, lam_max, G, g)
    if not ok:
        # rounding beyond the check's tolerance: the singular path decides, as in lpik.methods.lp2
        if singular_path == SINGULAR_PATH_NEVER:
            return CHECK_FAILED, p, binding, res
        code, p, binding, res = singular_core(J, dw, H, c, c_ref, lower, upper, lam_min, lam_max,
                                              G, g, dq, lam, pull)  # fmt: skip
        if code == SINGULAR and singular_path == SINGULAR_PATH_AFTER_CHECK:
            return CHECK_FAILED, p, binding, res  # HiGHS decides: the caller's numpy method
        return code, p, binding, res
    return OK, p, binding, res


#: :func:`lp2_core` inlined at numba's IR level, for the batch loop: a call with 14
#: array arguments spends a sizeable part of a solve on reference counting, which
#: inlining removes (at the price of a longer compile).
_lp2_core_inlined = njit(inline="always")(lp2_core.py_func)


@njit(cache=True, parallel=True)
def lp2_batch_kernel(
    J,
    dw,
    H,
    h_diag,
    c,
    c_ref,
    lower,
    upper,
    lam_min,
    lam_max,
    G,
    g,
    dq,
    lam,
    codes,
    ps,
    bindings,
    scales,
    chunks,
):
    """:func:`lp2_core` over a batch (leading axis ``B`` on every argument), in parallel.

    The batch is cut into ``chunks`` parts (a few per thread); each allocates its
    workspace once. ``scales`` receives each item's share of sec. 3.1's pull
    (:func:`pull_scale_of`).
    """
    B, m, n = J.shape
    chunks = max(1, min(B, chunks))
    size = workspace_size(n, m, G.shape[1])
    for chunk in prange(chunks):
        ws = np.empty(size)
        for b in range(chunk * B // chunks, (chunk + 1) * B // chunks):
            code, p, binding, _ = _lp2_core_inlined(
                J[b],
                dw[b],
                H[b],
                h_diag,
                c[b],
                c_ref[b],
                lower[b],
                upper[b],
                lam_min[b],
                lam_max[b],
                G[b],
                g[b],
                dq[b],
                lam[b],
                ws,
                SINGULAR_PATH_ALWAYS,
                MAX_SCHUR_CONDITION,
            )
            codes[b] = code
            ps[b] = p
            bindings[b] = binding
            scales[b] = pull_scale_of(ws, n, m, G.shape[1])
