"""Small dense linear algebra in plain loops, which the compiled kernels compile as it is.

The decomposition of LP2's singular path (:mod:`lpik.methods.singular`) and of the
potential field's null-space motion
(:func:`lpik.collision.avoidance.null_space_motion`): with ``H = L L^T``
(Cholesky), the triangular solves with ``L`` and the rule that decides which
singular values of ``J L^-T`` count as nonzero. Plain loops over small arrays,
so that numpy calls them as they are and :mod:`lpik.fast` compiles them
(:data:`lpik.fast.lp2_kernel.singular_helpers`); the hand-written Cholesky of the
kernels' own solves is :mod:`lpik.fast.linalg`.
"""

from __future__ import annotations

import numpy as np

from lpik.tolerances import SINGULAR_FLOOR, SINGULAR_RTOL


def regular_count(sv):  # type: ignore[no-untyped-def]
    """How many singular values ``sv`` (largest first) count as nonzero.

    Those above :data:`~lpik.tolerances.SINGULAR_RTOL` of the largest and above
    :data:`~lpik.tolerances.SINGULAR_FLOOR`; what is below is rounding.
    """
    smax = sv[0] if sv.shape[0] > 0 else 0.0
    regular = 0
    for i in range(sv.shape[0]):
        if sv[i] > SINGULAR_RTOL * smax and sv[i] > SINGULAR_FLOOR:
            regular += 1
    return regular


def forward_substitution(L, B):  # type: ignore[no-untyped-def]
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


def back_substitution(L, y, out):  # type: ignore[no-untyped-def]
    """``L^-T y`` into ``out`` for lower-triangular ``L``."""
    n = y.shape[0]
    for i in range(n - 1, -1, -1):
        s = y[i]
        for j in range(i + 1, n):
            s -= L[j, i] * out[j]
        out[i] = s / L[i, i]
