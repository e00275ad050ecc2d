"""A small singular value decomposition in plain loops (one-sided Jacobi), for the kernels.

LP2's singular path (:mod:`lpik.methods.singular`) and the automatic bound
(:mod:`lpik.fast.autobound`, which needs the singular values alone:
:func:`singular_values`) decompose a task Jacobian of at most a few rows.
numba's ``np.linalg.svd`` calls LAPACK, which is fast when warm but several
times slower right after Python's garbage collector has run (cold caches):
the tail of the fused step's time at a singular configuration
(docs/benchmarks.md). One-sided Jacobi (Hestenes;
Demmel and Veselic, "Jacobi's method is more accurate than QR", SIAM J. Matrix
Anal. Appl. 13(4), 1992) rotates the rows of ``A`` (the columns of ``A^T``)
until they are orthogonal: ``V^T A = W^T``, so ``A = V diag(|w_j|) (W / |w_j|)^T``.
It is as accurate (relative accuracy of the small singular values, the ones
that matter here), allocates only its outputs, and is a few dozen lines. It
works on rows, which lie contiguous in a C-ordered ``A``: the same arithmetic
as on the columns of ``A^T``, 13 % faster on the Panda's 6 x 7 Jacobian.
"""

from __future__ import annotations

import math

import numpy as np
from numba import float64, njit

#: Rotations stop when every pair of rows is orthogonal to this (relative) cosine.
JACOBI_TOL = 1e-15
#: A row whose norm is at most this share of ``A``'s Frobenius norm is rounding: it is
#: not rotated. A rank-deficient ``A`` leaves such rows (the Jacobian over the free joints
#: where several are pinned), and their noise is never orthogonal: rotated, it ran the
#: sweeps to :data:`MAX_SWEEPS` (60 instead of 6-8; 40 us of LP2's singular path on the
#: UR5e) while the rows shrank to 1e-155.
NEGLIGIBLE_ROW_RTOL = 1e-15
#: At most this many sweeps over all pairs (a handful suffice: convergence is quadratic).
MAX_SWEEPS = 60


@njit(cache=True)
def orthogonalize(B, V):
    """Rotate the rows of ``B`` (m, n) until they are orthogonal; ``V`` (m, m) with them.

    ``V_0^T B = W^T`` with ``V_0`` the product of the rotations, accumulated into
    ``V`` (start from the identity); a ``V`` with no rows accumulates nothing
    (the singular values alone, :func:`singular_values`). A pair with a row at
    rounding level (:data:`NEGLIGIBLE_ROW_RTOL`) counts as orthogonal. Returns the
    number of sweeps, the last one without a rotation (:data:`MAX_SWEEPS` at most).
    """
    m, n = B.shape
    total = 0.0
    for p in range(m):
        for i in range(n):
            total += B[p, i] * B[p, i]
    negligible = NEGLIGIBLE_ROW_RTOL * NEGLIGIBLE_ROW_RTOL * total
    for sweep in range(MAX_SWEEPS):
        rotated = False
        for p in range(m - 1):
            for q in range(p + 1, m):
                alpha, beta, gamma = 0.0, 0.0, 0.0
                for i in range(n):
                    alpha += B[p, i] * B[p, i]
                    beta += B[q, i] * B[q, i]
                    gamma += B[p, i] * B[q, i]
                if gamma == 0.0 or abs(gamma) <= JACOBI_TOL * math.sqrt(alpha * beta):
                    continue
                if min(alpha, beta) <= negligible:
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                c = 1.0 / math.sqrt(1.0 + t * t)
                s = c * t
                for i in range(n):
                    bp, bq = B[p, i], B[q, i]
                    B[p, i], B[q, i] = c * bp - s * bq, s * bp + c * bq
                for i in range(V.shape[0]):
                    vp, vq = V[i, p], V[i, q]
                    V[i, p], V[i, q] = c * vp - s * vq, s * vp + c * vq
        if not rotated:
            return sweep + 1
    return MAX_SWEEPS


@njit(cache=True)
def _row_norms(B):
    """The 2-norm of each row of ``B``: the singular values once the rows are orthogonal."""
    m, n = B.shape
    norms = np.empty(m)
    for j in range(m):
        total = 0.0
        for i in range(n):
            total += B[j, i] * B[j, i]
        norms[j] = math.sqrt(total)
    return norms


@njit((float64[:, :],), cache=True)  # one signature: views and C-ordered arrays alike
def singular_values(A):
    """``A``'s singular values (``min(m, n)``, largest first), those of :func:`jacobi_svd`."""
    m, n = A.shape
    B = A.copy()
    orthogonalize(B, np.empty((0, m)))
    norms = _row_norms(B)
    order = np.argsort(-norms)
    sv = np.empty(min(m, n))
    for jj in range(sv.size):
        sv[jj] = norms[order[jj]]
    return sv


@njit(cache=True)
def jacobi_svd(A):
    """``(U, s, Vt)`` of ``A`` (m, n) as ``np.linalg.svd(A)`` gives them (full ``U``).

    ``s`` (``min(m, n)``) is sorted largest first; ``U`` is (m, m) and
    orthogonal; ``Vt`` is (n, n) with its first ``min(m, n)`` rows the right
    singular vectors (rows for zero singular values are zero, and so are the
    rest: the callers read only the rows of nonzero singular values).
    """
    m, n = A.shape
    B = A.copy()  # (m, n): its rows are rotated
    V = np.eye(m)
    orthogonalize(B, V)
    norms = _row_norms(B)
    order = np.argsort(-norms)
    k = min(m, n)
    U, sv, Vt = np.empty((m, m)), np.empty(k), np.zeros((n, n))
    for jj in range(m):
        j = order[jj]
        for i in range(m):
            U[i, jj] = V[i, j]
        if jj < k:
            sv[jj] = norms[j]
            if norms[j] > 0.0:
                for i in range(n):
                    Vt[jj, i] = B[j, i] / norms[j]
    return U, sv, Vt
