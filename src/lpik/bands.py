"""How a joint's limits combine into one step's bounds on ``dq``: the rule of precedence.

Each limit allows a band of steps ``dq = q - q0`` for one joint: the end-stops
``[q_min - q0, q_max - q0]`` (eq. 13), the velocity limits ``[qd_min, qd_max] dt``
and the acceleration limits ``last + [qdd_min, qdd_max] dt^2`` (eq. 14, with
``last = q0 - q_prev``, the previous step). Normally the step's band is their
intersection. When the intersection is empty, the state is already outside a
limit (a joint past its end-stop, a speed above its limit, a joint too fast to
stop before its end-stop): then a lower limit *yields* to a higher one, which
is met exactly, and the lower one as closely as it allows. Precedence:

1. acceleration limits (what the drives can do: never broken);
2. velocity limits, and the braking distance to the end-stops under the
   acceleration limits (an end-stop that cannot be reached at full
   deceleration is a bound on the speed now: :func:`braking_room`);
3. the end-stops themselves.

Precedence applies to motions the arm can have made under these limits. A
``last`` that no step of its own leaves, faster than the velocity limit
(:func:`plausible_step`) or too fast to stop before the end-stop by more than
one braking step (:func:`stoppable_step`), is a fault of the state (a bad
``q_prev`` sample, a push from outside): it is taken at that limit (at rest,
where it lies more than one step of acceleration past the velocity limit:
:func:`rate_band`), and the end-stop keeps its room.

A joint outside its end-stops is *pinned* for the step: it returns onto the
end-stop if its velocity and acceleration limits allow, else as far towards it
as they allow, and never further out unless its acceleration limit forces it
(it was already moving out). No stop ahead of the motion narrows its band
(:func:`beyond_stops`). Every joint whose band is a single point is
pinned: LP2 then resolves its criterion over the other joints
(:func:`lpik.methods.kkt.pinned_system`), and the methods without a criterion
simply move it by that amount.

The functions work on scalars, so that the numpy layers
(:func:`lpik.limits.build_problem`, :meth:`lpik.problem.Problem.step_bounds`)
and the compiled fused step (:mod:`lpik.fast.step`) run the same rule. As for
:mod:`lpik.tolerances`, numba's disk cache does not notice an edit here: delete
the ``__pycache__`` folders under ``lpik`` afterwards.
"""

from __future__ import annotations

import math

from lpik.tolerances import FADING_HOLD_SHARE, FEASIBILITY_TOL, REST_STEP, SLACK_TOL

#: The share of its full deceleration that a stop ahead of a row counts on: every joint
#: that moves the row at its acceleration limit against the approach
#: (:func:`row_deceleration`); the rest is left to the task, to the joints' own
#: end-stops and to a row's value changing faster than its gradient tells (a scene's
#: distance). The command's own stop on its target counts on another share,
#: :data:`lpik.command.BRAKING_SHARE`.
ROW_BRAKING_SHARE = 0.5

#: :func:`yield_to`'s verdicts: the bands meet, or the soft band's lower or upper
#: bound had to give way (the state is outside it on that side).
MET, LOWER_YIELDED, UPPER_YIELDED = 0, -1, 1


def yield_to(hard_lo: float, hard_hi: float, soft_lo: float, soft_hi: float) -> tuple:
    """The intersection of two bands, or, when it is empty, the hard band's edge nearest the soft.

    Bands apart by at most :data:`~lpik.tolerances.SLACK_TOL` (relative) still
    meet, at the hard edge: rounding does not make a state outside its limits.

    Returns:
        ``(lo, hi, verdict)``: the bounds and :data:`MET`, :data:`LOWER_YIELDED`
        (the soft band lies above the hard one: the hard upper edge is taken)
        or :data:`UPPER_YIELDED` (the soft band lies below: the hard lower edge).
    """
    lo = max(hard_lo, soft_lo)
    hi = min(hard_hi, soft_hi)
    if lo <= hi:
        return lo, hi, MET
    met = lo - hi <= SLACK_TOL * max(1.0, abs(lo))
    if soft_hi < hard_lo:
        return hard_lo, hard_lo, MET if met else UPPER_YIELDED
    return hard_hi, hard_hi, MET if met else LOWER_YIELDED


def braking_room(room: float, decel_step: float) -> float:
    """The largest step towards an end-stop ``room`` away after which the joint can still stop.

    With deceleration ``decel_step = |qdd| dt^2`` per step, a step ``u`` followed
    by steps ``u - decel_step``, ``u - 2 decel_step``, ... travels at most
    ``u + (u - decel_step / 2)^2 / (2 decel_step)``; the bound keeps that within
    ``room``, and a step that can stop at once (``u <= decel_step``) may use all
    of ``room``. After a step at the bound, a full-deceleration step is again
    within the next step's bound, so the joint can always stop in time.

    Returns:
        ``+inf`` when there is no acceleration limit (``decel_step`` infinite);
        0 for a joint at or past the end-stop (it may not move further towards it).
    """
    if not decel_step < math.inf:
        return math.inf
    if not room > 0.0:
        return 0.0
    return max(min(room, decel_step), math.sqrt(2.0 * decel_step * room) - 0.5 * decel_step)


def stopping_distance(step: float, decel_step: float) -> float:
    """How far a step and the braking steps after it travel: :func:`braking_room`'s inverse.

    The steps ``step``, ``step - decel_step``, ... travel ``step + (step -
    decel_step / 2)^2 / (2 decel_step)`` (a step within one ``decel_step`` stops
    at once: ``step``), so ``braking_room(stopping_distance(u, c), c) == u``.
    """
    if step <= decel_step:
        return step
    return step + (step - 0.5 * decel_step) ** 2 / (2.0 * decel_step)


def row_deceleration(row, sign, qdd_min, qdd_max, dt):  # type: ignore[no-untyped-def]
    """How much one step within the acceleration bands can lower ``sign * row . dq`` [per step].

    Each joint's band is its last step plus ``[qdd_min, qdd_max] dt^2``; the sum of
    each joint's share at its limit against the row: ``inf`` where a joint that moves
    the row has no acceleration limit that way (it can stop at once).
    """
    total = 0.0
    for i in range(row.shape[0]):
        a = sign * row[i]
        if a > 0.0:
            total -= a * qdd_min[i]
        elif a < 0.0:
            total -= a * qdd_max[i]
    return total * dt * dt


def braked_room(room: float, deceleration: float) -> float:
    """A row's room for one step with its stop ahead: :func:`braking_room` at the share.

    ``room`` (``h - G q0``) as it is where the row is already met or broken
    (``room <= 0``), where nothing brakes it (``deceleration`` 0: a row of no joint)
    and where it can stop at once (``deceleration`` infinite); else the largest step
    after which the row can still be kept braking at :data:`ROW_BRAKING_SHARE` of
    ``deceleration`` (:func:`row_deceleration`), which is never more than ``room``.
    """
    if not (room > 0.0 and 0.0 < deceleration < math.inf):
        return room
    return braking_room(room, ROW_BRAKING_SHARE * deceleration)


def rate_band(
    last: float,
    room_lo: float,
    room_hi: float,
    vel_lo: float,
    vel_hi: float,
    qdd_min: float,
    qdd_max: float,
    dt: float,
) -> tuple:
    """One joint's band from its velocity and acceleration limits and its braking distance.

    Args:
        last: The previous step ``q0 - q_prev`` (0 at rest).
        room_lo: ``q_min - q0`` (``-inf``: no lower end-stop).
        room_hi: ``q_max - q0`` (``+inf``: no upper end-stop).
        vel_lo: Lower velocity limit times ``dt`` (``-inf``: none).
        vel_hi: Upper velocity limit times ``dt`` (``+inf``: none).
        qdd_min: Lower acceleration limit (``-inf``: none).
        qdd_max: Upper acceleration limit (``+inf``: none).
        dt: Control period.

    Returns:
        ``(lo, hi, lo_kind, hi_kind, verdict)``: the bounds on ``dq``; which
        limit sets each (0 end-stop by braking distance, 1 velocity, 2
        acceleration: :data:`lpik.labels.BOUND_KINDS`); and :func:`yield_to`'s
        verdict of the acceleration band over the others. When a side yielded,
        both kinds name the limit the motion is outside of on that side.

    A ``last`` faster than the velocity limits is a fault of the state (a bad
    ``q_prev`` sample: the drives cannot move the joint that fast), not a
    motion to continue, and the verdict names the velocity limit on that side.
    Within one step of acceleration past the limit (a joint at its limit, and
    noise or a push) the band is taken around the limit (:func:`plausible_step`).
    Beyond that the sample tells nothing of the motion, and the band is taken
    around rest: taken at the limit, one bad sample would send the joint at
    full speed in the sample's direction, which the acceleration limits then
    take a long way to stop (a closed-loop fuzz: a UR5e's base swung 0.5 rad
    into its own wrist, 97 mm deep). Near an end-stop, any ``last`` is taken
    at most as fast as a motion the joint's own steps can leave, one full
    deceleration beyond the braking distance's bound (:func:`stoppable_step`),
    so that the step brakes onto that bound: a ``last`` beyond it (a bad
    sample within the velocity limits, a push from outside) is a fault too,
    and the verdict names the end-stop (kind 0).
    """
    dt2 = dt * dt
    brake_hi = braking_room(room_hi, -qdd_min * dt2)
    brake_lo = -braking_room(-room_lo, qdd_max * dt2)
    fault, fault_kind = MET, 1
    if qdd_min > -math.inf or qdd_max < math.inf:  # else the last step binds nothing
        sample = last
        last, fault = plausible_step(last, vel_lo, vel_hi)
        # one step of acceleration past the limit, up to a rounding (SLACK_TOL, as
        # plausible_step): a measured loop's state taken at the edge of its plausible band
        # (lpik.continuation.plausible_previous) after a step at the limit lands there
        reach_lo = vel_lo - qdd_max * dt2 - SLACK_TOL * max(1.0, abs(vel_lo))
        reach_hi = vel_hi - qdd_min * dt2 + SLACK_TOL * max(1.0, abs(vel_hi))
        if fault != MET and not reach_lo <= sample <= reach_hi:
            # not even one step of acceleration past the limit: no motion at all is known
            last = min(max(0.0, vel_lo), vel_hi)
        # no motion to continue into an end-stop, whether the speed was a fault or not
        last, unstoppable = stoppable_step(last, brake_lo, brake_hi, qdd_min * dt2, qdd_max * dt2)
        if fault == MET and unstoppable != MET:
            fault, fault_kind = unstoppable, 0
    acc_lo, acc_hi = last + qdd_min * dt2, last + qdd_max * dt2
    soft_lo, lo_kind = (brake_lo, 0) if brake_lo > vel_lo else (vel_lo, 1)
    soft_hi, hi_kind = (brake_hi, 0) if brake_hi < vel_hi else (vel_hi, 1)
    lo, hi, verdict = yield_to(acc_lo, acc_hi, soft_lo, soft_hi)
    if verdict == UPPER_YIELDED:
        return lo, hi, hi_kind, hi_kind, verdict
    if verdict == LOWER_YIELDED:
        return lo, hi, lo_kind, lo_kind, verdict
    if acc_lo > soft_lo:
        lo_kind = 2
    if acc_hi < soft_hi:
        hi_kind = 2
    if fault != MET:  # the bands meet, around a faulty last step taken as plausible
        return lo, hi, fault_kind, fault_kind, fault
    return lo, hi, lo_kind, hi_kind, MET


def fading_band(
    last: float, steps: float, lo: float, hi: float, qdd_min: float, qdd_max: float, dt: float,
    hold: float = math.inf,
) -> tuple:  # fmt: skip
    """One joint's band where the arm's motion stops paying in ``steps`` steps: a stop ahead.

    Under acceleration limits a joint cannot stop at once. Where the arm's
    motion will stop reducing the task error ``steps`` steps ahead
    (:func:`lpik.continuation.fading_steps`), the joint keeps the room to stop
    there: the point ``steps * last`` ahead is taken as an end-stop
    (:func:`braking_room`, decelerating at the limit on the braking side), and
    the band's edge in the direction of motion is at most the step after which it
    can still stop there, never below the band's other edge. Near the stop of
    the motion's own gain, ``hold`` steps ahead (it could not keep its speed were
    that stop :data:`~lpik.tolerances.FADING_HOLD_SHARE` of the distance away),
    a joint that cannot stop within one step does not speed up towards it
    either: it coasts or slows down, instead of speeding up to brake at the
    limit a few steps later (the constant's comment says what that cost); one
    that can (a creeping arm) may. ``steps`` may be nearer, the stop
    before a singular configuration (:func:`lpik.methods.autobound.singular_steps`),
    which has its own rule at the floor; ``hold`` infinite: no such stop.
    A joint whose last step is at most :data:`~lpik.tolerances.REST_STEP` is at
    rest: its motion is rounding, and its direction tells nothing (at 2e-20 rad,
    ``steps * last`` took the band's edge from one full acceleration to 8e-6 rad,
    and the engines, whose rounding differs, took different steps).

    Returns:
        ``(lo, hi, lo_fades, hi_fades)``: the bounds, and whether the stop ahead
        sets each (its kind is then the acceleration limit's).
    """
    if not steps < math.inf or abs(last) <= REST_STEP:
        return lo, hi, False, False
    dt2 = dt * dt
    if last > 0.0:
        allowed = braking_room(steps * last, -qdd_min * dt2)
        if (
            allowed > last > -qdd_min * dt2
            and braking_room(FADING_HOLD_SHARE * hold * last, -qdd_min * dt2) < last
        ):  # near the stop: no speeding up towards it
            allowed = last
        if hi > allowed:
            return lo, max(allowed, lo), False, True
        return lo, hi, False, False
    allowed = braking_room(-steps * last, qdd_max * dt2)
    if (
        allowed > -last > qdd_max * dt2
        and braking_room(-FADING_HOLD_SHARE * hold * last, qdd_max * dt2) < -last
    ):
        allowed = -last
    if lo < -allowed:
        return min(-allowed, hi), hi, True, False
    return lo, hi, False, False


def plausible_step(last: float, vel_lo: float, vel_hi: float) -> tuple:
    """The last step as the limits allow it: ``last`` clipped to ``[vel_lo, vel_hi]``.

    Returns:
        ``(step, verdict)``: the step, and :data:`MET`, or :data:`UPPER_YIELDED`
        (:data:`LOWER_YIELDED`) where ``last`` was above (below) the velocity band
        by more than the ratio test's :data:`~lpik.tolerances.SLACK_TOL`.
    """
    if last > vel_hi:
        fault = UPPER_YIELDED if last - vel_hi > SLACK_TOL * max(1.0, abs(vel_hi)) else MET
        return vel_hi, fault
    if last < vel_lo:
        fault = LOWER_YIELDED if vel_lo - last > SLACK_TOL * max(1.0, abs(vel_lo)) else MET
        return vel_lo, fault
    return last, MET


def stoppable_step(
    last: float, brake_lo: float, brake_hi: float, accel_lo: float, accel_hi: float
) -> tuple:
    """The last step as a motion the braking distance can have left: at most one braking step out.

    A step within the braking distance's bound (:func:`braking_room`) leaves
    the next step's bound at most one full deceleration ``-accel_lo`` (towards
    the upper end-stop) below it, exactly so after a step at the bound: from
    its own steps a joint can always stop. A ``last`` further out (a joint
    that cannot stop before its end-stop, even braking at the acceleration
    limit from now on) is no motion the arm made under these limits: a bad
    ``q_prev`` sample, or a push from outside. Its real speed is unknown, and
    continued, it would run the joint into the end-stop; it is taken at that
    furthest motion instead, so that the step, one full deceleration from it,
    lands on the braking distance's bound. The clip is continuous: a ``last``
    a rounding beyond (a step at its bound within the ratio test's slack)
    changes the band by that rounding only.

    Args:
        last: The previous step ``q0 - q_prev``, already within the velocity band.
        brake_lo: The lower bound of the braking distance (``-braking_room``).
        brake_hi: The upper bound of the braking distance (``braking_room``).
        accel_lo: The lower acceleration limit times ``dt^2`` (at most 0).
        accel_hi: The upper acceleration limit times ``dt^2`` (at least 0).

    Returns:
        ``(step, verdict)``: the step, and :data:`MET`, or :data:`UPPER_YIELDED`
        (:data:`LOWER_YIELDED`) where ``last`` lay beyond the upper (lower)
        bound by more than one braking step and the ratio test's
        :data:`~lpik.tolerances.SLACK_TOL`.
    """
    reach_hi = brake_hi - accel_lo  # the furthest last step the arm's own steps can leave
    if last > reach_hi:
        fault = UPPER_YIELDED if last - reach_hi > SLACK_TOL * max(1.0, abs(reach_hi)) else MET
        return reach_hi, fault
    reach_lo = brake_lo - accel_hi
    if last < reach_lo:
        fault = LOWER_YIELDED if reach_lo - last > SLACK_TOL * max(1.0, abs(reach_lo)) else MET
        return reach_lo, fault
    return last, MET


def outside_tolerance(bound: float) -> float:
    """How far past an end-stop a joint may be and still count as on it (the check's tolerance)."""
    return FEASIBILITY_TOL * max(1.0, abs(bound)) if math.isfinite(bound) else 0.0


def beyond_stops(q0: float, q_min: float, q_max: float) -> bool:
    """Whether a joint is past an end-stop by more than :func:`outside_tolerance`: *outside*.

    :func:`stop_band` pins such a joint to its way back. A stop ahead
    (:func:`fading_band`) does not narrow its band: the end-stop is a limit, the
    stop ahead the continuation's way of braking in time for what the motion buys
    (or before a singular configuration), so it yields, as it yields to a row.
    The UR5e's wrist 2 read 0.05 rad past its end-stop at -2 pi, where the wrist is
    singular: the stop before the singular configuration held the joint still on
    every other step (it came back at 5 mrad/s, the other joints held, for 10 s;
    without it, in 0.1 s at its acceleration limit).
    """
    return stop_side(q0, q_min, q_max) != 0


def stop_side(q0: float, q_min: float, q_max: float) -> int:
    """Which end-stop a joint is past by more than :func:`outside_tolerance`.

    +1 above ``q_max``, -1 below ``q_min``, 0 within them (a joint past one by at
    most the tolerance counts as on it).
    """
    if q_max - q0 < -outside_tolerance(q_max):
        return 1
    if q_min - q0 > outside_tolerance(q_min):
        return -1
    return 0


def stop_band(q0: float, q_min: float, q_max: float, rate_lo: float, rate_hi: float) -> tuple:
    """One joint's bounds on ``dq``: its end-stops (eq. 13) within its rate band.

    A joint past an end-stop by at most :func:`outside_tolerance` counts as on
    it (it may stay, not go further). One past it by more is *outside* and
    pinned: both bounds become the end-stop if the rate band reaches it, else
    the rate band's edge nearest to it.

    Returns:
        ``(lo, hi, lo_is_stop, hi_is_stop, outside)``: the bounds; whether the
        end-stop (rather than the rate band) sets each; and -1 (below
        ``q_min``), +1 (above ``q_max``) or 0.
    """
    room_lo, room_hi = q_min - q0, q_max - q0
    outside = stop_side(q0, q_min, q_max)
    if outside:
        back = min(max(room_hi if outside > 0 else room_lo, rate_lo), rate_hi)
        return back, back, outside < 0, outside > 0, outside
    room_lo, room_hi = min(room_lo, 0.0), max(room_hi, 0.0)  # within the tolerance: on it
    lo, hi, _ = yield_to(rate_lo, rate_hi, room_lo, room_hi)
    if hi - lo <= SLACK_TOL * max(1.0, abs(lo), abs(hi)) and math.isfinite(hi - lo):
        # A band narrower than the ratio test's slack is one point: the joint is
        # pinned. Left as a sliver (a joint braking at its acceleration limit
        # towards an end-stop ends there within rounding), LP2 would resolve its
        # criterion over it too, and a change of the state by one rounding would
        # switch the step between two different answers.
        lo = hi = 0.5 * (lo + hi)
    return lo, hi, room_lo >= rate_lo, room_hi <= rate_hi, outside
