"""The compiled ratio test's per-entry helpers (:func:`lpik.fast.lp2_kernel.lp2_core`).

Each entry ``a + p b`` of LP2's affine solution limits ``p`` from above or below;
:func:`slacks` is its room to its bounds, :func:`limit_code` the limit that
stops it, with the tie rule of :func:`lpik.methods.lp2.ratio_test`.
"""

from __future__ import annotations

import math

from numba import njit

from lpik.tolerances import INTERVAL_TOL, SLACK_TOL


@njit(cache=True)
def slacks(a, lo, hi):
    """Room of ``a`` below ``hi`` and above ``lo``; a slack below 0 by rounding counts as 0."""
    s_hi, s_lo = hi - a, a - lo
    if s_hi < 0 and s_hi >= -SLACK_TOL * max(1.0, abs(hi)):
        s_hi = 0.0
    if s_lo < 0 and s_lo >= -SLACK_TOL * max(1.0, abs(lo)):
        s_lo = 0.0
    return s_hi, s_lo


@njit(cache=True)
def limit_code(av, bv, lo, hi, total, eps, upper_side, by_hi, by_lo):
    """The code (``2 k + 1`` upper bound, ``2 k`` lower) of the limit that stops ``p``.

    ``upper_side``: the limits from above on ``p``, whose extremes over the
    entries' upper and lower bounds are ``by_hi`` and ``by_lo`` (else the limits
    from below). Limits within INTERVAL_TOL of each other tie; a tie goes to the
    upper bounds, then to the first entry, as in :func:`lpik.methods.lp2.ratio_test`.
    Called only where a limit is named, so a step that meets its command walks
    the entries once.
    """
    if upper_side:
        hi_bound = by_hi <= by_lo + INTERVAL_TOL
    else:
        hi_bound = by_hi >= by_lo - INTERVAL_TOL
    extreme = by_hi if hi_bound else by_lo
    k = _first_within(av, bv, lo, hi, total, eps, upper_side, hi_bound, extreme)
    return 2 * k + 1 if hi_bound else 2 * k


@njit(cache=True)
def _first_within(av, bv, lo, hi, total, eps, upper_side, hi_bound, extreme):
    """The first entry whose limit on ``p`` lies within INTERVAL_TOL of ``extreme``.

    ``upper_side``: limits from above on ``p`` (else from below); ``hi_bound``:
    those set by the entries' upper bounds (else their lower ones). No limit at
    all (``extreme`` infinite): entry 0, as the numpy path's ``argmax``.
    """
    if not math.isfinite(extreme):
        return 0
    rising = upper_side == hi_bound  # the entries whose rate b > 0 set these limits
    for k in range(total):
        b = bv[k]
        if (rising and b > eps) or (not rising and b < -eps):
            s_hi, s_lo = slacks(av[k], lo[k], hi[k])
            v = s_hi / b if hi_bound else -s_lo / b
            if (upper_side and v <= extreme + INTERVAL_TOL) or (
                not upper_side and v >= extreme - INTERVAL_TOL
            ):
                return k
    return 0
