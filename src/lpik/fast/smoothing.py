"""Sec. 3.1's pull towards ``q_ref`` in the compiled LP2 kernel: resolved, whole where it fits.

The loop twin of :func:`lpik.methods.kkt.smoothing_scale` and the pull's share
of :func:`lpik.methods.kkt.affine_solution`, for :func:`lpik.fast.lp2_kernel.lp2_core`.
"""

from __future__ import annotations

from numba import float64, njit

from lpik.fast.linalg import cho_solve, refine, solve_free
from lpik.fast.twins import rebound
from lpik.methods.pull import pull_fits, pull_room, pull_scale

#: :func:`lpik.methods.pull.pull_room`, compiled for one signature (any 1-D float
#: arrays) when the module is imported: its callers pass views and C-ordered arrays.
_ANY = float64[:]
compiled_pull_room = njit((_ANY, _ANY, _ANY, _ANY, float64), cache=True)(pull_room)
compiled_pull_fits = njit((_ANY, _ANY, _ANY, _ANY), cache=True)(pull_fits)
#: :func:`lpik.methods.pull.pull_scale`, the one rule, compiled as it is (one signature).
compiled_pull_scale = njit((_ANY,) * 8, cache=True)(
    rebound(pull_scale, pull_room=compiled_pull_room, pull_fits=compiled_pull_fits)
)


@njit(cache=True)
def add_smoothing(J, H, h_diag, LH, LS, HinvJt, c_ref, lower, upper, lam_min, lam_max, a_q, a_l,
                  n_scratch, m_scratch):  # fmt: skip
    """Add ``s`` times the pull's share of eq. 18's solution to ``a_q`` and ``a_l``; return ``s``.

    ``s`` is :func:`lpik.methods.pull.pull_scale`'s: 1 where the whole pull fits.

    Called when ``c_ref = Lambda (q_ref - q0)`` pulls a free joint; pinned joints
    (``lower == upper``) take no pull. ``LH`` (unless ``h_diag``) and ``LS`` are
    the Cholesky factors of ``H'`` and ``S`` the kernel computed; ``n_scratch``
    and ``m_scratch`` hold four work vectors each. The share is refined
    (:func:`refine`) before it is scaled, as the numpy path refines it.
    """
    m, n = J.shape
    col, Hinvr, e_q, t_q = n_scratch
    rhs3, e_l, r_l, d_l = m_scratch
    for i in range(n):
        col[i] = 0.0 if lower[i] == upper[i] else c_ref[i]
    solve_free(H, h_diag, LH, lower, upper, col, Hinvr)
    for a in range(m):
        s = 0.0
        for i in range(n):
            s += J[a, i] * Hinvr[i]
        rhs3[a] = s
    cho_solve(LS, rhs3, e_l)
    for i in range(n):
        s = Hinvr[i]
        for k in range(m):
            s -= HinvJt[i, k] * e_l[k]
        e_q[i] = s
    refine(J, H, h_diag, c_ref, lower, upper, LH, LS, HinvJt, e_q, e_l, col, t_q, r_l, d_l)
    # the numpy path's rule (lpik.methods.kkt.smoothing_scale)
    scale = compiled_pull_scale(a_q, e_q, lower, upper, a_l, e_l, lam_min, lam_max)
    for i in range(n):
        a_q[i] += scale * e_q[i]
    for k in range(m):
        a_l[k] += scale * e_l[k]
    return scale
