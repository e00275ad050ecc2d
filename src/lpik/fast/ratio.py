"""The compiled ratio test's per-entry helpers (:func:`lpik.fast.lp2_kernel.lp2_core`).

Each entry ``a + p b`` of LP2's affine solution limits ``p`` from above or below;
:func:`slacks` is its room to its bounds, :func:`first_within` the entry that
names the limit, with the tie rule of :func:`lpik.methods.lp2.ratio_test`.
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
def first_within(av, bv, lo, hi, total, eps, upper_side, hi_bound, extreme):
    """The first entry whose limit on ``p`` lies within INTERVAL_TOL of ``extreme``.

    ``upper_side``: limits from above on ``p`` (else from below); ``hi_bound``:
    those set by the entries' upper bounds (else their lower ones). No limit at
    all (``extreme`` infinite): entry 0, as the numpy path's ``argmax``.
    """
    if not math.isfinite(extreme):
        return 0
    for k in range(total):
        s_hi, s_lo = slacks(av[k], lo[k], hi[k])
        b = bv[k]
        if upper_side and hi_bound and b > eps and s_hi / b <= extreme + INTERVAL_TOL:
            return k
        if upper_side and not hi_bound and b < -eps and s_lo / -b <= extreme + INTERVAL_TOL:
            return k
        if not upper_side and hi_bound and b < -eps and s_hi / b >= extreme - INTERVAL_TOL:
            return k
        if not upper_side and not hi_bound and b > eps and -s_lo / b >= extreme - INTERVAL_TOL:
            return k
    return 0
