"""The progress step's LP, compiled: least L1 task error within bounds and rows (no HiGHS).

The LP of :mod:`lpik.methods.progress` (the least-L1 task error, as Ho's LP
minimises an L1 norm, paper sec. 2.3), solved exactly by a small dense
bounded-variable primal simplex, so that a control loop takes it inside its
period. The interface, for every caller (the stall stage, ``mode="progress"``,
collision recovery with its distance rows)::

    code = least_error_step(J, target, lower, upper, G, g, dq)

    minimise  sum_k |J dq - target|_k + MOTION_WEIGHT sum_i |dq_i|
    subject to lower <= dq <= upper,  G dq <= g

- ``J`` (m, n), ``target`` (m,): the task rows and the displacement to come
  near (the command ``dw``);
- ``lower``, ``upper`` (n,): bounds on ``dq``, ``lower <= upper``; either may
  be infinite;
- ``G`` (r, n), ``g`` (r,): general extra rows (``r`` may be 0: a (0, n)
  array), e.g. the problem's rows ``G dq <= h - G q0`` or distance rows;
- ``dq`` (n,): receives the optimal step.

It returns :data:`SOLVED`, :data:`INFEASIBLE` (no ``dq`` within the bounds
holds the rows; ``dq`` is then ``0`` clipped to the bounds),
:data:`ITERATION_LIMIT` or :data:`SINGULAR_BASIS` (rounding left the basis
singular; ``dq`` as for :data:`INFEASIBLE`). The objective of a step is :func:`least_error_value`.
``MOTION_WEIGHT`` (:mod:`lpik.tolerances`) picks, among the steps of
least error, one of least motion, so that the joints do not jitter between
vertices; the simplex's tolerances are :data:`lpik.tolerances.SIMPLEX_PIVOT_TOL`
and :data:`~lpik.tolerances.SIMPLEX_COST_TOL`.

The method: ``dq = a - b`` with ``a, b >= 0`` (bounds split by sign, so that
``|dq_i| = a_i + b_i`` at the optimum), ``J dq - target = e+ - e-`` with
``e+-, >= 0``, a slack per row, and an artificial variable per row that the
start (``dq = 0`` clipped to its bounds) breaks (phase 1 drives them to 0).
Dantzig pricing, Bland's rule after a run of degenerate pivots (no cycling),
and at the optimum the basis is factorised afresh and the optimality checked
again on the fresh tableau, so that the answer is the vertex's exact value,
not the pivots' rounding. Sizes: ``m + r`` rows (a handful), ``2 n + 2 m +
2 r`` columns.

:func:`further_progress` is ``mode="progress"``'s second stage on the same
LP; :func:`largest_share_lp` is collision recovery's first LP (the largest share
of the distance rows' demand the bounds allow) on the same simplex.
:func:`state_rows` reads a fused step's LP inputs from its state buffer
(:mod:`lpik.fast.layout`) after the step; :func:`progress_in_state`,
:func:`stall_stage` and :func:`further_stage` solve on them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from lpik.fast import layout as L
from lpik.fast.autobound import clearly_regular
from lpik.fast.lp2_kernel import compiled_loop_check
from lpik.fast.step import (
    binding_label_index,
    brake_rows,
    continues,
    fading_in_state,
    step_bounds,
)
from lpik.fast.twins import compiled_twin
from lpik.methods import progress as rule
from lpik.methods.l1 import changes_motion
from lpik.tolerances import (
    ACTIVE_RTOL,
    DUAL_TOL,
    FEASIBILITY_TOL,
    FULL_P,
    MOTION_WEIGHT,
    SCALED_P_MARGIN,
    SIMPLEX_COST_TOL,
    SIMPLEX_PIVOT_TOL,
)

#: :func:`least_error_step`'s outcomes.
SOLVED, INFEASIBLE, ITERATION_LIMIT = 0, 1, 2
#: :func:`least_error_step`'s outcome when rounding left the basis singular (a pivot of
#: 0 in its fresh factorisation): no answer, the caller keeps its own step.
SINGULAR_BASIS = 3
#: :func:`stall_stage`'s decisions: the exact step stands (not a stall); it stalled and
#: ``dq`` holds the stalled step; it stalled but no motion brings the target nearer (the
#: exact step stands all the same; a stall for ``on_stall``'s count).
NOT_STALLED, STALLED, STALLED_NO_GAIN = 0, 1, 2
#: The stall stage's rule (:mod:`lpik.methods.progress`), compiled as it is.
_stall_limit = njit(cache=True)(rule.stall_limit)
_may_stall = compiled_twin(rule.may_stall, stall_limit=_stall_limit)
_motion_cosine = njit(cache=True)(rule.motion_cosine)
_moves_along = compiled_twin(rule.moves_along, motion_cosine=_motion_cosine)
_coasts_away = compiled_twin(rule.coasts_away, motion_cosine=_motion_cosine)
_drifts = compiled_twin(rule.drifts, coasts_away=_coasts_away)
_held_at_speed = compiled_twin(rule.held_at_speed, clearly_regular=clearly_regular)
_stalls = compiled_twin(rule.stalls, may_stall=_may_stall)
_exact_weight = njit(cache=True)(rule.exact_weight)
_makes_progress = njit(cache=True)(rule.makes_progress)
_scale = njit(cache=True)(rule.progress_scale)
_in_band = njit(cache=True)(rule.in_band)
_motion_prices = njit(cache=True)(rule.motion_prices)
_progress_center = compiled_twin(rule.progress_center, coasts_away=_coasts_away)
_changes_motion = njit(cache=True)(changes_motion)  # the criterion stage's rule
#: Degenerate pivots in a row after which the simplex prices by Bland's rule.
_BLAND_AFTER = 30
#: Fresh factorisations of the optimal basis before the answer stands.
_REFRESHES = 3


@njit(cache=True)
def least_error_value(J, target, dq):
    """``sum_k |J dq - target|_k + MOTION_WEIGHT sum_i |dq_i|``: the progress LP's objective."""
    m, n = J.shape
    total = 0.0
    for k in range(m):
        s = -target[k]
        for i in range(n):
            s += J[k, i] * dq[i]
        total += abs(s)
    for i in range(n):
        total += MOTION_WEIGHT * abs(dq[i])
    return total


@njit(cache=True)
def _columns(J, target, lower, upper, G, g, prices):
    """The standard form ``A x = b``, ``lo <= x <= up`` and the costs (see the module).

    ``prices`` (2, n): each joint's price per radian up and down (``MOTION_WEIGHT``:
    :func:`_even_prices`; the stall stage's: :func:`lpik.methods.progress.motion_prices`).
    """
    m, n = J.shape
    r = G.shape[0]
    rows, cols = m + r, 2 * n + 2 * m + 2 * r
    A, b = np.zeros((rows, cols)), np.empty(rows)
    lo, up, cost = np.zeros(cols), np.full(cols, np.inf), np.zeros(cols)
    for i in range(n):
        lo[i], up[i] = max(lower[i], 0.0), max(upper[i], 0.0)
        lo[n + i], up[n + i] = max(-upper[i], 0.0), max(-lower[i], 0.0)
        cost[i], cost[n + i] = prices[0, i], prices[1, i]
    for k in range(m):
        for i in range(n):
            A[k, i], A[k, n + i] = J[k, i], -J[k, i]
        A[k, 2 * n + k], A[k, 2 * n + m + k] = -1.0, 1.0
        cost[2 * n + k] = cost[2 * n + m + k] = 1.0
        b[k] = target[k]
    for j in range(r):
        for i in range(n):
            A[m + j, i], A[m + j, n + i] = G[j, i], -G[j, i]
        A[m + j, 2 * n + 2 * m + j], A[m + j, 2 * n + 2 * m + r + j] = 1.0, -1.0
        b[m + j] = g[j]
    return A, b, lo, up, cost


@njit(cache=True)
def _even_prices(n):
    """``MOTION_WEIGHT`` per radian for each joint, up and down: (2, n)."""
    return np.full((2, n), MOTION_WEIGHT)


@njit(cache=True)
def _start(A, b, lo, x, basis, row_of, m, r):
    """The start: every column at its lower bound, one basic column per row that fits it.

    Task row ``k``: ``e-`` or ``e+``; extra row ``j``: its slack, or where the
    start breaks the row its artificial variable. Returns whether any artificial is basic.
    """
    rows, cols = A.shape
    x[:] = lo
    row_of[:] = -1
    need = False
    for i in range(rows):
        res = b[i]
        for j in range(cols):
            res -= A[i, j] * x[j]
        if i < m:
            j = cols - 2 * r - m + i if res >= 0.0 else cols - 2 * r - 2 * m + i
        else:
            j = cols - 2 * r + (i - m) if res >= 0.0 else cols - r + (i - m)
            need = need or res < 0.0
        basis[i], row_of[j] = j, i
        x[j] = abs(res)
    return need


@njit(cache=True)
def _entering(T, cost, x, lo, up, basis, row_of, bland):
    """The entering column and its direction (+1 up, -1 down), or (-1, 0) at the optimum."""
    rows, cols = T.shape
    best, best_j, best_dir = 0.0, -1, 0
    for j in range(cols):
        if row_of[j] >= 0 or up[j] <= lo[j]:
            continue
        d = cost[j]
        for i in range(rows):
            d -= cost[basis[i]] * T[i, j]
        if x[j] <= lo[j] and d < -SIMPLEX_COST_TOL:
            gain, direction = -d, 1
        elif x[j] >= up[j] and d > SIMPLEX_COST_TOL:
            gain, direction = d, -1
        else:
            continue
        if gain > best:
            best, best_j, best_dir = gain, j, direction
            if bland:
                break
    return best_j, best_dir


@njit(cache=True)
def _leaving(T, x, lo, up, basis, j, direction, bland):
    """The ratio test: ``(row, step)``, row -1 for a bound flip of ``j`` (step inf: unbounded)."""
    rows = T.shape[0]
    t_min = up[j] - lo[j]
    for i in range(rows):
        alpha, k = direction * T[i, j], basis[i]
        if alpha > SIMPLEX_PIVOT_TOL:
            t_min = min(t_min, max(x[k] - lo[k], 0.0) / alpha)
        elif alpha < -SIMPLEX_PIVOT_TOL and up[k] < np.inf:
            t_min = min(t_min, max(up[k] - x[k], 0.0) / -alpha)
    if t_min >= up[j] - lo[j]:
        return -1, t_min
    best, row = -1.0, -1  # among the rows that tie at t_min: the largest pivot (Bland: first)
    for i in range(rows):
        alpha, k = direction * T[i, j], basis[i]
        if alpha > SIMPLEX_PIVOT_TOL:
            t = max(x[k] - lo[k], 0.0) / alpha
        elif alpha < -SIMPLEX_PIVOT_TOL and up[k] < np.inf:
            t = max(up[k] - x[k], 0.0) / -alpha
        else:
            continue
        if t <= t_min * (1.0 + 1e-12) + 1e-300 and abs(alpha) > best:
            best, row = abs(alpha), i
            if bland:
                break
    return row, t_min


@njit(cache=True)
def _move(T, x, lo, up, basis, row_of, j, direction, row, t):
    """Move ``j`` by ``t`` and the basic columns with it; pivot on ``(row, j)`` unless a flip."""
    rows, cols = T.shape
    for i in range(rows):
        x[basis[i]] -= direction * t * T[i, j]
    if row < 0:
        x[j] = up[j] if direction > 0 else lo[j]
        return
    x[j] = (lo[j] if direction > 0 else up[j]) + direction * t
    k = basis[row]
    x[k] = lo[k] if direction * T[row, j] > 0 else up[k]
    row_of[k], row_of[j], basis[row] = -1, row, j
    pivot = T[row, j]
    for c in range(cols):
        T[row, c] /= pivot
    for i in range(rows):
        if i != row and T[i, j] != 0.0:
            f = T[i, j]
            for c in range(cols):
                T[i, c] -= f * T[row, c]


@njit(cache=True)
def _pivots(T, cost, x, lo, up, basis, row_of, limit):
    """Simplex iterations until no column improves.

    Returns the iterations left, or -1 when ``limit`` ran out or the LP is unbounded
    (not an LP of this module: every column with a negative cost is bounded above).
    """
    degenerate = 0
    while True:
        bland = degenerate > _BLAND_AFTER
        j, direction = _entering(T, cost, x, lo, up, basis, row_of, bland)
        if j < 0:
            return limit
        if limit == 0:
            return -1
        limit -= 1
        row, t = _leaving(T, x, lo, up, basis, j, direction, bland)
        if t == np.inf:
            return -1
        degenerate = degenerate + 1 if t == 0.0 else 0
        _move(T, x, lo, up, basis, row_of, j, direction, row, t)


@njit(cache=True)
def _refresh(A, b, x, lo, up, basis, row_of, T):
    """``T = B^-1 A`` and the basic values afresh from the basis (Gauss-Jordan, partial pivots).

    Returns False (``T`` and ``x`` then unusable) where the basis is singular: a pivot
    of at most :data:`~lpik.tolerances.SIMPLEX_PIVOT_TOL` after the partial pivoting.
    """
    rows, cols = A.shape
    W = np.empty((rows, cols + 1))
    for i in range(rows):
        s = b[i]
        for j in range(cols):
            W[i, j] = A[i, j]
            if row_of[j] < 0:
                s -= A[i, j] * x[j]
        W[i, cols] = s
    order = basis.copy()
    for p in range(rows):
        j = order[p]
        piv = p
        for i in range(p + 1, rows):
            if abs(W[i, j]) > abs(W[piv, j]):
                piv = i
        if piv != p:
            for c in range(cols + 1):
                W[p, c], W[piv, c] = W[piv, c], W[p, c]
        pivot = W[p, j]
        if abs(pivot) <= SIMPLEX_PIVOT_TOL:
            return False
        for c in range(cols + 1):
            W[p, c] /= pivot
        for i in range(rows):
            if i != p and W[i, j] != 0.0:
                f = W[i, j]
                for c in range(cols + 1):
                    W[i, c] -= f * W[p, c]
    for p in range(rows):  # row p of W now holds basic column order[p]
        j = order[p]
        basis[p], row_of[j] = j, p
        x[j] = min(max(W[p, cols], lo[j]), up[j])
        for c in range(cols):
            T[p, c] = W[p, c]
    return True


@njit(cache=True)
def _solve(A, b, lo, up, cost, x, basis, row_of, T):
    """Pivot, factorise the basis afresh, and again until the fresh tableau is optimal."""
    limit = 50 * (A.shape[0] + A.shape[1])
    for _ in range(_REFRESHES):
        limit = _pivots(T, cost, x, lo, up, basis, row_of, limit)
        if limit < 0:
            return ITERATION_LIMIT
        if not _refresh(A, b, x, lo, up, basis, row_of, T):
            return SINGULAR_BASIS
        if _entering(T, cost, x, lo, up, basis, row_of, False)[0] < 0:
            return SOLVED
    return ITERATION_LIMIT


@njit(cache=True)
def _two_phases(A, b, lo, up, cost, r, g, x):
    """Phase 1 where the start needs it, then phase 2 on ``cost``: the outcome; ``x`` the vertex.

    Phase 1 drives the ``r`` artificial columns (the last ones) to 0; each row's
    tolerance is relative to its own right-hand side in ``g``, as the check's
    (:func:`lpik.collision.recovery.rows_kept`): one scale for all would let a row of
    ``1e9`` (a reserved row with no pair in reach) excuse a violation of the others.
    """
    rows, cols = A.shape
    basis, row_of = np.empty(rows, np.int64), np.empty(cols, np.int64)
    return _phases(A, b, lo, up, cost, r, g, x, basis, row_of, np.empty((rows, cols)))


@njit(cache=True)
def _phases(A, b, lo, up, cost, r, g, x, basis, row_of, T):
    """:func:`_two_phases` with its basis (``basis``, ``row_of``) and tableau ``T`` the caller's.

    At :data:`SOLVED` they hold the optimal vertex's, for a further LP on the same rows.
    """
    rows, cols = A.shape
    need = _start(A, b, lo, x, basis, row_of, rows - r, r)
    if not _refresh(A, b, x, lo, up, basis, row_of, T):
        return SINGULAR_BASIS
    if need:  # phase 1: the artificial variables down to 0
        phase1 = np.zeros(cols)
        phase1[cols - r :] = 1.0
        code = _solve(A, b, lo, up, phase1, x, basis, row_of, T)
        if code != SOLVED:
            return code
        for j in range(r):
            if x[cols - r + j] > FEASIBILITY_TOL * max(1.0, abs(g[j])):
                return INFEASIBLE
    up[cols - r :] = 0.0  # phase 2: the artificial variables stay at 0
    for j in range(cols - r, cols):
        x[j] = 0.0
    return _solve(A, b, lo, up, cost, x, basis, row_of, T)


@njit(cache=True)
def least_error_step(J, target, lower, upper, G, g, dq):
    """The progress LP of the module docstring: writes ``dq``, returns the outcome.

    A row ``0 dq <= g`` with ``g >= 0`` (a scene's reserved row with no pair in
    reach, ``INACTIVE_RHS``) holds whatever the step and is left out: its slack
    would stay basic and never price, and a scene reserves one row per pair.
    """
    return priced_least_error_step(J, target, lower, upper, G, g, _even_prices(J.shape[1]), dq)


@njit(cache=True)
def priced_least_error_step(J, target, lower, upper, G, g, prices, dq):
    """:func:`least_error_step` with each joint's motion priced by ``prices`` (2, n): up, down."""
    n = J.shape[1]
    G, g = _binding_rows(G, g)
    A, b, lo, up, cost = _columns(J, target, lower, upper, G, g, prices)
    for i in range(n):
        dq[i] = min(max(0.0, lower[i]), upper[i])
    x = np.empty(A.shape[1])
    code = _two_phases(A, b, lo, up, cost, G.shape[0], g, x)
    if code == SOLVED:
        for i in range(n):
            dq[i] = min(max(x[i] - x[n + i], lower[i]), upper[i])
    return code


@njit(cache=True)
def _binding_rows(G, g):
    """The rows of ``G dq <= g`` that can bind: those with a coefficient, or with ``g < 0``.

    ``G`` and ``g`` themselves where every row can (no copy on the common path).
    """
    r, n = G.shape
    count = 0
    for j in range(r):
        count += _can_bind(G, g, j)
    if count == r:
        return G, g
    G_kept, g_kept = np.empty((count, n)), np.empty(count)
    k = 0
    for j in range(r):
        if _can_bind(G, g, j):
            G_kept[k] = G[j]
            g_kept[k] = g[j]
            k += 1
    return G_kept, g_kept


@njit(cache=True)
def _can_bind(G, g, j):
    """Whether row ``j`` of ``G dq <= g`` can bind: a coefficient, or ``g_j < 0``."""
    if g[j] < 0.0:
        return True
    for i in range(G.shape[1]):
        if G[j, i] != 0.0:
            return True
    return False


@njit(cache=True)
def largest_share_lp(G, b, demand, lower, upper):
    """The largest share ``s`` in [0, 1] of ``demand`` that the rows and bounds allow.

    Maximise ``s`` with ``G dq - s demand <= b`` and ``lower <= dq <= upper``
    (:func:`lpik.collision.recovery.highs_largest_share`'s LP, by this module's
    simplex: the share is one more column, priced -1). Returns ``(outcome, s)``.
    """
    r, n = G.shape
    rows = np.empty((r, n + 1))
    for j in range(r):
        for i in range(n):
            rows[j, i] = G[j, i]
        rows[j, n] = -demand[j]
    lo, hi = np.append(lower, 0.0), np.append(upper, 1.0)
    A, bb, col_lo, col_up, cost = _columns(np.empty((0, n + 1)), np.empty(0), lo, hi, rows, b,
                                           _even_prices(n + 1))  # fmt: skip
    cost[:] = 0.0
    cost[n] = -1.0  # the share's column (its negative part is fixed at 0)
    x = np.empty(A.shape[1])
    code = _two_phases(A, bb, col_lo, col_up, cost, r, b, x)
    return code, min(max(x[n] - x[2 * n + 1], 0.0), 1.0) if code == SOLVED else 0.0


@njit(cache=True)
def least_l1_in_state(state, q0, q_prev, dq, residual):
    """Ho's LP past the full displacement (:func:`lpik.methods.l1.l1`) on a fused step's state.

    The controller's step where LP2's conditions admit none (the fused step
    ``infeasible``) but a motion along the command exists: LP1's largest ``p``
    (eqs. 11-14) on the step's problem (:func:`state_rows`: its ``J``, command,
    bounds and rows; around the arm's motion where the step is, in ``u = dq -
    last``: :func:`lpik.continuation.continued`), then, with ``p`` at most
    :data:`~lpik.tolerances.SCALED_P_MARGIN` below it, the least ``sum |u|``, the
    least change of the motion: the second LP goes on from the first's optimal
    vertex in the same tableau. ``dq`` receives the step from ``q0`` and
    ``residual[0]`` its ``max |J u - p (dw - J last)|`` (the line around the motion,
    as the numpy stage's :func:`lpik.continuation.resumed` keeps it).

    Returns ``(outcome, p, label)``: :data:`SOLVED` for a step that passes the
    check of :func:`lpik.check.loop_check` and changes the motion toward the
    command (:func:`lpik.methods.l1.changes_motion`), else
    :data:`INFEASIBLE`; ``label``: the binding limit's index in the step's label
    table (:func:`lpik.fast.step.binding_label_index` of :func:`_share_binding`'s
    code; -1 at ``p = 1``).
    """
    n = q0.shape[0]
    kinds = np.empty((2, n))
    J, dw, lower, upper, G, g = _rows_and_kinds(state, q0, q_prev, True, True, kinds)
    m, r = J.shape[0], G.shape[0]
    last = np.zeros(n)
    if continues(state, q0, q_prev):
        for i in range(n):
            last[i] = min(max(q0[i] - q_prev[i], lower[i]), upper[i])
    dw_u, g_u = dw.copy(), g.copy()  # the step in u (continuation.continued)
    for i in range(n):
        for k in range(m):
            dw_u[k] -= J[k, i] * last[i]
        for j in range(r):
            g_u[j] -= G[j, i] * last[i]
    A, b, lo, up, cost = _share_columns(J, dw_u, lower - last, upper - last, G, g_u)
    rows, cols = A.shape
    basis, row_of, T = np.empty(rows, np.int64), np.empty(cols, np.int64), np.empty((rows, cols))
    x = np.empty(cols)
    code = _phases(A, b, lo, up, cost, rows, b, x, basis, row_of, T)
    if code != SOLVED:
        return code, 0.0, -1
    share = x[n] - x[2 * n + 1]
    binding = -1 if share >= FULL_P else _share_binding(T, cost, x, lo, up, b, basis, n, m, r)
    first = x.copy()
    lo[n] = up[n] = 1.0  # Ho's LP at the full displacement where LP1 reaches it, else below
    if share < FULL_P:
        lo[n], up[n] = max(0.0, share - SCALED_P_MARGIN), share
    x[n] = min(max(x[n], lo[n]), up[n])
    for j in range(cols):
        cost[j] = 1.0 if j < 2 * n + 2 and j != n and j != 2 * n + 1 else 0.0
    if _solve(A, b, lo, up, cost, x, basis, row_of, T) != SOLVED:
        x = first
    p = min(max(x[n] - x[2 * n + 1], 0.0), 1.0)
    u = np.empty(n)
    for i in range(n):
        dq[i] = min(max(last[i] + x[i] - x[n + 1 + i], lower[i]), upper[i])
        u[i] = dq[i] - last[i]
    zero = np.zeros(m)
    ok, residual[0] = compiled_loop_check(J, dw_u, p, u, zero, zero, zero, G, g_u)
    if not (ok and _changes_motion(p)):  # no change toward the command: the caller's safe step
        return INFEASIBLE, p, -1
    return SOLVED, p, -1 if binding < 0 else binding_label_index(binding, kinds, m + r)


@njit(cache=True)
def _share_columns(J, dw, lower, upper, G, g):
    """LP1 as :func:`largest_share_lp`'s LP: ``(A, b, lo, up, cost)``.

    ``[J; G] u - s [dw; 0] (=, <=) [0; g]`` (``J u = s dw``, eq. 12: the task rows'
    slacks held at 0), ``lower <= u <= upper`` and ``0 <= s <= 1`` (column ``n``),
    priced ``-1``: the largest share. The start (``u = 0``, ``s = 0``; 0 is within
    the bounds of a step around the motion) meets the task rows.
    """
    m, n = J.shape
    r = G.shape[0]
    rows = np.zeros((m + r, n + 1))
    rhs = np.zeros(m + r)
    for k in range(m):
        for i in range(n):
            rows[k, i] = J[k, i]
        rows[k, n] = -dw[k]
    for j in range(r):
        for i in range(n):
            rows[m + j, i] = G[j, i]
        rhs[m + j] = g[j]
    lo, up = np.append(lower, 0.0), np.append(upper, 1.0)
    A, b, lo, up, cost = _columns(np.empty((0, n + 1)), np.empty(0), lo, up, rows, rhs,
                                  _even_prices(n + 1))  # fmt: skip
    for k in range(m):
        up[2 * n + 2 + k] = 0.0  # the task row's slack: an equality
    cost[:] = 0.0
    cost[n] = -1.0
    return A, b, lo, up, cost


@njit(cache=True)
def _share_binding(T, cost, x, lo, up, b, basis, n, m, r):
    """The limit that holds LP1's ``p`` at :func:`_share_columns`'s optimal vertex: its code.

    Among the joints' bounds and the rows that are active (within
    :data:`~lpik.tolerances.ACTIVE_RTOL`), the one whose reduced cost (its dual) is
    largest, as :func:`lpik.methods.duals.binding_from_duals` reads HiGHS's duals;
    :func:`lpik.methods.singular.singularity_code` where none exceeds
    :data:`~lpik.tolerances.DUAL_TOL`. Joint ``k``'s step is ``x_k - x_{n+1+k}``, its
    bounds ``up_k - lo_{n+1+k}`` and ``lo_k - up_{n+1+k}``; row ``j``'s slack is
    column ``2 n + 2 + j`` of the ``m + r`` rows (the rows after the task's).
    """
    best, code = DUAL_TOL, 2 * (n + m + r)
    for k in range(n + r):
        j = k if k < n else 2 * n + 2 + m + (k - n)
        d = cost[j]
        for i in range(T.shape[0]):
            d -= cost[basis[i]] * T[i, j]
        if abs(d) <= best:
            continue
        if k >= n:  # a row: active where its slack is 0
            if x[j] <= ACTIVE_RTOL * max(1.0, abs(b[m + k - n])):
                best, code = abs(d), 2 * (n + m + k - n)
            continue
        u, high, low = x[k] - x[n + 1 + k], up[k] - lo[n + 1 + k], lo[k] - up[n + 1 + k]
        at_hi = math.isfinite(high) and abs(u - high) <= ACTIVE_RTOL * max(1.0, abs(high))
        at_lo = math.isfinite(low) and abs(u - low) <= ACTIVE_RTOL * max(1.0, abs(low))
        if at_hi or at_lo:
            best, code = abs(d), 2 * k + (1 if at_hi and (not at_lo or d <= 0.0) else 0)
    return code


@njit(cache=True)
def further_progress(J, dw, lower, upper, G, g, dq1, dq):
    """``mode="progress"``'s second stage: ``dq = dq1 + delta``, delta of least error left.

    ``delta`` minimises ``|J delta - (dw - J dq1)|_1 + MOTION_WEIGHT |delta|_1``
    within ``lower - dq1 <= delta <= upper - dq1`` and ``G delta <= g - G dq1``,
    and keeps each task row's error within the exact step's:
    ``|J_k (dq1 + delta) - dw_k| <= |J_k dq1 - dw_k|`` (``delta = 0`` is a
    candidate, so the step is never worse than ``dq1`` on any row).
    """
    m, n = J.shape
    r = G.shape[0]
    rows = np.empty((r + 2 * m, n))
    rhs, left = np.empty(r + 2 * m), np.empty(m)
    lo, hi, delta = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        lo[i], hi[i] = min(lower[i] - dq1[i], 0.0), max(upper[i] - dq1[i], 0.0)
    for j in range(r):
        s = g[j]
        for i in range(n):
            rows[j, i] = G[j, i]
            s -= G[j, i] * dq1[i]
        rhs[j] = max(s, 0.0)
    for k in range(m):
        e = -dw[k]
        for i in range(n):
            e += J[k, i] * dq1[i]
            rows[r + k, i], rows[r + m + k, i] = J[k, i], -J[k, i]
        left[k] = -e
        rhs[r + k], rhs[r + m + k] = abs(e) - e, abs(e) + e
    code = least_error_step(J, left, lo, hi, rows, rhs, delta)
    for i in range(n):
        dq[i] = min(max(dq1[i] + (delta[i] if code == SOLVED else 0.0), lower[i]), upper[i])
    return code


@njit(cache=True)
def state_rows(state, q0, q_prev, singular_stop, stops_ahead):
    """The step's ``J``, ``dw``, bounds on ``dq`` and rows ``G dq <= h - G q0`` from ``state``.

    ``singular_stop`` False: the bounds without the stop before a singular configuration
    (:func:`lpik.fast.step.fading_in_state`; the floor's row takes its place).
    ``stops_ahead`` False: the joints' own bands, without any stop ahead of the motion
    (the rows stage: :meth:`lpik.control.stepper.Stepper.within_rows`).
    """
    return _rows_and_kinds(state, q0, q_prev, singular_stop, stops_ahead,
                           np.empty((2, q0.shape[0])))  # fmt: skip


@njit(cache=True)
def _rows_and_kinds(state, q0, q_prev, singular_stop, stops_ahead, kinds):
    """:func:`state_rows`, with which limit sets each joint's bounds written into ``kinds``."""
    n, m, r = q0.shape[0], int(state[L.M]), int(state[L.R])
    lower, upper = np.empty(n), np.empty(n)
    J, dw = L.matrix_at(state, L.JACOBIAN, m, n), L.vector(state, L.DW)
    moving = stops_ahead and continues(state, q0, q_prev)
    fading, own = (fading_in_state(state, q0, q_prev, J, dw, singular_stop) if moving
                   else (math.inf, math.inf))  # fmt: skip
    step_bounds(L.matrix_at(state, L.LIMITS, 6, n), state[L.DT], q0, q_prev, lower, upper, kinds,
                fading, own)  # fmt: skip
    G, h = L.matrix_at(state, L.ROWS_G, r, n), L.vector(state, L.ROWS_H)
    g = np.empty(r)
    for j in range(r):
        s = h[j]
        for i in range(n):
            s -= G[j, i] * q0[i]
        g[j] = s
    brake_rows(state, q0, g)
    return J, dw, lower, upper, G, g


@njit(cache=True)
def progress_in_state(state, q0, q_prev, dq, floor, exact, engaged):
    """The stall stage's progress step on the step a fused step left in ``state``.

    ``J`` and ``dw`` are the step's (its Jacobian and command blocks), the
    bounds are recomputed from ``q0`` and ``q_prev`` (eqs. 13-14) and the rows
    are the state's. ``floor`` (n + 1): where the arm's motion has reached the
    automatic bound's floor, its row and right-hand side
    (:func:`lpik.methods.autobound.floor_row`), which the step takes instead of
    the stop ahead's band; ``floor[n]`` inf: none. ``exact`` (n,): the exact step,
    the motion term's center where the step is not solved around a motion
    (:func:`lpik.methods.progress.progress_center`); ``engaged``: the last step was
    the progress step (the motion's prices: :func:`lpik.methods.progress.motion_prices`,
    from the last motion ``q0 - q_prev``). Returns ``(outcome, error
    before, error after)``: the L1 task errors ``sum |dw|`` and ``sum |J dq - dw|``.
    """
    n = q0.shape[0]
    on_floor = floor[n] < math.inf  # the row instead of the stop ahead
    J, dw, lower, upper, G, g = state_rows(state, q0, q_prev, not on_floor, True)
    if on_floor:  # one more row floor[:n] . dq <= floor[n]
        G = np.vstack((G, floor[:n].copy().reshape((1, n))))
        g = np.append(g, floor[n])
    m, r = J.shape[0], G.shape[0]
    last = np.empty(n)
    for i in range(n):
        last[i] = q0[i] - q_prev[i]
    moving = continues(state, q0, q_prev)
    center = _progress_center(J, dw, last, exact, moving, lower, upper, np.empty(n))
    shifted, lo, hi, rhs, delta = dw.copy(), lower - center, upper - center, g.copy(), np.empty(n)
    for k in range(m):
        for i in range(n):
            shifted[k] -= J[k, i] * center[i]
    for j in range(r):
        for i in range(n):
            rhs[j] -= G[j, i] * center[i]
    prices = _motion_prices(last, center, engaged, np.empty((2, n)))
    code = priced_least_error_step(J, shifted, lo, hi, G, rhs, prices, delta)
    for i in range(n):
        dq[i] = min(max(center[i] + delta[i], lower[i]), upper[i])
    zero = np.zeros(n)
    return code, least_error_value(J, dw, zero), least_error_value(J, dw, dq) - _motion(dq)


@njit(cache=True)
def stall_stage(state, q0, q_prev, exact_dq, p, held, velocity, by_row, engaged, floor, dq,
                residual):  # fmt: skip
    """The stall stage's rule (:class:`lpik.methods.progress.StallWatch`) on the exact step.

    The exact step (``exact_dq``, its ``p``; ``held``, ``velocity``, ``by_row``: its
    binding limit is an acceleration limit, a velocity limit, a row: with the step's
    direction, :func:`~lpik.methods.progress.at_speed` and
    :func:`~lpik.methods.progress.drifts`) is the one a fused step left in
    ``state``; ``engaged``: the step before it was the progress step
    (:meth:`~lpik.methods.progress.StallWatch.engaged_at`, False for a batch row).
    Within the band after a progress step
    (:meth:`~lpik.methods.progress.StallWatch.keeping`), where the step was not
    solved around a motion, the band's rule applies. Where the step
    :func:`~lpik.methods.progress.may_stall`, :func:`progress_in_state` solves the
    progress step (``floor`` as there) and :func:`~lpik.methods.progress.stalls`
    compares the two steps' gains; a stalled step is
    :func:`~lpik.methods.progress.stalled_step`'s blend, written into ``dq``, with
    ``max |J dq - dw|`` in ``residual[0]``. One call, so that a stalled step of a
    control loop costs one compiled call and the Result. Returns :data:`NOT_STALLED`,
    :data:`STALLED` or :data:`STALLED_NO_GAIN` (:func:`~lpik.methods.progress.makes_progress`;
    a step that brakes a motion carrying the tool away from the command,
    :func:`~lpik.methods.progress.drifts`, is :data:`STALLED` without a gain).
    """
    moving = continues(state, q0, q_prev)
    keeping = _in_band(engaged, moving)
    n, m = q0.shape[0], int(state[L.M])
    J, dw = L.matrix_at(state, L.JACOBIAN, m, n), L.vector(state, L.DW)
    # at_speed counts only for a step not solved around a motion, outside the band
    at_speed = not (moving or keeping) and _held_at_speed(velocity, J)
    last = np.empty(n)
    for i in range(n):
        last[i] = q0[i] - q_prev[i]
    along, drifting = (
        _moves_along(J, dw, last, moving),
        _drifts(J, dw, last, moving, held or by_row),
    )
    if not _may_stall(p, held, moving, keeping, at_speed, along):
        return NOT_STALLED
    code, before, after = progress_in_state(state, q0, q_prev, dq, floor, exact_dq, engaged)
    if code != SOLVED:
        return NOT_STALLED
    exact_after = _task_error(J, dw, exact_dq)[0]
    gains = (before - exact_after, before - after)
    if not _stalls(p, *gains, held, moving, keeping, _scale(dw), at_speed, along, drifting):
        return NOT_STALLED
    weight = _exact_weight(p)
    if weight != 0.0:
        for i in range(n):
            dq[i] = weight * exact_dq[i] + (1.0 - weight) * dq[i]
    after, residual[0] = _task_error(J, dw, dq)
    # a step that brakes a drifting motion stands without a gain (rule.stalls)
    return STALLED if drifting or _makes_progress(before, after, _scale(dw)) else STALLED_NO_GAIN


@njit(cache=True)
def further_stage(state, q0, q_prev, dq1, dq, residual):
    """``mode="progress"``'s second stage after the exact step ``dq1`` and its verdict, one call.

    :func:`further_progress` over ``state``'s step (:func:`state_rows`). ``dq``
    receives the step and ``residual[0]`` its ``max |J dq - dw|``. Returns True where
    the LP answered and the step reduces the L1 task error that the exact step
    leaves (:func:`~lpik.methods.progress.makes_progress`); False: the exact step stands.
    """
    J, dw, lower, upper, G, g = state_rows(state, q0, q_prev, True, True)
    if further_progress(J, dw, lower, upper, G, g, dq1, dq) != SOLVED:
        return False
    before = _task_error(J, dw, dq1)[0]
    after, residual[0] = _task_error(J, dw, dq)
    return _makes_progress(before, after, _scale(dw))


@njit(cache=True)
def _task_error(J, dw, dq):
    """``(sum_k |J dq - dw|_k, max_k |J dq - dw|_k)``: the task error a step leaves."""
    total, worst = 0.0, 0.0
    for k in range(J.shape[0]):
        s = -dw[k]
        for i in range(J.shape[1]):
            s += J[k, i] * dq[i]
        total += abs(s)
        worst = max(worst, abs(s))
    return total, worst


@njit(cache=True)
def _motion(dq):
    """``MOTION_WEIGHT sum |dq_i|``."""
    s = 0.0
    for i in range(dq.shape[0]):
        s += MOTION_WEIGHT * abs(dq[i])
    return s


def least_error(
    J: np.ndarray, target: np.ndarray, lower: np.ndarray, upper: np.ndarray,
    G: np.ndarray, g: np.ndarray,
) -> tuple[int, np.ndarray]:  # fmt: skip
    """:func:`least_error_step` on any arrays (as C-contiguous float64): ``(code, dq)``."""

    def arr(a: np.ndarray, ndim: int) -> np.ndarray:
        out = np.ascontiguousarray(a, dtype=np.float64)
        return out.reshape(0, J.shape[1]) if ndim == 2 and out.size == 0 else out

    dq = np.empty(np.shape(J)[1])
    code = least_error_step(arr(J, 2), arr(target, 1), arr(lower, 1), arr(upper, 1), arr(G, 2),
                            arr(g, 1), dq)  # fmt: skip
    return int(code), dq


__all__ = [
    "INFEASIBLE",
    "ITERATION_LIMIT",
    "SINGULAR_BASIS",
    "SOLVED",
    "further_progress",
    "further_stage",
    "largest_share_lp",
    "least_error",
    "least_error_step",
    "least_error_value",
    "priced_least_error_step",
    "progress_in_state",
    "stall_stage",
    "state_rows",
]
