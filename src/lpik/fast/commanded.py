"""The control loop's commanded-motion check (:mod:`lpik.control.commanded`), compiled.

The same functions, compiled as they are: ``plausible_previous`` and ``hold_step``
are the dispatchers the background compile fills numba's disk cache with
(:data:`lpik.control.warmup.STAGES`); :func:`motion_kernels` are the controller's,
typed, so that arguments of other types raise ``TypeError`` instead of compiling
in the middle of a loop. :func:`follow_kernel` keeps the fused step's memory of
the target's motion where a step's ``q_prev`` was corrected.
"""

from __future__ import annotations

from typing import Any

from numba import njit, types

from lpik import bands
from lpik import continuation as rule
from lpik.fast import command_law
from lpik.fast.signatures import typed_kernel
from lpik.fast.twins import rebound

#: :func:`lpik.continuation.plausible_previous` with its velocity check compiled.
_plausible_rule = rebound(
    rule.plausible_previous, plausible_step=njit(cache=True)(bands.plausible_step)
)
plausible_previous = njit(cache=True)(_plausible_rule)
hold_step = njit(cache=True)(rule.hold_step)

_VECTOR, _MATRIX = types.float64[::1], types.float64[:, ::1]
#: The argument types each is called with.
PLAUSIBLE_SIGNATURE = HOLD_SIGNATURE = (_VECTOR, _VECTOR, _MATRIX)
#: ``follow(state, q0, q_prev, taken)``'s (:func:`lpik.fast.command_law.follow`).
FOLLOW_SIGNATURE = (_VECTOR,) * 4


def motion_kernels() -> tuple[Any, Any]:
    """The typed dispatchers of ``plausible_previous`` and ``hold_step``.

    Loaded from the disk cache (:data:`lpik.control.warmup.STAGES` fills it), else compiled.
    """
    return (
        typed_kernel("plausible_previous", _plausible_rule, [PLAUSIBLE_SIGNATURE]),
        typed_kernel("hold_step", rule.hold_step, [HOLD_SIGNATURE]),
    )


def follow_kernel() -> Any:
    """The typed dispatcher of :func:`lpik.fast.command_law.follow`.

    A step whose ``q_prev`` was corrected keeps the fused step's memory of the
    target's motion (:func:`lpik.command.continues_with`). Loaded from the disk cache
    (:data:`lpik.control.warmup.STAGES` fills it), else compiled.
    """
    return typed_kernel("follow_in_state", command_law.follow, [FOLLOW_SIGNATURE])
