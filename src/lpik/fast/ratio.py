"""The ratio test's per-entry rule and tie rule (:mod:`lpik.methods.ratio`), compiled as they are.

:func:`lpik.fast.lp2_kernel.lp2_core` calls :func:`slacks` for every entry and
:func:`limit_code` where a limit stops ``p``; both are the numpy path's own
functions compiled by :func:`lpik.fast.twins.compiled_twin`.
"""

from __future__ import annotations

from numba import njit

from lpik.fast.twins import compiled_twin
from lpik.methods import ratio

slacks = njit(cache=True)(ratio.slacks)
ties = njit(cache=True)(ratio.ties)
first_within = compiled_twin(ratio.first_within, slacks=slacks, ties=ties)
limit_code = compiled_twin(ratio.limit_code, ties=ties, first_within=first_within)
