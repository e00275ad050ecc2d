"""LP2 with saturation in the null space, compiled: :func:`lpik.methods.lp2s.lp2s` as a loop.

Each pass is :func:`lpik.fast.lp2_kernel.lp2_core`; the joint whose bound stops
the pass is fixed there by setting its lower and upper bound to that bound
(the kernel pins every joint whose bounds coincide), and the next pass resolves
the criterion over the joints still free. The passes, their stopping rules and
their tie-breaking are those of the numpy method, which the tests hold equal.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from lpik.fast.lp2_kernel import (
    CHECK_FAILED,
    INFEASIBLE,
    OK,
    SINGULAR_PATH_AFTER_CHECK,
    SINGULAR_PATH_ALWAYS,
    _workspace_size,
    lp2_core,
    pull_scale_of,
)
from lpik.fast.workspace import PULL_SCALE, vector
from lpik.tolerances import (
    FULL_P,
    INTERVAL_TOL,
    MAX_SCHUR_CONDITION,
    SATURATION_MAX_CONDITION,
    SATURATION_MAX_PRICE,
)


@njit(cache=True)
def _keep(best, dq, lam):
    """``best = (dq, lam)``, element by element.

    A loop, not ``best[:n] = dq``: numba's array assignment compiles its
    shape-mismatch message, string formatting and all (seconds of compile time).
    """
    n = dq.shape[0]
    for i in range(n):
        best[i] = dq[i]
    for k in range(lam.shape[0]):
        best[n + k] = lam[k]


@njit(cache=True)
def _restore(dq, lam, best):
    """``(dq, lam) = best``, element by element (see :func:`_keep`)."""
    n = dq.shape[0]
    for i in range(n):
        dq[i] = best[i]
    for k in range(lam.shape[0]):
        lam[k] = best[n + k]


@njit(cache=True)
def _worth_it(best, dq, p_before, p_after):
    """:func:`lpik.methods.lp2s.worth_it`: whether the pass ``dq`` at ``p_after`` pays.

    Against the step kept in ``best[:n]`` at ``p_before``; plain loops.
    """
    if p_before <= 0.0:
        return True
    added = 0.0
    before = 0.0
    for i in range(dq.shape[0]):
        added += (dq[i] - best[i]) ** 2
        before += best[i] ** 2
    gain = max(p_after - p_before, INTERVAL_TOL)  # a tie goes on
    return math.sqrt(added) <= SATURATION_MAX_PRICE * gain * math.sqrt(before) / p_before


@njit(cache=True)
def _names_free_joint(binding, lower, upper):
    """Whether ``binding`` is a bound of a joint not yet held (``lower != upper``).

    A held joint (saturated, or pinned by its bounds) that stops a pass along a
    direction the free joints have lost (:func:`lpik.methods.singular._pinned_code`)
    ends the passes: saturating another joint does not give that direction back.
    """
    n = lower.shape[0]
    return 0 <= binding < 2 * n and lower[binding // 2] != upper[binding // 2]


@njit(cache=True)
def lp2s_core(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam, ws, best):
    """LP2 with saturation (eqs. 15-18 over the free joints); writes ``dq`` and ``lam``.

    Arguments as :func:`~lpik.fast.lp2_kernel.lp2_core`, plus ``best``, a float
    scratch of length ``n + m``. ``lower`` and ``upper`` are changed in place
    (saturated joints end with coinciding bounds).

    Returns:
        ``(code, p, binding, residual)`` of the pass with the largest ``p``, whose
        share of sec. 3.1's pull is left in ``ws`` (``pull_scale_of``). An
        infeasible first pass whose conflict is a joint's bound saturates that
        joint as a stopping bound would (the first feasible pass goes on as
        usual; none feasible: the first pass's safe step and conflict). Any
        other first pass other than OK is returned as it is (``SINGULAR`` and
        ``CHECK_FAILED`` send the caller to the numpy method); later passes
        skip the singular path, as :func:`lpik.methods.lp2s.saturation_passes`
        does: a later singular pass ends the passes (no well-conditioned
        redundancy left), a later ``CHECK_FAILED`` hands the step to the numpy method.
    """
    m, n = J.shape
    pull = vector(ws, PULL_SCALE, n, m, G.shape[0])  # each pass's share of sec. 3.1's pull
    code, p, binding, residual = lp2_core(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min,
                                          lam_max, G, g, dq, lam, ws, SINGULAR_PATH_ALWAYS,
                                          MAX_SCHUR_CONDITION)  # fmt: skip
    # an infeasible first pass saturates the joint its conflict names, as the numpy method
    stuck = code == INFEASIBLE and _names_free_joint(binding, lower, upper)
    if code != OK and not stuck:
        return code, p, binding, residual
    first_binding = binding
    best_pull = pull[0]
    if stuck:
        _keep(best, dq, lam)
    free = 0
    for i in range(n):
        if lower[i] != upper[i]:
            free += 1
    while p < FULL_P and _names_free_joint(binding, lower, upper) and free - 1 >= m:
        if code == OK:  # the best pass so far (while stuck: the first pass's safe step)
            _keep(best, dq, lam)
            best_pull = pull[0]
        joint = binding // 2
        if binding % 2 == 1:
            lower[joint] = upper[joint]
        else:
            upper[joint] = lower[joint]
        free -= 1
        code2, p2, binding2, residual2 = lp2_core(J, dw, H, h_diag, c, c_ref, lower, upper,
                                                  lam_min, lam_max, G, g, dq, lam, ws,
                                                  SINGULAR_PATH_AFTER_CHECK,
                                                  SATURATION_MAX_CONDITION)  # fmt: skip
        if code2 == CHECK_FAILED:  # the numpy method decides
            return code2, p2, binding2, residual2
        if code2 == INFEASIBLE and stuck:  # saturate the next conflict
            binding = binding2
            continue
        # keep the best pass (SINGULAR: no redundancy); a pass within INTERVAL_TOL ties
        if code2 != OK or (not stuck and p2 < p - INTERVAL_TOL):
            _restore(dq, lam, best)
            pull[0] = best_pull
            break
        if not stuck and not _worth_it(best, dq, p, p2):  # the pass does not pay
            _restore(dq, lam, best)
            pull[0] = best_pull
            break
        code, p, binding, residual, stuck = code2, p2, binding2, residual2, False
    if stuck:  # no pass feasible: the first pass's safe step and conflict
        _restore(dq, lam, best)
        return INFEASIBLE, 0.0, first_binding, residual
    return code, p, binding, residual


@njit(cache=True)
def lp2s_kernel(J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam):
    """:func:`lp2s_core` with its own workspace, on copies of the bounds.

    Returns ``(code, p, binding, residual, pull_scale)``, as
    :func:`lpik.fast.lp2_kernel.lp2_kernel`.
    """
    m, n = J.shape
    ws = np.empty(_workspace_size(n, m, G.shape[0]))
    code, p, binding, res = lp2s_core(J, dw, H, h_diag, c, c_ref, lower.copy(), upper.copy(),
                                      lam_min, lam_max, G, g, dq, lam, ws,
                                      np.empty(n + m))  # fmt: skip
    return code, p, binding, res, pull_scale_of(ws, n, m, G.shape[0])


@njit(cache=True, parallel=True)
def lp2s_batch_kernel(
    J, dw, H, h_diag, c, c_ref, lower, upper, lam_min, lam_max, G, g, dq, lam, codes, ps, bindings,
    scales, chunks,
):  # fmt: skip
    """:func:`lp2s_core` over a batch (leading axis ``B`` on every argument), in parallel.

    As :func:`lpik.fast.lp2_kernel.lp2_batch_kernel`: the batch is cut into
    ``chunks`` parts, each with its own workspace; every item works on copies
    of its bounds.
    """
    B, m, n = J.shape
    chunks = max(1, min(B, chunks))
    for chunk in prange(chunks):
        ws = np.empty(_workspace_size(n, m, G.shape[1]))
        best = np.empty(n + m)
        for b in range(chunk * B // chunks, (chunk + 1) * B // chunks):
            code, p, binding, _ = lp2s_core(
                J[b], dw[b], H[b], h_diag, c[b], c_ref[b], lower[b].copy(), upper[b].copy(),
                lam_min[b], lam_max[b], G[b], g[b], dq[b], lam[b], ws, best,
            )  # fmt: skip
            codes[b] = code
            ps[b] = p
            bindings[b] = binding
            scales[b] = pull_scale_of(ws, n, m, G.shape[1])
