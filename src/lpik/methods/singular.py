"""LP2 when the Schur complement is singular or ill-conditioned (eqs. 15-18).

At a singular configuration the KKT matrix ``K = [[H, J^T], [J, 0]]`` of
eq. 18 is singular and LP2 is no longer a ratio test in ``p`` alone. With
``H = L L^T`` and the singular value decomposition
``J L^-T = sum_i s_i u_i v_i^T``, write ``lam = sum_i mu_i u_i`` and
``y = L^T dq``. Eq. 18's rows ``H dq + J^T lam = c`` and ``J dq = p dw - w_fixed``
read ``y = L^-1 c - sum_i s_i mu_i v_i`` and, along each ``u_i``,
``s_i^2 mu_i = t_i - p e_i`` with ``t = U^T (J L^-T L^-1 c + w_fixed)`` and
``e = U^T dw``. So:

- along a *regular* direction (``s_i`` above :data:`~lpik.tolerances.SINGULAR_RTOL`
  times the largest) ``mu_i`` is affine in ``p`` and so is ``dq``, as on the
  ratio-test path;
- along a *singular* one (``s_i`` below it, or beyond ``J``'s rank) the row
  reads ``t_i = p e_i``: ``dw`` must lie in the range of ``J`` (then ``p`` is
  free) or ``p`` is fixed there, usually at 0, and the binding limit is
  ``"singularity"``; ``mu_i`` is then a free variable that only the multiplier
  bounds (sec. 3.2) constrain. ``dq`` is unique whatever ``mu_i`` is.

The LP left over ``p`` and the free ``mu_i`` is solved exactly: the free
``mu_i`` are eliminated from the multiplier bounds (Fourier-Motzkin, at most
:data:`MAX_FREE_MULTIPLIERS` of them; more go to HiGHS), the largest ``p`` in
the remaining intervals is taken as by the ratio test, and the free ``mu_i``
are chosen, by back-substitution, as close to 0 as the bounds allow (the
smallest multipliers). Where every multiplier is held at one value
(``lam_min == lam_max``: the automatic bound's floor, ``B = 0``, sec. 3.2)
``lam`` is given, however many directions are free: along each regular
direction ``(a_l + p b_l) . u_i`` must equal the held value's share, which fixes
``p`` (the multiplier that moves most along ``u_i`` binds) or leaves no step.

An ill-conditioned but regular ``J`` is solved exactly here (the decomposition
is backward stable where the Cholesky factor of the Schur complement is not):
near a singularity, with a command ``J`` can hardly produce, the answer moves
along ``v_i`` at the joints' rate limits for a small ``p``, which is how the arm
leaves a singular configuration. Only where ``s_i`` is rounding is ``J`` taken
to have the lower rank.

Plain loops over small arrays: numba compiles this very code for the fused step
(:mod:`lpik.fast.lp2_kernel`, with its own SVD), the numpy path runs it as it is.
Outcome and binding codes are the kernel's (``2 k``/``2 k + 1``: lower/upper side
of joint, multiplier or row ``k``; :func:`singularity_code`: the singularity).
"""

from __future__ import annotations

import math

import numpy as np

from lpik.check import loop_check
from lpik.methods.pull import pull_scale
from lpik.tolerances import (
    EQUALITY_RTOL,
    FULL_P,
    INTERVAL_TOL,
    RATE_TOL,
    SINGULAR_RTOL,
    SLACK_TOL,
)

#: Outcome codes of the loop-level LP2 solvers (here and :mod:`lpik.fast.lp2_kernel`).
OK = 0
INFEASIBLE = 1
SINGULAR = 2  # beyond this path: the caller solves the LP with HiGHS
CHECK_FAILED = 3

#: At most this many free multiplier directions are eliminated; more go to HiGHS.
MAX_FREE_MULTIPLIERS = 2


def singularity_code(n, m, r):
    """The binding code of ``"singularity"`` after ``n`` joints, ``m`` multipliers, ``r`` rows."""
    return 2 * (n + m + r)


def _svd(A):  # the compiled twin binds lpik.fast.jacobi.jacobi_svd instead
    return np.linalg.svd(A)


def _forward(L, B):
    """``L^-1 B`` for lower-triangular ``L`` (n, n) and ``B`` (n, k)."""
    n, k = B.shape
    X = np.empty((n, k))
    for col in range(k):
        for i in range(n):
            s = B[i, col]
            for j in range(i):
                s -= L[i, j] * X[j, col]
            X[i, col] = s / L[i, i]
    return X


def _backward(L, y, out):
    """``L^-T y`` into ``out`` for lower-triangular ``L``."""
    n = y.shape[0]
    for i in range(n - 1, -1, -1):
        s = y[i]
        for j in range(i + 1, n):
            s -= L[j, i] * out[j]
        out[i] = s / L[i, i]


def _interval(alpha, beta, codes, count):
    """The ``p`` with ``alpha_k + beta_k p <= 0`` for ``k < count``.

    Returns ``(stuck, p_lo, lo_code, p_hi, hi_code)``: ``stuck`` is the code of
    a constraint no ``p`` meets (``-1``: none), then the interval's ends and
    the constraints that set them (ties: the first).
    """
    bmax = 0.0
    for k in range(count):
        bmax = max(bmax, abs(beta[k]))
    eps = RATE_TOL * max(1.0, bmax)
    p_lo, p_hi, lo_code, hi_code = -np.inf, np.inf, -1, -1
    for k in range(count):
        slack = -alpha[k]
        if slack < 0.0 and slack >= -SLACK_TOL * max(1.0, abs(alpha[k])):
            slack = 0.0
        b = beta[k]
        if b > eps:
            v = slack / b
            if v < p_hi:
                p_hi, hi_code = v, codes[k]
        elif b < -eps:
            v = slack / b
            if v > p_lo:
                p_lo, lo_code = v, codes[k]
        elif slack < 0.0:
            return codes[k], p_lo, lo_code, p_hi, hi_code
    return -1, p_lo, lo_code, p_hi, hi_code


def _eliminate(A, count, var):
    """Fourier-Motzkin: remove column ``2 + var`` of the constraints ``A[:count]``.

    A row of ``A`` is ``(code, alpha, beta, gamma_0, gamma_1, ...)`` for
    ``alpha + beta p + gamma . z <= 0``. Returns the new rows and their
    number; a combined pair keeps the code of its member with ``gamma > 0``.
    """
    width = A.shape[1]
    col = 3 + var
    pos, neg = 0, 0
    for k in range(count):
        if A[k, col] > 0.0:
            pos += 1
        elif A[k, col] < 0.0:
            neg += 1
    out = np.zeros((count - pos - neg + pos * neg, width))
    o = 0
    for k in range(count):
        if A[k, col] == 0.0:
            out[o, :] = A[k, :]
            o += 1
    for i in range(count):
        if A[i, col] > 0.0:
            for j in range(count):
                if A[j, col] < 0.0:
                    gi, gj = A[i, col], -A[j, col]
                    out[o, 0] = A[i, 0]
                    for w in range(1, width):
                        out[o, w] = A[i, w] / gi + A[j, w] / gj
                    out[o, col] = 0.0
                    o += 1
    return out, o


def _free_range(A, count, var, p, z):
    """The interval of ``z[var]`` that rows ``A[:count]`` allow, given ``p`` and ``z[:var]``."""
    lo, hi = -np.inf, np.inf
    for k in range(count):
        g = A[k, 3 + var]
        if g == 0.0:
            continue
        s = A[k, 1] + A[k, 2] * p
        for j in range(var):
            s += A[k, 3 + j] * z[j]
        if g > 0.0:
            hi = min(hi, -s / g)
        else:
            lo = max(lo, -s / g)
    return lo, hi


def singular_core(J, dw, H, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam, pull):
    """LP2 (eqs. 15-18) through the singular value decomposition; writes ``dq`` and ``lam``.

    Arguments and return value as :func:`lpik.fast.lp2_kernel.lp2_core` (without
    ``h_diag`` and the workspace): ``c`` is the criterion's ``f`` part, ``c_ref``
    sec. 3.1's pull (weighed as :func:`lpik.methods.kkt.smoothing_scale` weighs
    it: :func:`~lpik.methods.pull.pull_scale`, whose ``s`` goes to ``pull[0]``),
    joints with ``lower == upper`` are pinned. Returns
    ``(code, p, binding, residual)``; :data:`SINGULAR` when more than
    :data:`MAX_FREE_MULTIPLIERS` free multiplier directions meet finite
    multiplier bounds.
    """
    m, n = J.shape
    r = G.shape[0]
    # --- eq. 18 over the free joints (lpik.methods.kkt.pinned_system) ---
    Hp = np.zeros((n, n))
    Jt = np.zeros((n, m))
    rhs = np.zeros((n, 2))
    w_fixed = np.zeros(m)
    for i in range(n):
        if lower[i] == upper[i]:
            Hp[i, i] = 1.0
            rhs[i, 0] = lower[i]
            for a in range(m):
                w_fixed[a] += J[a, i] * lower[i]
            continue
        s = c[i]
        for j in range(n):
            if lower[j] == upper[j]:
                s -= H[i, j] * lower[j]
            else:
                Hp[i, j] = H[i, j]
        rhs[i, 0] = s
        rhs[i, 1] = c_ref[i]
        for a in range(m):
            Jt[i, a] = J[a, i]
    L = np.linalg.cholesky(Hp)
    Jh = _forward(L, Jt).T.copy()  # J L^-T, (m, n)
    ch = _forward(L, rhs)  # L^-1 c and L^-1 c_ref, (n, 2)
    U, sv, Vt = _svd(Jh)
    k0 = min(m, n)
    smax = sv[0] if k0 > 0 else 0.0
    regular = 0
    for i in range(k0):
        if sv[i] > SINGULAR_RTOL * smax and sv[i] > 0.0:
            regular += 1
    # --- the affine parts: y = L^T dq = ay + p by, lam = al + p bl (+ free directions) ---
    jc, jr = w_fixed.copy(), np.zeros(m)
    for a in range(m):
        for j in range(n):
            jc[a] += Jh[a, j] * ch[j, 0]
            jr[a] += Jh[a, j] * ch[j, 1]
    t, tr, e = np.zeros(m), np.zeros(m), np.zeros(m)
    for i in range(m):
        for a in range(m):
            t[i] += U[a, i] * jc[a]
            tr[i] += U[a, i] * jr[a]
            e[i] += U[a, i] * dw[a]
    ay, ey, by = ch[:, 0].copy(), ch[:, 1].copy(), np.zeros(n)
    al, el, bl = np.zeros(m), np.zeros(m), np.zeros(m)
    for i in range(regular):
        si = sv[i]
        for j in range(n):
            ay[j] -= Vt[i, j] * t[i] / si
            ey[j] -= Vt[i, j] * tr[i] / si
            by[j] += Vt[i, j] * e[i] / si
        for a in range(m):
            al[a] += U[a, i] * t[i] / (si * si)
            el[a] += U[a, i] * tr[i] / (si * si)
            bl[a] -= U[a, i] * e[i] / (si * si)
    a_q, e_q, b_q = np.empty(n), np.empty(n), np.empty(n)
    _backward(L, ay, a_q)
    _backward(L, ey, e_q)
    _backward(L, by, b_q)
    # --- sec. 3.1's pull: whole where it fits, else scaled to leave room (smoothing_scale) ---
    scale = pull_scale(a_q, e_q, lower, upper, al, el, lam_min, lam_max)
    pull[0] = scale
    for i in range(n):
        a_q[i] += scale * e_q[i]
    for a in range(m):
        al[a] += scale * el[a]
    # --- the singular directions: t_i = p e_i ---
    wmax, fmax = 0.0, 0.0
    for a in range(m):
        wmax, fmax = max(wmax, abs(dw[a])), max(fmax, abs(w_fixed[a]))
    tol = 0.25 * EQUALITY_RTOL * max(1.0, wmax, fmax)
    sing = singularity_code(n, m, r)
    fixed, p_fix = False, 0.0
    for i in range(regular, m):
        # J as the nearby matrix of lower rank: only the pinned joints' motion lies along u_i
        ti = 0.0
        for a in range(m):
            ti += U[a, i] * w_fixed[a]
        if abs(e[i]) > tol:
            v = ti / e[i]
            if fixed and abs(v - p_fix) > INTERVAL_TOL * max(1.0, abs(v)):
                return _stop(lower, upper, dq, sing)
            fixed, p_fix = True, v
        elif abs(ti) > tol:
            return _stop(lower, upper, dq, sing)
    # --- bounds on dq and the rows: alpha + beta p <= 0 ---
    count = 2 * n + r
    alpha, beta = np.empty(count), np.empty(count)
    codes = np.empty(count, dtype=np.int64)
    for i in range(n):
        alpha[2 * i], beta[2 * i], codes[2 * i] = lower[i] - a_q[i], -b_q[i], 2 * i
        alpha[2 * i + 1], beta[2 * i + 1], codes[2 * i + 1] = a_q[i] - upper[i], b_q[i], 2 * i + 1
    for j in range(r):
        sa, sb = 0.0, 0.0
        for i in range(n):
            sa += G[j, i] * a_q[i]
            sb += G[j, i] * b_q[i]
        alpha[2 * n + j], beta[2 * n + j], codes[2 * n + j] = sa - g[j], sb, 2 * (n + m + j) + 1
    stuck, p_lo, lo_code, p_hi, hi_code = _interval(alpha, beta, codes, count)
    if stuck >= 0:
        return _stop(lower, upper, dq, stuck)
    # --- every multiplier held at one value (the automatic bound's floor, B = 0) ---
    held = _held(lam_min, lam_max)
    fixer = sing  # what fixes p: the singularity, or a held multiplier
    if held:
        lmax = 1.0
        for a in range(m):
            lmax = max(lmax, abs(lam_min[a]), abs(al[a]), abs(bl[a]))
        ltol = 0.25 * EQUALITY_RTOL * lmax
        for i in range(regular):
            # lam's share along u_i is (al + p bl) . u_i: the held value's where hi_ = p bi
            hi_, bi, a_top = 0.0, 0.0, 0
            for a in range(m):
                hi_ += U[a, i] * (lam_min[a] - al[a])
                bi += U[a, i] * bl[a]
                if abs(U[a, i]) > abs(U[a_top, i]):
                    a_top = a
            # the multiplier that moves most along u_i binds, on the side lam would leave by
            if abs(bi) > ltol:
                code = 2 * (n + a_top) + (1 if U[a_top, i] * bi > 0.0 else 0)
                v = hi_ / bi
                if fixed and abs(v - p_fix) > INTERVAL_TOL * max(1.0, abs(v)):
                    return _stop(lower, upper, dq, code)
                fixed, p_fix, fixer = True, v, code
            elif abs(hi_) > ltol:
                side = 1 if U[a_top, i] * hi_ < 0.0 else 0
                return _stop(lower, upper, dq, 2 * (n + a_top) + side)
    # --- the multiplier bounds, the free directions eliminated ---
    free = m - regular
    bounded = False
    for a in range(m):
        if math.isfinite(lam_min[a]) or math.isfinite(lam_max[a]):
            bounded = True
    if bounded and not held and free > MAX_FREE_MULTIPLIERS:
        return SINGULAR, 0.0, -1, 0.0
    nz = free if bounded and not held else 0
    width = 3 + max(nz, 1)
    rows = np.zeros((2 * m, width))  # (code, alpha, beta, gamma...)
    nrows = 0
    for a in range(m):
        for side in range(2):
            bound = lam_max[a] if side == 1 else lam_min[a]
            if held or not math.isfinite(bound):
                continue
            sign = 1.0 if side == 1 else -1.0
            rows[nrows, 0] = 2 * (n + a) + side
            rows[nrows, 1] = sign * (al[a] - bound)
            rows[nrows, 2] = sign * bl[a]
            for j in range(nz):  # U is orthonormal: entries at rounding level are 0
                u = U[a, regular + j]
                rows[nrows, 3 + j] = sign * u if abs(u) > RATE_TOL**0.5 else 0.0
            nrows += 1
    stages = [(rows, nrows)]
    for var in range(nz - 1, -1, -1):
        A, cnt = _eliminate(stages[-1][0], stages[-1][1], var)
        stages.append((A, cnt))
    last, cnt = stages[-1]
    lam_codes = np.empty(cnt, dtype=np.int64)
    for k in range(cnt):
        lam_codes[k] = int(last[k, 0])
    stuck, q_lo, q_lo_code, q_hi, q_hi_code = _interval(
        last[:cnt, 1].copy(), last[:cnt, 2].copy(), lam_codes, cnt
    )
    if stuck >= 0:
        return _stop(lower, upper, dq, stuck)
    if q_hi < p_hi:
        p_hi, hi_code = q_hi, q_hi_code
    if q_lo > p_lo:
        p_lo, lo_code = q_lo, q_lo_code
    top, bottom = min(1.0, p_hi), max(0.0, p_lo)
    if top < bottom - INTERVAL_TOL:
        return _stop(lower, upper, dq, lo_code if bottom > 1.0 else hi_code)
    if fixed:
        if p_fix > top + INTERVAL_TOL or p_fix < bottom - INTERVAL_TOL:
            return _stop(lower, upper, dq, fixer)
        p = min(max(p_fix, bottom), max(top, bottom))
        binding = fixer if p < FULL_P else -1
    else:
        p = max(top, bottom)
        binding = hi_code if p < FULL_P else -1
    p = min(1.0, max(0.0, p))
    # --- the free directions, as close to 0 as the bounds allow ---
    z = np.zeros(max(nz, 1))
    for var in range(nz):
        A, cnt = stages[nz - 1 - var]
        lo, hi = _free_range(A, cnt, var, p, z)
        z[var] = min(max(0.0, lo), hi) if lo <= hi else 0.5 * (lo + hi)
    for i in range(n):  # the step, and its own check (as lpik.check.check_step)
        dq[i] = min(max(a_q[i] + p * b_q[i], lower[i]), upper[i])
    for a in range(m):
        v = al[a] + p * bl[a]
        for j in range(nz):
            u = U[a, regular + j]
            v += u * z[j] if abs(u) > RATE_TOL**0.5 else 0.0
        lam[a] = lam_min[a] if held else v
    ok, res = loop_check(J, dw, p, dq, lam, lam_min, lam_max, G, g)
    if not ok:
        return CHECK_FAILED, p, binding, res
    return OK, p, binding, res


def _held(lam_min, lam_max):
    """True when every multiplier's bounds coincide (and there is one): ``lam`` is given."""
    for a in range(lam_min.shape[0]):
        if lam_min[a] != lam_max[a]:
            return False
    return lam_min.shape[0] > 0


def _stop(lower, upper, dq, binding):
    """The outcome :data:`INFEASIBLE` with the safe step (0 clipped to the bounds) in ``dq``."""
    for i in range(lower.shape[0]):
        dq[i] = min(max(0.0, lower[i]), upper[i])
    return INFEASIBLE, 0.0, binding, 0.0
