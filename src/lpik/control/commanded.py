"""A control loop's last commanded step, against which the next state's motion is checked.

Under acceleration limits a step continues the motion its state implies,
``last = q0 - q_prev`` (:mod:`lpik.continuation`, :mod:`lpik.bands`): each joint's
step may differ from it by one period of its acceleration limit,
``qdd dt^2``. A loop that feeds back measured joint coordinates hands the step
their noise divided by the period: encoder noise of 1e-4 rad at 1 kHz is a
velocity noise of 0.1 rad/s, ten times what a limit of 10 rad/s^2 lets one step
change. Continued as if it were motion, that noise is integrated: each step's
command carries the last reading's noise on into the next velocity, and the
velocity random-walks (the Panda, 5 cm along x, ``qdd_max=10``, noise of 1e-4
rad per joint and reading: the tool ended 196 mm from the goal, and was 284 mm
away at worst).

The drives cannot change a joint's velocity by more than its acceleration
limit in one period, so a state whose implied step differs from the step the
loop commanded from ``q_prev`` by more is not one the drives made: the
difference is noise (or a push). :class:`CommandedMotion` remembers the last
step it answered, ``q0`` and the commanded ``q - q0``; where the next call
continues that loop (its ``q_prev`` is that ``q0``), the implied step is taken
as near it as the state allows: within one period of the acceleration limits
of the commanded step (:func:`plausible_previous`). A loop fed with its own
commands (``q0`` the last answer, ``q_prev`` the one before) implies the
commanded step exactly, and nothing changes for it. A loop that passes a
``q_prev`` that is not the last ``q0`` (one that builds it from a velocity
reading, ``q0 - qd dt``) is checked too where ``q0`` is where the last step sent
the arm: a joint whose reading differs from the commanded step by more than the
band is taken at the motion since the last ``q0``, which the positions show.
Continued as it came, one reading 0.5 rad/s off changed the joint's real speed
by 49 times its acceleration limit in one period; one beyond the velocity
limit, taken at rest (:mod:`lpik.bands`), by 15 to 99 times. A reading beyond
the velocity limit is a fault, and the step is reported ``recovering``, naming
that limit (:meth:`CommandedMotion.reported`), as is a fault that the check of a
loop on its readings replaces. A state that reads as at rest is taken as it
comes (a loop resumed after a pause), as is a loop that starts anew or jumps.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from lpik import labels
from lpik.continuation import (
    BAND_LOWER,
    BAND_UPPER,
    FAULT,
    HELD_FROM,
    HELD_STEP,
    MEMORY_ROWS,
    PLAUSIBLE,
    SPEED_LOWER,
    SPEED_UPPER,
    hold_step,
    plausible_previous,
)
from lpik.labels import SIDES, Binding
from lpik.result import INFEASIBLE, OFF_DIRECTION, OPTIMAL, RECOVERING, SCALED, Result
from lpik.types import FloatArray, real_array

#: What the check raises for arguments that are not float64 (n,) arrays: the compiled
#: twin a ``TypeError``, the plain function on lists or other shapes the others.
NOT_VECTORS = (TypeError, AttributeError, ValueError, IndexError)
#: The first steps of a loop whose feeding is watched (:meth:`CommandedMotion.watch_feed`),
#: and how many of them in a row must feed the last answer back as the configuration one
#: period before ``q0`` for the warning.
FEED_WATCH, MISFED_STEPS = 8, 3
#: How near the last answer a configuration is taken to be it [rad]: the rounding of
#: ``q0 + (q - q0)``.
ANSWER_TOL = 1e-12
#: The statuses that a step from a state with a replaced velocity fault reports as
#: ``recovering`` (:meth:`CommandedMotion.reported`).
REPORTED_AS_FAULT = frozenset({OPTIMAL, SCALED, OFF_DIRECTION, INFEASIBLE})
#: The warning of a loop that feeds the last answer back as ``q_prev`` (or none).
MISFED = (
    "q_prev is the last step's answer (or missing, with q0 that answer) while the arm moved "
    "on the last step: under acceleration limits each step then starts from rest, and the "
    "tool crawls. Pass the configuration one period before q0: in a loop fed its commands "
    "the last q0 (q_prev, q = q, result.q), in a loop on measured joints the reading before"
)


class CommandedMotion:
    """The last step a controller answered, and the states it took at their plausible motion.

    Args:
        rates: :func:`lpik.control.inputs.rate_limits`' (4, n): the joints' velocity
            limits [rad/s] and acceleration limits [rad/s^2].
        dt: The control period [s].
        joint_names: The names of the joints, for the label of a fault (default
            ``"joint 1"`` ...).
    """

    def __init__(
        self, rates: FloatArray, dt: float, joint_names: Sequence[str] | None = None
    ) -> None:
        n = rates.shape[1]
        #: The rows of :mod:`lpik.continuation`'s loop memory (``HELD_FROM`` ... ``FAULT``).
        self.memory = np.zeros((MEMORY_ROWS, n))
        self.memory[HELD_FROM] = np.nan  # no step answered yet: no q_prev matches
        self.memory[SPEED_LOWER] = rates[0] * dt
        self.memory[SPEED_UPPER] = rates[1] * dt
        self.memory[BAND_LOWER] = rates[2] * dt * dt
        self.memory[BAND_UPPER] = rates[3] * dt * dt
        self.joint_names = tuple(joint_names or labels.default_joint_names(n))
        #: States whose implied step was taken at the plausible one (noise of a measured loop).
        self.corrected = 0
        #: Of those, the states whose implied step was faster than a velocity limit.
        self.faults = 0
        #: The velocity limit the last state's implied step was beyond, where the plausible
        #: step replaced it (the step is reported ``recovering``, naming it), else None.
        self.fault: Binding | None = None
        #: :func:`plausible_previous` and :func:`hold_step` (compiled in a compiled
        #: controller), for callers that run them on ``memory`` themselves.
        self.check: Callable[..., bool] = plausible_previous
        self.keep: Callable[..., None] = hold_step
        #: Whether the next steps' feeding is watched (:meth:`watch_feed`).
        self.watching = True
        self._watched = self._misfed = 0

    @property
    def held_from(self) -> FloatArray:
        """The ``q0`` of the last step answered (NaN: none)."""
        return self.memory[HELD_FROM]

    @classmethod
    def for_rates(
        cls, rates: FloatArray, dt: float, joint_names: Sequence[str] | None = None
    ) -> CommandedMotion | None:
        """As the constructor; None where there is no acceleration limit (nothing to check)."""
        if not np.isfinite(rates[2:]).any():
            return None
        return cls(rates, dt, joint_names)

    def compiled(self, plausible: Callable[..., bool], hold: Callable[..., None]) -> None:
        """Use the compiled twins of :func:`plausible_previous` and :func:`hold_step`."""
        self.check, self.keep = plausible, hold

    def admit(self, q0: Any, q_prev: Any) -> Any:
        """``q_prev``, or the plausible one (:func:`plausible_previous`) where it differs.

        The ``q_prev`` a step of the loop takes (``None`` stays ``None``), after the
        loop's first steps are watched (:meth:`watch_feed`). A result that ``is not
        q_prev`` was corrected: the step still follows the last one
        (:func:`lpik.command.continues_with`), which the caller's memory of the
        target's motion is told. Arguments that are not (n,) coordinates are handed
        on as they are: the step names what is wrong with them.
        """
        if self.watching:
            self.watch_feed(q0, q_prev)
        self.fault = None
        if q_prev is None:
            return None
        try:
            clipped = self.check(q0, q_prev, self.memory)
        except NOT_VECTORS:  # lists, other dtypes
            vectors = self._vectors(q0, q_prev)
            if vectors is None:
                return q_prev
            clipped = self.check(*vectors, self.memory)
        return self.taken() if clipped else q_prev

    def taken(self) -> FloatArray:
        """The plausible ``q_prev`` that :func:`plausible_previous` has just found, counted.

        Where it replaced a step faster than a velocity limit, :attr:`fault` names the
        first such limit.
        """
        self.corrected += 1
        beyond = np.flatnonzero(self.memory[FAULT])
        if beyond.size:
            i = int(beyond[0])
            side = SIDES[1] if self.memory[FAULT, i] > 0 else SIDES[0]
            velocity = labels.BOUND_KINDS[1]
            self.fault = labels.bound_label(self.joint_names[i], side, velocity, i).outside()
            self.faults += 1
        return self.memory[PLAUSIBLE].copy()

    def reported(self, result: Result) -> Result:
        """``result``, reported ``recovering`` and naming :attr:`fault` where there was one.

        A state that implied a speed above a velocity limit was outside its limits, as
        :func:`lpik.bands.rate_band` reports it where no memory replaces the speed: a
        step within the limits (or the safe step) from it is ``recovering``; one already
        ``recovering`` keeps the limit it names, and the others (a failed check, a
        classical method's step that breaks a limit) keep theirs.
        """
        if self.fault is None or result.status not in REPORTED_AS_FAULT:
            return result
        return replace(result, status=RECOVERING, binding=self.fault)

    def _vectors(self, *values: Any) -> tuple[FloatArray, ...] | None:
        """``values`` as contiguous float64 (n,) arrays, or None where one is not."""
        try:
            out = tuple(real_array(v, order="C") for v in values)  # writable
        except (TypeError, ValueError):
            return None
        return out if all(v.shape == self.held_from.shape for v in out) else None

    def hold(self, q0: Any, q: FloatArray) -> None:
        """Remember the step answered from ``q0`` to ``q`` (:func:`hold_step`)."""
        try:
            self.keep(q0, q, self.memory)
        except NOT_VECTORS:  # not float64 arrays: converted (the step has checked them)
            vectors = self._vectors(q0, q)
            if vectors is not None:
                self.keep(*vectors, self.memory)

    def forget(self) -> None:
        """Forget the last step: the next state is taken as it comes (and its loop watched)."""
        self.memory[HELD_FROM] = np.nan
        self.watching, self._watched, self._misfed = True, 0, 0

    def watch_feed(self, q0: Any, q_prev: Any) -> None:
        """Warn once where a loop's first steps feed back the last answer as its ``q_prev``.

        Over the first :data:`FEED_WATCH` steps after the memory starts: a ``q_prev``
        within :data:`ANSWER_TOL` of the last answer ``q`` that is not its ``q0``, or no
        ``q_prev`` with ``q0`` that answer, after a step that moved, says the arm has not
        moved over the period while it was commanded to: each step then starts from
        rest, the tool crawls under acceleration limits, and nothing fails. On
        :data:`MISFED_STEPS` such steps in a row, a ``RuntimeWarning`` (:data:`MISFED`).
        A step whose arguments are not coordinates ends the watch (the step names them).
        """
        self._watched += 1
        self.watching = self._watched < FEED_WATCH
        step = self.memory[HELD_STEP]
        if not (np.isfinite(self.held_from).all() and step.any()):
            return
        try:
            last = np.asarray(q0 if q_prev is None else q_prev, dtype=np.float64)
            answer = self.held_from + step
            misfed = last.shape == answer.shape and bool(
                np.all(np.abs(last - answer) <= ANSWER_TOL)
                and (q_prev is None or not np.array_equal(last, self.held_from))
            )
        except (TypeError, ValueError):
            self.watching = False
            return
        self._misfed = self._misfed + 1 if misfed else 0
        if self._misfed >= MISFED_STEPS:
            warnings.warn(MISFED, RuntimeWarning, stacklevel=3)
            self.watching = False
