"""How much of sec. 3.1's pull towards ``q_ref`` a step takes: one rule for every path.

The pull ``Lambda (q_ref - q0)`` adds ``s e`` to LP2's step at ``p = 0`` (and to its
multipliers). :func:`pull_scale` is the rule: the whole pull (``s = 1``, sec. 3.1's
LP2 as the paper writes it) wherever it keeps the step at ``p = 0`` within every
bound (:func:`pull_fits`); only where it does not, the largest ``s`` that leaves
the command its share of every band (:func:`pull_room`). They are written as
plain loops so that the numpy path (:func:`lpik.methods.kkt.smoothing_scale`),
LP2's singular path (:func:`lpik.methods.singular.singular_core`) and the
compiled kernel (:func:`lpik.fast.smoothing.add_smoothing`) run the same code.
"""

from __future__ import annotations

from lpik.tolerances import PULL_TOL, SLACK_TOL, SMOOTHING_SHARE


def pull_scale(a_q, e_q, lower, upper, a_l, e_l, lam_min, lam_max):  # type: ignore[no-untyped-def]
    """The share ``s`` of sec. 3.1's pull the step takes: 1 where it fits, else its room.

    ``a_q + s e_q`` is the step at ``p = 0`` (bounds ``lower``, ``upper``) and
    ``a_l + s e_l`` its multipliers (bounds ``lam_min``, ``lam_max``, sec. 3.2).
    Where the whole pull keeps every joint and multiplier within its bounds
    (:func:`pull_fits`), ``s = 1`` exactly: the step is the paper's LP2 with
    sec. 3.1's term. Only where it would carry the step at ``p = 0`` past a
    bound is it scaled to its share of the room (:func:`pull_room`): joints
    first, then multipliers. ``s`` jumps from 1 to that share where the whole
    pull stops fitting.
    """
    if pull_fits(a_q, e_q, lower, upper) and pull_fits(a_l, e_l, lam_min, lam_max):
        return 1.0
    return pull_room(a_l, e_l, lam_min, lam_max, pull_room(a_q, e_q, lower, upper, 1.0))


def pull_fits(a, e, lower, upper):  # type: ignore[no-untyped-def]
    """Whether ``a + e`` lies within ``[lower, upper]`` on every entry.

    With the ratio test's tolerance: an entry past a bound by at most
    :data:`~lpik.tolerances.SLACK_TOL` (relative to the bound, at least 1) is on it.
    """
    for i in range(len(e)):
        v = a[i] + e[i]
        if v > upper[i] + SLACK_TOL * max(1.0, abs(upper[i])):
            return False
        if v < lower[i] - SLACK_TOL * max(1.0, abs(lower[i])):
            return False
    return True


def pull_room(a, e, lower, upper, scale):  # type: ignore[no-untyped-def]
    """The largest ``s`` in [0, ``scale``] with which ``a + s e`` keeps to its bands' share.

    On each entry ``s e`` may take at most :data:`~lpik.tolerances.SMOOTHING_SHARE`
    of the room between ``a`` and its bounds ``lower``, ``upper`` (and any amount
    towards them when ``a`` is outside). A share at or below
    :data:`~lpik.tolerances.PULL_TOL` (relative to the largest, at least 1) may be
    the rounding of a zero and takes no share of the room; it may still not carry
    an entry that is within its bounds past them by more than the ratio test's
    :data:`~lpik.tolerances.SLACK_TOL`, which would leave no feasible ``p``.
    Infinite bounds leave room for any pull. :func:`pull_scale` calls it once for
    the joints and once for the multipliers, each with its own largest share.
    """
    emax = 0.0
    for i in range(len(e)):
        emax = max(emax, abs(e[i]))
    eps = PULL_TOL * max(1.0, emax)
    for i in range(len(e)):
        if e[i] > eps:
            scale = min(scale, max(0.0, SMOOTHING_SHARE * (upper[i] - a[i])) / e[i])
        elif e[i] < -eps:
            scale = min(scale, min(0.0, SMOOTHING_SHARE * (lower[i] - a[i])) / e[i])
        elif e[i] > 0.0 and lower[i] <= a[i] <= upper[i]:
            if a[i] + e[i] > upper[i] + SLACK_TOL * max(1.0, abs(upper[i])):
                scale = min(scale, (upper[i] - a[i]) / e[i])
        elif e[i] < 0.0 and lower[i] <= a[i] <= upper[i]:
            if a[i] + e[i] < lower[i] - SLACK_TOL * max(1.0, abs(lower[i])):
                scale = min(scale, (lower[i] - a[i]) / e[i])
    return max(0.0, scale)
