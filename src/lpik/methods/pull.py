"""How much of sec. 3.1's pull towards ``q_ref`` a step may take: one rule for every path.

The pull ``Lambda (q_ref - q0)`` adds ``s e`` to LP2's step at ``p = 0`` (and to its
multipliers). :func:`pull_room` gives the largest ``s`` that leaves the command
its share of every band; it is written as plain loops so that the numpy path
(:func:`lpik.methods.kkt.smoothing_scale`), LP2's singular path
(:func:`lpik.methods.singular.singular_core`) and the compiled kernel
(:func:`lpik.fast.smoothing.add_smoothing`) run the same code.
"""

from __future__ import annotations

from lpik.tolerances import PULL_TOL, SLACK_TOL, SMOOTHING_SHARE


def pull_room(a, e, lower, upper, scale):  # type: ignore[no-untyped-def]
    """The largest ``s`` in [0, ``scale``] with which ``a + s e`` keeps to its bands' share.

    On each entry ``s e`` may take at most :data:`~lpik.tolerances.SMOOTHING_SHARE`
    of the room between ``a`` and its bounds ``lower``, ``upper`` (and any amount
    towards them when ``a`` is outside). A share at or below
    :data:`~lpik.tolerances.PULL_TOL` (relative to the largest, at least 1) may be
    the rounding of a zero and takes no share of the room; it may still not carry
    an entry that is within its bounds past them by more than the ratio test's
    :data:`~lpik.tolerances.SLACK_TOL`, which would leave no feasible ``p``.
    Infinite bounds leave room for any pull. Called once for the joints and once
    for the multipliers, each with its own largest share.
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
