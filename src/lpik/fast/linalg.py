"""Small dense linear algebra for the compiled kernels: Cholesky factor and solves."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def cholesky(A, L):
    """Lower Cholesky factor of the SPD matrix ``A`` into ``L``; False if not SPD."""
    n = A.shape[0]
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(cache=True)
def cho_solve(L, b, x):
    """Solve ``L L^T x = b`` (vectors)."""
    n = L.shape[0]
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(cache=True)
def cho_solve2(L, b, c, x, y):
    """Solve ``L L^T x = b`` and ``L L^T y = c`` in one sweep (two independent chains)."""
    n = L.shape[0]
    for i in range(n):
        s, t = b[i], c[i]
        for k in range(i):
            s -= L[i, k] * x[k]
            t -= L[i, k] * y[k]
        d = L[i, i]
        x[i], y[i] = s / d, t / d
    for i in range(n - 1, -1, -1):
        s, t = x[i], y[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
            t -= L[k, i] * y[k]
        d = L[i, i]
        x[i], y[i] = s / d, t / d


@njit(cache=True)
def solve_free(H, h_diag, LH, lower, upper, b, x):
    """``x = H'^-1 b`` over the free joints, 0 on the pinned ones (``lower == upper``).

    ``b`` must be 0 on the pinned joints. ``H`` diagonal (``h_diag``): one
    division per joint; else through ``LH``, the Cholesky factor of ``H'``
    (the identity on the pinned joints: :func:`lpik.methods.kkt.pinned_system`).
    """
    if h_diag:
        for i in range(b.shape[0]):
            x[i] = b[i] / H[i, i] if lower[i] != upper[i] else 0.0
    else:
        cho_solve(LH, b, x)


@njit(cache=True)
def refine(J, H, h_diag, c, lower, upper, LH, LS, HinvJt, a_q, a_l, r_q, t_q, r_l, d_l):
    """One pass of iterative refinement of a solution ``(a_q, a_l)`` of LP2's rows, in place.

    :func:`lpik.methods.kkt.affine_solution`'s pass, in loops, for the step at
    ``p = 0`` (``c`` = ``f``) and the smoothing pull's share (``c`` = ``c_ref``):
    the residual of ``H dq + J^T lam = c`` on the free joints (a pinned joint's
    row holds exactly) and of ``J dq = 0`` (the pinned joints' share included),
    solved with the factors ``LH`` of ``H'`` (unless ``h_diag``) and ``LS`` of
    ``S``, and ``HinvJt``. ``r_q``, ``t_q`` (n) and ``r_l``, ``d_l`` (m) are scratch.
    """
    m, n = J.shape
    for i in range(n):
        if lower[i] == upper[i]:
            r_q[i] = 0.0
            continue
        s = c[i]
        for j in range(n):
            s -= H[i, j] * a_q[j]
        for k in range(m):
            s -= J[k, i] * a_l[k]
        r_q[i] = s
    solve_free(H, h_diag, LH, lower, upper, r_q, t_q)
    for k in range(m):
        s = 0.0
        for i in range(n):
            s += J[k, i] * (a_q[i] + t_q[i])
        r_l[k] = s
    cho_solve(LS, r_l, d_l)
    for k in range(m):
        a_l[k] += d_l[k]
    for i in range(n):
        s = t_q[i]
        for k in range(m):
            s -= HinvJt[i, k] * d_l[k]
        a_q[i] += s
