"""The ratio test's per-entry rule and tie rule (:mod:`lpik.methods.ratio`), compiled as they are.

:func:`lpik.fast.lp2_kernel.lp2_core` calls :func:`slacks` for every entry and
:func:`limit_code` where a limit stops ``p``; both are the numpy path's own
functions compiled by :func:`lpik.fast.twins.compiled_twin`. The ones that
take a side (``upper_side``) are compiled for one signature, when the module
is imported: the kernel passes the side as a constant, which numba would
otherwise type as a literal and compile each function once per side.
"""

from __future__ import annotations

from numba import boolean, float64, int64, njit

from lpik.fast.twins import rebound
from lpik.methods import ratio

_ENTRIES = (float64[:], float64[:], float64[:], float64[:], int64, float64, boolean)

slacks = njit(cache=True)(ratio.slacks)
ties = njit((float64, float64, boolean), cache=True)(ratio.ties)
first_within = njit((*_ENTRIES, boolean, float64), cache=True)(
    rebound(ratio.first_within, slacks=slacks, ties=ties)
)
limit_code = njit((*_ENTRIES, float64, float64), cache=True)(
    rebound(ratio.limit_code, ties=ties, first_within=first_within)
)
