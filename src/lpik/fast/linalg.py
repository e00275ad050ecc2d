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
