"""The ratio test's rule for one entry and its tie rule, written once as plain loops.

Each entry ``a + p b`` of LP2's affine solution (eqs. 15-18) limits ``p``
from above or below by its bounds ``lo <= a + p b <= hi``: :func:`slacks` is
its room to its bounds (a slack below 0 by rounding counts as 0), and
:func:`limit_code` names the limit that stops ``p``. Limits within
:data:`~lpik.tolerances.INTERVAL_TOL` of each other in ``p`` tie
(:func:`ties`), and a tie goes to the upper bounds, then to the first entry,
so that the rounding of two paths cannot name two limits. The numpy ratio
test (:func:`lpik.methods.lp2.ratio_test`) and the singular path
(:mod:`lpik.methods.singular`) run these functions as Python; the compiled
kernels compile them as they are (:mod:`lpik.fast.ratio`).
"""

from __future__ import annotations

import math

from lpik.tolerances import INTERVAL_TOL, SLACK_TOL


def slacks(a, lo, hi):  # type: ignore[no-untyped-def]
    """Room of ``a`` below ``hi`` and above ``lo``; a slack below 0 by rounding counts as 0."""
    s_hi, s_lo = hi - a, a - lo
    if s_hi < 0 and s_hi >= -SLACK_TOL * max(1.0, abs(hi)):
        s_hi = 0.0
    if s_lo < 0 and s_lo >= -SLACK_TOL * max(1.0, abs(lo)):
        s_lo = 0.0
    return s_hi, s_lo


def ties(v, extreme, upper_side):  # type: ignore[no-untyped-def]
    """Whether a limit ``v`` on ``p`` ties with the tightest one, ``extreme`` (the tie rule).

    ``upper_side``: limits from above on ``p`` (``extreme`` their smallest), else
    from below (``extreme`` their largest).
    """
    if upper_side:
        return v <= extreme + INTERVAL_TOL
    return v >= extreme - INTERVAL_TOL


def limit_code(av, bv, lo, hi, total, eps, upper_side, by_hi, by_lo):  # type: ignore[no-untyped-def]
    """The code (``2 k + 1`` upper bound, ``2 k`` lower) of the limit that stops ``p``.

    ``upper_side``: the limits from above on ``p``, whose extremes over the
    entries' upper and lower bounds are ``by_hi`` and ``by_lo`` (else the limits
    from below). A tie goes to the upper bounds, then to the first entry.
    Called only where a limit is named, so a step that meets its command walks
    the entries once.
    """
    hi_bound = ties(by_hi, by_lo, upper_side)
    extreme = by_hi if hi_bound else by_lo
    k = first_within(av, bv, lo, hi, total, eps, upper_side, hi_bound, extreme)
    return 2 * k + 1 if hi_bound else 2 * k


def first_within(av, bv, lo, hi, total, eps, upper_side, hi_bound, extreme):  # type: ignore[no-untyped-def]
    """The first entry whose limit on ``p`` ties with ``extreme`` (:func:`ties`).

    ``upper_side``: limits from above on ``p`` (else from below); ``hi_bound``:
    those set by the entries' upper bounds (else their lower ones). No limit at
    all (``extreme`` infinite): entry 0.
    """
    if not math.isfinite(extreme):
        return 0
    rising = upper_side == hi_bound  # the entries whose rate b > 0 set these limits
    for k in range(total):
        b = bv[k]
        if (rising and b > eps) or (not rising and b < -eps):
            s_hi, s_lo = slacks(av[k], lo[k], hi[k])
            v = s_hi / b if hi_bound else -s_lo / b
            if ties(v, extreme, upper_side):
                return k
    return 0
