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
  times the largest, and above :data:`~lpik.tolerances.SINGULAR_FLOOR`) ``mu_i`` is
  affine in ``p`` and so is ``dq``, as on the ratio-test path;
- along a *singular* one (``s_i`` below it, or beyond ``J``'s rank) the row
  reads ``t_i = p e_i``: ``dw`` must lie in the range of ``J`` (then ``p`` is
  free) or ``p`` is fixed there, usually at 0, and the binding limit is
  ``"singularity"``; ``mu_i`` is then a free variable that only the multiplier
  bounds (sec. 3.2) constrain. ``dq`` is unique whatever ``mu_i`` is.

The LP left over ``p`` and the free ``mu_i`` is solved exactly: the free
``mu_i`` are eliminated from the multiplier bounds (Fourier-Motzkin, at most
:data:`MAX_FREE_MULTIPLIERS` of them), the largest ``p`` in the remaining
intervals is taken as by the ratio test, and the free ``mu_i`` are chosen, by
back-substitution, as close to 0 as the bounds allow (the smallest
multipliers). With more free directions and finite bounds, the bounds become
rows on ``p`` alone, the facets of their image along the regular directions
(:func:`_facet_rows`), and ``lam`` a vertex of least ``sum |lam|``
(:func:`_vertex_multipliers`); beyond :data:`MAX_FACET_RANK` regular
directions, :data:`MAX_FACET_ROWS` task rows or with an infinite bound,
HiGHS decides. Where every multiplier is held at one value
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
from lpik.linalg import back_substitution, forward_substitution, regular_count
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

#: At most this many free multiplier directions are eliminated (Fourier-Motzkin); with more,
#: the bounds' image along the regular directions (:func:`_facet_rows`) takes them.
MAX_FREE_MULTIPLIERS = 2
#: :func:`_facet_rows` takes at most this many regular directions (its facets are normal to
#: pairs of generators); more, or an infinite multiplier bound, go to HiGHS.
MAX_FACET_RANK = 3
#: :func:`_vertex_multipliers` enumerates the vertices of ``m`` multipliers' box (``2^m``
#: choices at most); a step with more task rows than this goes to HiGHS there.
MAX_FACET_ROWS = 8


def singularity_code(n, m, r):
    """The binding code of ``"singularity"`` after ``n`` joints, ``m`` multipliers, ``r`` rows."""
    return 2 * (n + m + r)


def _svd(A):  # the compiled twin binds lpik.fast.jacobi.jacobi_svd instead
    return np.linalg.svd(A)


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
    Jh = forward_substitution(L, Jt).T.copy()  # J L^-T, (m, n)
    ch = forward_substitution(L, rhs)  # L^-1 c and L^-1 c_ref, (n, 2)
    U, sv, Vt = _svd(Jh)
    regular = regular_count(sv)
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
    back_substitution(L, ay, a_q)
    back_substitution(L, ey, e_q)
    back_substitution(L, by, b_q)
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
    fixed, p_fix, fixer = False, 0.0, sing  # fixer: what fixes p (a pinned joint, else sing)
    for i in range(regular, m):
        # J as the nearby matrix of lower rank: only the pinned joints' motion lies along u_i
        ti = 0.0
        for a in range(m):
            ti += U[a, i] * w_fixed[a]
        if abs(e[i]) > tol:
            v = ti / e[i]
            if fixed and abs(v - p_fix) > INTERVAL_TOL * max(1.0, abs(v)):
                return _stop(lower, upper, dq, _pinned_code(U, regular, J, dw, w_fixed, lower,
                                                            upper, False, sing))  # fmt: skip
            fixed, p_fix = True, v
        elif abs(ti) > tol:
            return _stop(lower, upper, dq, _pinned_code(U, regular, J, dw, w_fixed, lower, upper,
                                                        False, sing))  # fmt: skip
    if fixed:
        fixer = _pinned_code(U, regular, J, dw, w_fixed, lower, upper, True, sing)
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
    if held:  # or a held multiplier fixes p
        stop, fixed, p_fix, fixer = _held_share(U, regular, al, bl, lam_min, n, fixed, p_fix,
                                                fixer)  # fmt: skip
        if stop >= 0:
            return _stop(lower, upper, dq, stop)
    # --- the multiplier bounds, the free directions eliminated ---
    free = m - regular
    bounded = False
    for a in range(m):
        if math.isfinite(lam_min[a]) or math.isfinite(lam_max[a]):
            bounded = True
    # more free directions than eliminated: the bounds' image along the regular ones
    wide = bounded and not held and free > MAX_FREE_MULTIPLIERS
    if wide and (regular > MAX_FACET_RANK or m > MAX_FACET_ROWS or not _finite(lam_min, lam_max)):
        return SINGULAR, 0.0, -1, 0.0
    nz = free if bounded and not held and not wide else 0
    width = 3 + max(nz, 1)
    rows = np.zeros((2 * m, width))  # (code, alpha, beta, gamma...)
    nrows = 0
    for a in range(m):
        for side in range(2):
            bound = lam_max[a] if side == 1 else lam_min[a]
            if held or wide or not math.isfinite(bound):
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
    lam_alpha, lam_beta = last[:cnt, 1].copy(), last[:cnt, 2].copy()
    if wide:
        lam_alpha, lam_beta, lam_codes, cnt = _facet_rows(U, regular, al, bl, lam_min, lam_max, n)
    stuck, q_lo, q_lo_code, q_hi, q_hi_code = _interval(lam_alpha, lam_beta, lam_codes, cnt)
    if stuck >= 0:
        return _stop(lower, upper, dq, stuck)
    if q_hi < p_hi:
        p_hi, hi_code = q_hi, q_hi_code
    if q_lo > p_lo:
        p_lo, lo_code = q_lo, q_lo_code
    top, bottom = min(1.0, p_hi), max(0.0, p_lo)
    if top < bottom - INTERVAL_TOL:
        return _stop(lower, upper, dq, lo_code if bottom > 1.0 else hi_code)
    touching = top < bottom  # empty within INTERVAL_TOL: a point, where the rows hold there
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
    if wide and not _vertex_multipliers(U, regular, al, bl, p, lam_min, lam_max, lam):
        return CHECK_FAILED, p, binding, 0.0
    for a in range(m if not wide else 0):
        v = al[a] + p * bl[a]
        for j in range(nz):
            u = U[a, regular + j]
            v += u * z[j] if abs(u) > RATE_TOL**0.5 else 0.0
        lam[a] = lam_min[a] if held else v
    ok, res = loop_check(J, dw, p, dq, lam, lam_min, lam_max, G, g)
    if not ok and touching:  # a multiplier that p moves fast (1 / s_i^2) broken at the point
        ok, res = _within_bounds(L, rhs, scale, Jt, J, dw, p, lower, upper, lam_min, lam_max, G,
                                 g, dq, lam)  # fmt: skip
        if not ok:
            return _stop(lower, upper, dq, lo_code if bottom > 1.0 else hi_code)
    if not ok:
        return CHECK_FAILED, p, binding, res
    return OK, p, binding, res


def _pinned_code(U, regular, J, dw, w_fixed, lower, upper, raise_p, sing):
    """The limit of the pinned joint that stops the task where the free joints cannot move.

    A joint with ``lower == upper`` (at an end-stop with no room left, or braking
    at its acceleration limit) leaves eq. 18 over the free joints; where its column
    of ``J`` moves the task within the directions the free joints have lost (the
    columns ``u_i``, ``i >= regular``, of ``U``), that joint's limit stops the step,
    not a singular configuration (an arm with two joints braking was told
    "singularity" far from one). The motion the pinned joints would have to add,
    projected on the lost directions (basis-free, so that both SVDs agree): ``dw``
    itself where they fix ``p`` (``raise_p``: a larger ``p`` needs more of it), else
    ``p dw - w_fixed`` at the least-squares ``p`` in [0, 1] (no ``p`` makes the
    pinned joints' motion ``w_fixed`` fit the command there). The pinned joint whose
    column moves the task most along it binds, on its upper side where it would have
    to move up; ``sing`` where no pinned joint moves the task along it.
    """
    m, n = J.shape
    along_dw, along_w, dw_dw, dw_w = np.zeros(m), np.zeros(m), 0.0, 0.0
    for i in range(regular, m):
        for a in range(m):
            along_dw[i] += U[a, i] * dw[a]
            along_w[i] += U[a, i] * w_fixed[a]
        dw_dw += along_dw[i] * along_dw[i]
        dw_w += along_dw[i] * along_w[i]
    p = 1.0 if raise_p else (min(max(dw_w / dw_dw, 0.0), 1.0) if dw_dw > 0.0 else 0.0)
    need, norm = np.zeros(m), 0.0
    for i in range(regular, m):
        need[i] = along_dw[i] if raise_p else p * along_dw[i] - along_w[i]
        norm += need[i] * need[i]
    best, code, size = 0.0, sing, 0.0
    for j in range(n):
        c = 0.0  # need . J_j within the lost directions
        for i in range(regular, m):
            share = 0.0
            for a in range(m):
                share += U[a, i] * J[a, j]
                size = max(size, abs(J[a, j]))
            c += need[i] * share
        if lower[j] == upper[j] and abs(c) > best:
            best, code = abs(c), 2 * j + (1 if c > 0.0 else 0)
    return code if best > SINGULAR_RTOL * size * math.sqrt(norm) else sing


def held_joint_code(J, dw, lower, upper, sing):
    """:func:`_pinned_code` of a step whose ``p`` no active limit holds, for HiGHS's path.

    The lost directions are those of ``J`` over the free joints (``lower != upper``),
    from numpy's SVD; the pinned joints would have to raise ``p``. Returns the binding
    code ``2 j + side`` of a pinned joint, or ``sing`` (:func:`singularity_code`) where
    none moves the task along them: then it is a singular configuration.
    :func:`lpik.methods.duals.binding_from_duals` names it, so that HiGHS's path says
    what the ratio test says.
    """
    m, n = J.shape
    free = lower != upper
    if free.all():
        return sing
    U, sv, _ = np.linalg.svd(J[:, free]) if free.any() else (np.eye(m), np.zeros(0), None)
    regular = regular_count(sv)
    w_fixed = J[:, ~free] @ lower[~free]
    return int(_pinned_code(U, regular, J, dw, w_fixed, lower, upper, True, sing))


def _held(lam_min, lam_max):
    """True when every multiplier's bounds coincide (and there is one): ``lam`` is given."""
    for a in range(lam_min.shape[0]):
        if lam_min[a] != lam_max[a]:
            return False
    return lam_min.shape[0] > 0


def _held_share(U, regular, al, bl, held, n, fixed, p_fix, fixer):
    """Every multiplier held at ``held``: the ``p`` that the regular directions fix.

    ``lam``'s share along a regular direction ``u_i`` is ``(al + p bl) . u_i``; it
    must be the held value's, which fixes ``p`` (where ``bl . u_i`` is not 0) or
    leaves no step. The multiplier that moves most along ``u_i`` binds, on the side
    ``lam`` would leave by. Returns ``(stop, fixed, p_fix, fixer)``: ``stop`` the code
    of the conflict (``-1``: none), ``fixer`` the code of what fixes ``p``.
    """
    m = U.shape[0]
    lmax = 1.0
    for a in range(m):
        lmax = max(lmax, abs(held[a]), abs(al[a]), abs(bl[a]))
    ltol = 0.25 * EQUALITY_RTOL * lmax
    for i in range(regular):
        gap, bi, top = 0.0, 0.0, 0  # the share to make up, and its rate in p
        for a in range(m):
            gap += U[a, i] * (held[a] - al[a])
            bi += U[a, i] * bl[a]
            if abs(U[a, i]) > abs(U[top, i]):
                top = a
        if abs(bi) > ltol:
            code = 2 * (n + top) + (1 if U[top, i] * bi > 0.0 else 0)
            v = gap / bi
            if fixed and abs(v - p_fix) > INTERVAL_TOL * max(1.0, abs(v)):
                return code, fixed, p_fix, fixer
            fixed, p_fix, fixer = True, v, code
        elif abs(gap) > ltol:
            return 2 * (n + top) + (1 if U[top, i] * gap < 0.0 else 0), fixed, p_fix, fixer
    return -1, fixed, p_fix, fixer


def _finite(lam_min, lam_max):
    """True when every multiplier bound is finite."""
    for a in range(lam_min.shape[0]):
        if not (math.isfinite(lam_min[a]) and math.isfinite(lam_max[a])):
            return False
    return True


def _facet_rows(U, regular, al, bl, lam_min, lam_max, n):
    """The multiplier bounds as rows ``alpha + beta p <= 0`` on ``p`` alone (finite bounds).

    ``lam = al + p bl + U_s z`` lies within its bounds for some ``z`` exactly where
    its share along the regular directions, ``c(p) = U_r^T (al + p bl)``, lies in the
    image of the bounds' box, ``U_r^T box``: a zonotope in ``regular`` (at most
    :data:`MAX_FACET_RANK`) dimensions whose generators are the rows of ``U_r``. Each
    facet is normal to ``regular - 1`` generators; for each such unit normal ``nu``
    and its opposite, one row ``nu . c(p) <= max over the box of nu . U_r^T lam``.
    A row's code is the bound of the multiplier that moves most along ``nu``.
    Returns ``(alpha, beta, codes, count)``.
    """
    m = U.shape[0]
    normals = np.zeros((max(m * m, 1), 3))
    count = 0
    if regular == 1:
        normals[0, 0], count = 1.0, 1
    for a in range(m if regular == 2 else 0):
        normals[count, 0], normals[count, 1] = -U[a, 1], U[a, 0]
        count += 1
    for a in range(m if regular == 3 else 0):
        for b in range(a + 1, m):
            normals[count, 0] = U[a, 1] * U[b, 2] - U[a, 2] * U[b, 1]
            normals[count, 1] = U[a, 2] * U[b, 0] - U[a, 0] * U[b, 2]
            normals[count, 2] = U[a, 0] * U[b, 1] - U[a, 1] * U[b, 0]
            count += 1
    alpha, beta = np.empty(2 * count), np.empty(2 * count)
    codes = np.empty(2 * count, dtype=np.int64)
    rows = 0
    for k in range(count):
        size = math.sqrt(normals[k, 0] ** 2 + normals[k, 1] ** 2 + normals[k, 2] ** 2)
        if size <= SINGULAR_RTOL:
            continue  # two generators along one line: no facet
        for side in range(2):
            sign = (1.0 if side == 0 else -1.0) / size
            support, sa, sb, top, code = 0.0, 0.0, 0.0, 0.0, 0
            for a in range(m):
                s = 0.0
                for i in range(regular):
                    s += sign * normals[k, i] * U[a, i]
                support += s * (lam_max[a] if s > 0.0 else lam_min[a])
                sa += s * al[a]
                sb += s * bl[a]
                if abs(s) > top:
                    top, code = abs(s), 2 * (n + a) + (1 if s > 0.0 else 0)
            alpha[rows], beta[rows], codes[rows] = sa - support, sb, code
            rows += 1
    return alpha, beta, codes, rows


def _basic_values(U, c, x, cols, rest, d, W):
    """``x`` at the ``d`` basic multipliers ``cols`` from ``U_B^T x_B = c - U_N^T x_N``.

    The others (the bits of ``rest``) are given in ``x``; Gauss-Jordan with
    partial pivots on ``W`` (3, 4). False where the basic columns are dependent.
    """
    m = U.shape[0]
    for i in range(d):  # W = [U_B^T | c - U_N^T x_N]
        W[i, d] = c[i]
        for a in range(m):
            if rest >> a & 1:
                W[i, d] -= U[a, i] * x[a]
        for j in range(d):
            W[i, j] = U[cols[j], i]
    for j in range(d):
        piv = j
        for i in range(j + 1, d):
            if abs(W[i, j]) > abs(W[piv, j]):
                piv = i
        if abs(W[piv, j]) <= SINGULAR_RTOL:
            return False
        for col in range(d + 1):
            W[j, col], W[piv, col] = W[piv, col], W[j, col]
        for i in range(d):
            if i != j:
                f = W[i, j] / W[j, j]
                for col in range(j, d + 1):
                    W[i, col] -= f * W[j, col]
    for j in range(d):
        x[cols[j]] = W[j, d] / W[j, j]
    return True


def _vertex_multipliers(U, regular, al, bl, p, lam_min, lam_max, lam):
    """``lam`` within its (finite) bounds with ``U_r^T lam = U_r^T (al + p bl)``.

    A vertex of that polytope: ``regular`` multipliers solve the equations, the
    others sit on a bound; of the vertices within the bounds (to rounding), the
    one of least ``sum |lam|``. Where ``regular`` is 0 each multiplier is the
    value nearest 0 its bounds allow. Returns False where no vertex fits (rounding).
    """
    m = U.shape[0]
    d = regular
    if d == 0:
        for a in range(m):
            lam[a] = min(max(0.0, lam_min[a]), lam_max[a])
        return True
    c = np.zeros(3)
    for i in range(d):
        for a in range(m):
            c[i] += U[a, i] * (al[a] + p * bl[a])
    x, W, cols = np.empty(m), np.empty((3, 4)), np.empty(3, dtype=np.int64)
    best = np.inf
    for basic in range(1 << m):
        k = 0
        for a in range(m):
            if basic >> a & 1:
                cols[min(k, 2)] = a
                k += 1
        if k != d:
            continue
        rest = (1 << m) - 1 - basic
        upper_set = rest
        while True:  # every choice of bounds for the others (subsets of rest)
            for a in range(m):
                if rest >> a & 1:
                    x[a] = lam_max[a] if upper_set >> a & 1 else lam_min[a]
            ok = _basic_values(U, c, x, cols, rest, d, W)
            total = 0.0
            for j in range(d if ok else 0):
                a = cols[j]
                tol = EQUALITY_RTOL * max(1.0, abs(lam_min[a]), abs(lam_max[a]))
                if x[a] < lam_min[a] - tol or x[a] > lam_max[a] + tol:
                    ok = False
                x[a] = min(max(x[a], lam_min[a]), lam_max[a])
            for a in range(m):
                total += abs(x[a])
            if ok and total < best:
                best = total
                for a in range(m):
                    lam[a] = x[a]
            if upper_set == 0:
                break
            upper_set = (upper_set - 1) & rest
    return best < np.inf


def _within_bounds(L, rhs, scale, Jt, J, dw, p, lower, upper, lam_min, lam_max, G, g, dq, lam):
    """The step at ``p`` with ``lam`` clipped to its bounds, and its check.

    ``dq`` comes from eq. 18's criterion rows for that ``lam`` and is checked by
    :func:`~lpik.check.loop_check`. Where the interval of ``p`` closes to a point
    that a multiplier moving as ``1 / s_i^2`` breaks, this is the answer within
    the equality tolerance of ``J dq = p dw`` that a general LP solver returns
    (its own tolerances), or none.
    """
    n, m = Jt.shape
    for a in range(m):
        lam[a] = min(max(lam[a], lam_min[a]), lam_max[a])
    v = np.empty((n, 1))
    for i in range(n):
        v[i, 0] = rhs[i, 0] + scale * rhs[i, 1]
        for a in range(m):
            v[i, 0] -= Jt[i, a] * lam[a]
    back_substitution(L, forward_substitution(L, v)[:, 0], dq)
    for i in range(n):
        dq[i] = min(max(dq[i], lower[i]), upper[i])
    return loop_check(J, dw, p, dq, lam, lam_min, lam_max, G, g)


def _stop(lower, upper, dq, binding):
    """The outcome :data:`INFEASIBLE` with the safe step (0 clipped to the bounds) in ``dq``."""
    for i in range(lower.shape[0]):
        dq[i] = min(max(0.0, lower[i]), upper[i])
    return INFEASIBLE, 0.0, binding, 0.0
