"""The progress step: the motion that most reduces the task error within every limit.

LP1, LP2 and LP2 with saturation keep the commanded direction exactly
(``J dq = p dw``). From some states that direction is not available at all
(a joint at its end-stop near a singular configuration): every step returns
``p = 0`` (or nearly) although the error could still be reduced. The progress
step gives up the direction for progress: the least-L1 task error (as Ho's LP
minimises the L1 norm of the joint step, paper sec. 2.3)::

    minimise  sum_k |J dq - dw|_k + MOTION_WEIGHT sum_i |dq_i|   within every bound and row;

the small second term picks, among the steps of least error, one of least
motion (without it the LP's vertex choice makes the joints jitter). The stall
stage measures that motion from the arm's own motion under acceleration limits,
else from the exact step it replaces (``|dq - c|``, :func:`progress_center`),
and after a progress step prices the way each joint left ``c`` last step a
little lower (:func:`motion_prices`), so that nearly tied vertices do not take turns.

Two uses, one LP (:func:`least_error_lp` here through HiGHS,
:func:`lpik.fast.progress.least_error_step` compiled, held equal by tests):

- **the stall stage** (``on_stall``, on by default:
  :data:`lpik.defaults.DEFAULT_ON_STALL` is 1; ``None`` keeps the paper's strict
  steps): once the step has stalled (:func:`is_stall`) for ``on_stall`` steps in a
  row, :func:`progress_step` replaces it, with the status ``off_direction`` and
  ``p = 0``, so that the operator knows that the tool moved but not along the
  command. After a progress step, without acceleration limits, the next step is
  judged within a band (:meth:`StallWatch.keeping`), so that the steps do not flip
  between the two laws (each flip is a jump of the joint velocities): it stalls
  while the exact step gains less than the progress step, and up to ``p =
  STALL_BLEND_P``, where the stalled step blends the progress step with the exact
  one (:func:`stalled_step`), so that the way back to the exact step is
  continuous in ``p``. Its cost, measured on the quality suite
  (``docs/quality.md``): with targets beyond reach and no acceleration limits the
  progress steps between exact ones add joint jitter (scenario 2);
- **``mode="progress"``**: after every exact step with ``p < 1``,
  :func:`further_step` spends what the limits leave on the error that remains
  (status ``off_direction``, ``p`` the exact step's).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

import numpy as np

from lpik import check
from lpik.continuation import progress_scale
from lpik.highs import HighsSolver, LinearProgram
from lpik.methods.assembly import solver_for
from lpik.methods.autobound import clearly_regular
from lpik.problem import Problem
from lpik.result import CHECK_FAILED, INFEASIBLE, OFF_DIRECTION, OPTIMAL, SCALED, Result, safe_step
from lpik.tolerances import (
    ALONG_COMMAND_COSINE,
    COASTING_DRIFT_COSINE,
    EQUALITY_RTOL,
    FEASIBILITY_TOL,
    GAIN_RTOL,
    MOTION_KEEP_RTOL,
    MOTION_KEEP_SHARE,
    MOTION_WEIGHT,
    NO_CHANGE_P,
    SINGULAR_ACTIVATION,
    STALL_BLEND_P,
    STALL_KEEP_SHARE,
    STALL_P,
    STALL_SHARE,
)
from lpik.types import FloatArray


def least_error_lp(
    J: FloatArray, target: FloatArray, lower: FloatArray, upper: FloatArray,
    G: FloatArray, g: FloatArray, solver: HighsSolver | None = None,
    prices: FloatArray | None = None,
) -> tuple[str, FloatArray]:  # fmt: skip
    """``min |J dq - target|_1 + MOTION_WEIGHT |dq|_1``, ``lower <= dq <= upper``, ``G dq <= g``.

    The LP of the module docstring through HiGHS: variables ``(dq, t, u)`` with
    ``t >= +-(J dq - target)`` and ``u >= +-dq``. ``prices`` (2, n): the price per
    radian of each joint's motion up (row 0) and down (row 1) in place of
    ``MOTION_WEIGHT`` (:func:`motion_prices`), as ``u``'s cost, their mean, and a
    linear cost on ``dq``, half their difference. Returns the solve's status and ``dq``.
    """
    m, n = J.shape
    r = G.shape[0]
    eye, zeros = np.eye(n), np.zeros
    up, down = (np.full(n, MOTION_WEIGHT),) * 2 if prices is None else prices
    A = np.block([
        [J, -np.eye(m), zeros((m, n))],
        [-J, -np.eye(m), zeros((m, n))],
        [eye, zeros((n, m)), -eye],
        [-eye, zeros((n, m)), -eye],
        [G, zeros((r, m + n))],
    ])  # fmt: skip
    lp = LinearProgram(
        c=np.concatenate([0.5 * (up - down), np.ones(m), 0.5 * (up + down)]), A=A,
        row_lower=np.full(A.shape[0], -np.inf),
        row_upper=np.concatenate([target, -target, zeros(2 * n), g]),
        col_lower=np.concatenate([lower, zeros(m + n)]),
        col_upper=np.concatenate([upper, np.full(m + n, np.inf)]),
    )  # fmt: skip
    sol = solver_for(solver).solve(lp)
    dq = np.clip(sol.x[:n], lower, upper) if sol.status == OPTIMAL else np.zeros(n)
    return sol.status, dq


def l1_error(J: FloatArray, dw: FloatArray, dq: FloatArray) -> float:
    """``sum_k |J dq - dw|_k``: the task error a step leaves."""
    return float(np.abs(J @ dq - dw).sum())


#: The statuses of a step that can stall: the method's step, Ho's LP past the full
#: displacement (``scaled``: the controller's step where LP2's conditions admit none,
#: :meth:`lpik.control.stepper.Stepper.scaled`) and the safe step (or the controlled
#: stop). A ``recovering`` step (back within a limit the state is outside of) has its
#: own rule, which the stall stage leaves as it is.
STALLS = (OPTIMAL, SCALED, INFEASIBLE)


def stall_limit(keeping: bool) -> float:
    """The largest ``p`` at which a step may stall.

    :data:`~lpik.tolerances.STALL_BLEND_P` for a step judged within the band after
    a progress step (``keeping``: :meth:`StallWatch.keeping`, only where no
    acceleration limit bounds the change of the joint velocities), where
    :func:`exact_weight` blends the two steps so that the way back to the exact
    step does not jump (the constant's comment says why);
    :data:`~lpik.tolerances.STALL_P` otherwise, so that an exact step with a
    small ``p`` that follows no progress step needs no progress LP.
    """
    return STALL_BLEND_P if keeping else STALL_P


def exact_weight(p: float) -> float:
    """The exact step's weight ``w`` in a stalled step ``w dq_exact + (1 - w) dq_progress``.

    0 at ``p <= STALL_P`` (the progress step alone), 1 at ``p >= STALL_BLEND_P``,
    linear in between, so that the stall stage's step is continuous in ``p`` where
    ``p`` rises back above ``STALL_P`` after progress steps (:func:`stall_limit`). Both
    steps keep every bound, row and acceleration band, all of them convex, so
    their blend does too.
    """
    return min(max((p - STALL_P) / (STALL_BLEND_P - STALL_P), 0.0), 1.0)


def stalled_step(exact_dq: FloatArray, progress_dq: FloatArray, p: float) -> FloatArray:
    """The step that replaces a stalled exact step (``p`` its): :func:`exact_weight`'s blend."""
    weight = exact_weight(p)
    if weight == 0.0:
        return progress_dq
    return weight * np.asarray(exact_dq, dtype=np.float64) + (1.0 - weight) * progress_dq


def held_by_acceleration(binding: object) -> bool:
    """Whether a step's binding limit is an acceleration limit (``binding.kind``)."""
    return getattr(binding, "kind", None) == "acceleration"


def held_by_row(binding: object) -> bool:
    """Whether a step's binding limit is a row: a collision pair's damper or a user's row."""
    return getattr(binding, "kind", None) in ("row", "collision")


def held_by_velocity(binding: object) -> bool:
    """Whether a step's binding limit is a velocity limit (``binding.kind``)."""
    return getattr(binding, "kind", None) == "velocity"


def may_stall(
    p: float, held: bool, moving: bool, keeping: bool, at_speed: bool = False,
    along: bool = False,
) -> bool:  # fmt: skip
    """Whether a step may stall (:func:`stalls`), from its ``p``, binding limit and motion.

    ``p`` at most :func:`stall_limit` (``keeping``: within the band after a
    progress step), and not one of two motions that keep the direction where the
    step is not solved around a motion (``moving`` False: no acceleration limits,
    or an arm at rest) or around a motion along the command (``along``:
    :func:`moves_along`), with ``p > 0`` (above :data:`~lpik.tolerances.NO_CHANGE_P`):

    - a start from rest, or a motion along the command, held by an acceleration
      limit (``held``: :func:`held_by_acceleration`) has its direction and takes
      it as fast as the arm can speed up (or slows down as fast as it can, where
      it moves faster than the command), and ``p`` grows as it does; the second
      step of a move from rest was otherwise weighed against the progress step,
      which speeds every joint up at its limit, and taken in its place (status
      ``off_direction`` on three of six point-to-point moves of 50 and 200 mm on
      the Panda, its joints thrown off the line the first step began);
    - a step held by a velocity limit away from singular configurations
      (``at_speed``: :func:`at_speed`) follows the command as fast as the joints
      allow: ``p`` is small because the command asks for more than one step can
      do, not because the direction is blocked
      (:data:`~lpik.tolerances.SINGULAR_ACTIVATION`). Outside the band after a
      progress step only: within it the band decides when the progress steps end
      (the rule there too ended them midway while the Panda unfolded from a
      stretched pose in the quality suite's scenario 2: jitter 702 rad/s against
      313, the hand's orientation error up to 0.93 mrad against 0.23).

    Only a candidate needs the progress step's LP. Scalars only: the compiled
    stall stage runs this function itself (:func:`lpik.fast.progress.stall_stage`).
    """
    if p > stall_limit(keeping):
        return False
    if p <= NO_CHANGE_P or (moving and not along):
        return True
    return not (held or (at_speed and not keeping))


def motion_cosine(J, dw, last):  # type: ignore[no-untyped-def]
    """The cosine of the angle between the task motion ``J last`` and the command ``dw``.

    0 where either is zero. Plain loops: the compiled stall stage runs this code.
    """
    m, n = J.shape
    along, command, task = 0.0, 0.0, 0.0  # dw . J last, |dw|^2, |J last|^2
    for k in range(m):
        row = 0.0
        for i in range(n):
            row += J[k, i] * last[i]
        along += dw[k] * row
        command += dw[k] * dw[k]
        task += row * row
    size = math.sqrt(command * task)
    return along / size if size > 0.0 else 0.0


def coasts_away(J, dw, last, moving):  # type: ignore[no-untyped-def]
    """Whether the arm's motion ``last`` carries the tool away from the command ``dw``.

    Solved around a motion (``moving``) whose task motion ``J last`` lies at a cosine
    below ``-COASTING_DRIFT_COSINE`` to ``dw``
    (:data:`~lpik.tolerances.COASTING_DRIFT_COSINE`). There the progress step brakes
    (:func:`progress_center`). Plain: the compiled stall stage runs it.
    """
    return moving and motion_cosine(J, dw, last) < -COASTING_DRIFT_COSINE


def drifts(J, dw, last, moving, held):  # type: ignore[no-untyped-def]
    """:func:`stalls`' ``drifting``: the motion carries the tool away, held by a joint's bound.

    :func:`coasts_away`, and the step's binding limit is neither an acceleration
    limit nor a row (``held``: :func:`held_by_acceleration` or :func:`held_by_row`).
    Held by an acceleration limit, the exact step turns the motion towards the command
    as fast as the arm can (a target that jumps back: the arm brakes along the
    command's line and comes back); held by a collision pair's damper, it slides along
    the obstacle as the damper lets it (braking there instead took the Panda of the
    shelf scene's closed loop, ``lpik_bench.closed_loops``, into ``d_s`` on both seeds
    tried, where the acceleration limits left no step within the rows); held by
    anything else (an end-stop, a velocity limit, a multiplier bound), a step with a
    small ``p`` keeps the motion as it is. Plain: the compiled stall stage runs it.
    """
    return coasts_away(J, dw, last, moving) and not held


def moves_along(J, dw, last, moving):  # type: ignore[no-untyped-def]
    """:func:`may_stall`'s ``along``: the arm's motion ``last`` carries the tool along ``dw``.

    Solved around a motion (``moving``) whose task motion ``J last`` lies within
    :data:`~lpik.tolerances.ALONG_COMMAND_COSINE` of the command's direction. Plain:
    the compiled stall stage runs this function itself.
    """
    return moving and motion_cosine(J, dw, last) >= ALONG_COMMAND_COSINE


def stalls(
    p: float, exact_gain: float, progress_gain: float, held: bool, moving: bool, keeping: bool,
    scale: float, at_speed: bool = False, along: bool = False, drifting: bool = False,
) -> bool:  # fmt: skip
    """Whether a step stalls: no step along the command, or one far worse than leaving it.

    ``exact_gain`` and ``progress_gain`` are how much the exact step and the
    progress step reduce the L1 task error, ``sum |dw| - sum |J dq - dw|``;
    ``held``, ``at_speed``, ``along``: as for :func:`may_stall`; ``drifting``: the
    arm's motion carries the tool away from the command and a joint's bound, not an
    acceleration limit or a row, holds the step (:func:`drifts`); ``scale``:
    :func:`progress_scale` of the command, within :data:`~lpik.tolerances.GAIN_RTOL`
    of which the comparison below is rounding (no stall: a progress step that is the
    exact step itself). A step stalls where it :func:`may_stall` and

    - no step along the command exists at all (``p`` at most
      :data:`~lpik.tolerances.NO_CHANGE_P`: the step is the safe step, or the
      controlled stop of a moving arm, which keep no direction either), or
    - the arm's motion carries the tool away from the command and a joint's bound,
      not an acceleration limit or a row, holds the step (``drifting``): the exact step,
      solved around that motion, turns it by a share ``p`` of what the command asks
      per step and, with ``p`` this small, keeps it: the tool drifts away for as long
      as ``p`` stays small (on the iiwa14's random goal 5 without saturation, joint 7
      on its end-stop and ``p`` about 5e-5, 2,465 steps in a row, the tool 4.8 mm
      from its goal at the start and 62 mm at the end, every step ``optimal``). The
      progress step then brakes (:func:`progress_center`) and stands even where it
      gains nothing in this one step (the L1 error of one step cannot see that the
      motion it stops would carry the tool further away on every step after), or
    - it reduces the error by less than :data:`~lpik.tolerances.STALL_SHARE` of
      what the progress step achieves within the same limits; ``keeping`` (the
      last step was the progress step): less than
      :data:`~lpik.tolerances.STALL_KEEP_SHARE`, a band that keeps the steps from
      flipping between the two laws.

    A stalled step is replaced by :func:`stalled_step` (the progress step, blended
    with the exact one where ``p > STALL_P``). Where no motion brings the target
    nearer the stall stage keeps the step all the same (:func:`makes_progress`).
    Scalars only, as :func:`may_stall`.
    """
    if not may_stall(p, held, moving, keeping, at_speed, along):
        return False
    if drifting:
        return True
    share = STALL_KEEP_SHARE if keeping else STALL_SHARE
    return p <= NO_CHANGE_P or share * progress_gain - exact_gain > GAIN_RTOL * scale


def in_band(engaged: bool, moving: bool) -> bool:
    """Whether a step is judged within the band after a progress step (:func:`stalls`' ``keeping``).

    After a progress step (``engaged``), where no acceleration limit carries the
    motion on (``moving`` False: the step is not solved around a motion): there
    every flip between the exact and the progress step is a jump of the joint
    velocities. Under acceleration limits the limits bound that jump, and the band
    would only hold back exact steps (measured on the quality suite: fewer
    excursions recovered, more jitter; on scenario 11 a goal ended 21.6 mm off,
    held in the progress step). Scalars only, as :func:`may_stall`.
    """
    return engaged and not moving


def makes_progress(before: float, after: float, scale: float) -> bool:
    """Whether a step that takes the L1 task error from ``before`` to ``after`` gains.

    A gain within :data:`~lpik.tolerances.EQUALITY_RTOL` of ``scale``
    (:func:`progress_scale`) is rounding, not progress. Scalars only, as :func:`may_stall`.
    """
    return before - after > EQUALITY_RTOL * scale


def at_speed(binding: object, J: FloatArray) -> bool:
    """:func:`may_stall`'s ``at_speed``: a velocity limit binds, ``J`` is far from singular.

    Far from singular: ``sigma_min > SINGULAR_ACTIVATION sigma_max``, as certified by
    :func:`lpik.methods.autobound.clearly_regular` (a Cholesky test; it may say no a
    little above the threshold, never yes below it): :func:`held_at_speed`.
    """
    return bool(held_at_speed(held_by_velocity(binding), J))


def held_at_speed(velocity, J):  # type: ignore[no-untyped-def]
    """:func:`at_speed` from ``velocity`` (:func:`held_by_velocity`).

    Plain: the compiled stall stage runs this function itself
    (:func:`lpik.fast.progress.stall_stage`).
    """
    return velocity and clearly_regular(J, SINGULAR_ACTIVATION)


def stall_candidate(
    p: float, binding: object = None, moving: bool = True, keeping: bool = False,
    speed: bool = False, along: bool = False,
) -> bool:  # fmt: skip
    """:func:`may_stall` with the step's ``binding`` limit itself (``speed``: :func:`at_speed`)."""
    return may_stall(p, held_by_acceleration(binding), moving, keeping, speed, along)


def is_stall(
    p: float, exact_gain: float, progress_gain: float, binding: object = None,
    moving: bool = True, keeping: bool = False, scale: float = 1.0, speed: bool = False,
    along: bool = False, drifting: bool = False,
) -> bool:  # fmt: skip
    """:func:`stalls` with the step's ``binding`` limit itself (``speed``: :func:`at_speed`)."""
    return stalls(p, exact_gain, progress_gain, held_by_acceleration(binding), moving, keeping,
                  scale, speed, along, drifting)  # fmt: skip


def progress_step(
    problem: Problem, *, solver: HighsSolver | None = None, exact: FloatArray | None = None,
    last_motion: FloatArray | None = None, engaged: bool = False, braking: bool = False,
) -> Result:  # fmt: skip
    """The step of least L1 task error ``sum |J dq - dw|`` within every limit (an LP).

    Args:
        problem: The step; ``dw`` is the command whose error is reduced.
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across steps.
        exact: The exact step it replaces: the motion term's center where the step
            is not solved around a motion (:func:`progress_center`; None: 0).
        last_motion: The arm's last step ``q0 - q_prev`` (None: at rest), and
        engaged: whether that step was the progress step: the motion term's prices
            (:func:`motion_prices`).
        braking: The step brakes a motion that carries the tool away from the
            command (:func:`drifts`): it stands even without a gain.

    Returns:
        Status ``off_direction`` and ``p = 0`` (the direction is not kept) when the
        step reduces the error (or ``braking``); ``residual`` is ``max |J dq - dw|``,
        what remains of the command. The safe step (status of the solve) when the LP fails; a
        no-progress answer is returned as the safe step with status ``optimal``
        and binding ``"no progress"``.
    """
    start = time.perf_counter()
    lower, upper = problem.step_bounds()[:2]
    J, G, zero = problem.J, problem.G, np.zeros(problem.n)
    moving = problem.last is not None
    center = progress_center(J, problem.dw, problem.last if moving else zero,
                             zero if exact is None else np.asarray(exact, dtype=float), moving,
                             lower, upper, np.empty(problem.n))  # fmt: skip
    last = zero if last_motion is None else np.asarray(last_motion, dtype=float)
    prices = motion_prices(last, center, engaged, np.empty((2, problem.n)))
    rows_rhs = problem.h - G @ (problem.q0 + center)
    status, delta = least_error_lp(J, problem.dw - J @ center, lower - center, upper - center, G,
                                   rows_rhs, solver, prices)  # fmt: skip
    before = float(np.abs(problem.dw).sum())
    dq = np.clip(center + delta, lower, upper)
    return _checked(problem, status, dq, before, 0.0, None, start, braking)


def progress_center(J, dw, last, exact, moving, lower, upper, center):  # type: ignore[no-untyped-def]
    """Where the progress step's motion term is measured from, within the step's bounds.

    The stall stage minimises ``|J dq - dw|_1 + MOTION_WEIGHT |dq - c|_1``; ``c`` is
    written into ``center`` (n,) and returned:

    - under acceleration limits (``moving``: the step solved around the motion,
      ``last = q0 - q_prev``, :mod:`lpik.continuation`) ``c`` is that motion: the step
      keeps the motion the arm has unless changing it buys clearly less error, so that
      stalled and exact steps in turn do not throw the joints one way and back. Where
      that motion carries the task away from the command, ``J last`` at a cosine below
      ``-COASTING_DRIFT_COSINE`` to ``dw``, ``c`` is the braking step (0 within the
      bounds): coasting there can still pay in L1 while the tool drifts away from the
      target (:data:`~lpik.tolerances.COASTING_DRIFT_COSINE`);
    - otherwise ``c`` is the exact step ``exact`` (0 where there is none): the progress
      step is the exact step but where leaving it buys clearly less error. Measured on
      the quality suite's scenario 2 without acceleration limits: with ``c`` 0 (the
      least motion) an arm unfolding from a stretched pose at its velocity limits (``p``
      0.002 to 0.008) took, every few steps, a progress step of almost no motion, which
      gained twice as much in the linear model: two jumps of 8.9 rad/s each time; with
      ``c`` the exact step the scenario's jitter fell from 482 to 311 rad/s and its
      largest orientation error from 0.38 to 0.27 mrad (the progress steps take back the
      curvature's error that the exact step adds), every excursion recovered. ``c`` the
      arm's last motion instead carried the arm into a pose it could not leave (2 of 6
      excursions recovered).

    Plain loops: the compiled stall stage runs this function itself
    (:func:`lpik.fast.progress.progress_in_state`).
    """
    n = J.shape[1]
    braking = coasts_away(J, dw, last, moving)
    for i in range(n):
        c = 0.0 if braking else (last[i] if moving else exact[i])
        center[i] = min(max(c, lower[i]), upper[i])
    return center


def motion_prices(last, center, engaged, prices):  # type: ignore[no-untyped-def]
    """The stall stage's price per radian of each joint's motion from ``center``: ``prices`` (2, n).

    Row 0 prices a joint's motion up, row 1 down: :data:`~lpik.tolerances.MOTION_WEIGHT`
    each, but after a progress step (``engaged``) the way each joint left the center
    in the arm's last step (``last = q0 - q_prev``) is cheaper by
    :data:`~lpik.tolerances.MOTION_KEEP_SHARE` times its share of the largest such
    deviation (deviations below :data:`~lpik.tolerances.MOTION_KEEP_RTOL` of the
    motion are rounding: the last step was the center itself). Where two vertices
    of the progress LP are nearly a tie (two joints whose motion buys about as
    much), which one is least flips with every step the
    arm takes, and the joints' velocities jump between them at every step; the
    price keeps the vertex of the last step until the other is clearly better.
    Measured on scenario 2 of the quality suite on the iiwa14 (leg +z, the arm
    stretched towards a target beyond reach): its joints 2 and 6 took turns at
    every step for 80 steps, the two vertices' objectives 1e-7 apart and the
    sign of the difference alternating, 120 of the leg's 149 rad/s of jitter.
    Under acceleration limits the center is the last motion itself, and at rest
    (``last`` 0: no ``q_prev``) nothing is known of the last step: the prices are
    even. Plain loops: the compiled stall stage runs this code.
    """
    n = center.shape[0]
    largest, size, moved = 0.0, 0.0, False
    for i in range(n):
        largest = max(largest, abs(last[i] - center[i]))
        size = max(size, abs(last[i]), abs(center[i]))
        moved = moved or last[i] != 0.0
    largest = max(largest, MOTION_KEEP_RTOL * size)  # a deviation of rounding's size is none
    for i in range(n):
        prices[0, i] = prices[1, i] = MOTION_WEIGHT
        if engaged and moved and largest > 0.0:
            share = (last[i] - center[i]) / largest
            cheaper = MOTION_WEIGHT * MOTION_KEEP_SHARE * abs(share)
            if share > 0.0:
                prices[0, i] -= cheaper
            else:
                prices[1, i] -= cheaper
    return prices


def further_step(problem: Problem, exact: Result, *, solver: HighsSolver | None = None) -> Result:
    """``mode="progress"``: after the exact step, the least error that the limits leave.

    ``dq = dq1 + delta`` (``dq1`` the exact step): ``delta`` minimises
    ``|J delta - (dw - J dq1)|_1 + MOTION_WEIGHT |delta|_1`` within every bound
    and row, with each task row's error kept within the exact step's,
    ``|J_k dq - dw_k| <= |J_k dq1 - dw_k|`` (so ``delta = 0`` is a candidate and no
    row ends worse). The motion term keeps the step near the exact one.

    Returns:
        ``exact`` itself where it has ``p >= 1`` (nothing left), is not an
        optimal step, or where the second stage gains nothing; otherwise the step,
        status ``off_direction``, ``p`` and ``binding`` the exact step's,
        ``residual`` ``max |J dq - dw|``.
    """
    if exact.status != OPTIMAL or exact.p >= 1.0:
        return exact
    start = time.perf_counter()
    lower, upper = problem.step_bounds()[:2]
    J, dw, dq1, G = problem.J, problem.dw, exact.dq, problem.G
    e = J @ dq1 - dw
    rows = np.vstack([G, J, -J])
    rhs = np.concatenate([np.maximum(problem.h - G @ problem.q0 - G @ dq1, 0.0),
                          np.abs(e) - e, np.abs(e) + e])  # fmt: skip
    status, delta = least_error_lp(J, -e, np.minimum(lower - dq1, 0.0),
                                   np.maximum(upper - dq1, 0.0), rows, rhs, solver)  # fmt: skip
    result = _checked(problem, status, np.clip(dq1 + delta, lower, upper),
                      float(np.abs(e).sum()), exact.p, exact.binding, start)  # fmt: skip
    return result if result.status == OFF_DIRECTION else exact


def _checked(
    problem: Problem, status: str, dq: FloatArray, before: float, p: float,
    binding: str | None, start: float, braking: bool = False,
) -> Result:  # fmt: skip
    """The progress LP's answer, checked: ``off_direction``, or the safe step saying why not.

    ``braking``: as for :func:`progress_result`.
    """
    elapsed = time.perf_counter() - start
    if status != OPTIMAL:
        return safe_step(problem, "progress", status, solve_time=elapsed, path="highs")
    violation = check.worst_violation(problem, dq)
    if violation.amount > FEASIBILITY_TOL or not np.isfinite(dq).all():
        return safe_step(problem, "progress", CHECK_FAILED, violation.label,
                         solve_time=elapsed, path="highs")  # fmt: skip
    result = progress_result(problem.q0, dq, problem.J, problem.dw, before, p, binding,
                             elapsed, "highs", braking)  # fmt: skip
    if result.status != OFF_DIRECTION:
        return safe_step(problem, "progress", OPTIMAL, "no progress", solve_time=elapsed,
                         path="highs")  # fmt: skip
    return result


def progress_result(
    q0: FloatArray, dq: FloatArray, J: FloatArray, dw: FloatArray, before: float, p: float,
    binding: str | None, elapsed: float, path: str, braking: bool = False,
) -> Result:  # fmt: skip
    """The progress step as a Result (every path): ``off_direction`` where it gains.

    ``before`` is the L1 task error without it (``sum |dw|``, or the exact step's).
    A gain that is none (:func:`makes_progress`): status ``optimal``, binding ``"no
    progress"``, ``dq`` as given; but a step that brakes a motion carrying the tool
    away from the command (``braking``: :func:`drifts`) stands all the same.
    """
    left = np.abs(J @ dq - dw)  # what remains of each task row (once: the step is timed)
    if not (braking or makes_progress(before, float(left.sum()), progress_scale(dw))):
        return Result(q=q0 + dq, dq=dq, p=p, lam=None, status=OPTIMAL, binding="no progress",
                      method="progress", solve_time=elapsed, path=path)  # fmt: skip
    return Result(
        q=q0 + dq, dq=dq, p=p, lam=None, status=OFF_DIRECTION, binding=binding,
        method="progress", solve_time=elapsed,
        residual=float(left.max()) if dw.size else 0.0, path=path,
    )  # fmt: skip


class StallWatch:
    """Counts stalled steps (:func:`is_stall`) in a row and says when to take the progress step.

    Args:
        after: Stalled steps in a row before the progress step is taken
            (``None``: never, the paper's strict steps).
    """

    def __init__(self, after: int | None) -> None:
        whole = isinstance(after, int | np.integer) and not isinstance(after, bool)
        if after is not None and not (whole and after >= 1):
            raise ValueError(
                f"on_stall: must be a whole number of steps >= 1 or None, got {after!r}"
            )
        self.after = None if after is None else int(after)
        self.run = 0
        self._key: bytes | None = None  # the q0 of the last step judged (engaged_at)
        self._engaged_at = False  # and whether the step before it was the progress step

    def count(self, stall: bool) -> bool:
        """Count one step (``stall``: :func:`is_stall`); True when the progress step is due."""
        if self.after is None:
            return False
        self.run = self.run + 1 if stall else 0
        return self.run >= self.after

    def clear(self) -> None:
        """A step that did not stall: the count starts again."""
        self.run = 0

    @property
    def engaged(self) -> bool:
        """Whether the last step was the progress step."""
        return self.after is not None and self.run >= self.after

    def engaged_at(self, q0: FloatArray) -> bool:
        """:attr:`engaged` as it was when the step from ``q0`` was first judged.

        The same step asked again (the same ``q0``: ``step`` then ``step_into``, or
        an arm that did not move) is judged as the first time.
        """
        key = np.asarray(q0, dtype=np.float64).tobytes()
        if key != self._key:
            self._key, self._engaged_at = key, self.engaged
        return self._engaged_at

    def keeping(self, q0: FloatArray, moving: bool) -> bool:
        """Whether the step from ``q0`` is judged within the band (:func:`in_band`)."""
        return in_band(self.engaged_at(q0), moving)

    def check(
        self, result: Result, problem_of: Callable[[], Problem],
        last_motion: FloatArray | None = None,
    ) -> Result:  # fmt: skip
        """``result``, or the progress step (HiGHS) once the step has stalled ``after`` times.

        ``problem_of()`` builds the step's :class:`~lpik.problem.Problem` (only when
        needed: a step with ``p <= STALL_P`` under a watch, or up to ``STALL_BLEND_P``
        right after a progress step, where the band may apply: :func:`stall_limit`).
        ``last_motion``: the arm's last step ``q0 - q_prev`` (None: at rest), for the
        progress step's prices (:func:`motion_prices`).
        """
        if (self.after is None or result.status not in STALLS
                or result.p > stall_limit(self.engaged)):  # fmt: skip
            self.run = 0
            return result
        problem = problem_of()
        moving = problem.last is not None  # under acceleration limits, q_prev != q0
        keeping = self.keeping(problem.q0, moving)  # after a progress step: the band
        # at_speed counts only for a step not solved around a motion, outside the band
        speed = not (moving or keeping) and at_speed(result.binding, problem.J)
        along = moves_along(problem.J, problem.dw, problem.last, moving)
        held = held_by_acceleration(result.binding) or held_by_row(result.binding)
        drifting = drifts(problem.J, problem.dw, problem.last, moving, held)
        if not stall_candidate(result.p, result.binding, moving, keeping, speed, along):
            self.run = 0
            return result
        progress = progress_step(problem, exact=result.dq, last_motion=last_motion,
                                 engaged=self.engaged_at(problem.q0), braking=drifting)  # fmt: skip
        before = float(np.abs(problem.dw).sum())
        gains = (before - l1_error(problem.J, problem.dw, result.dq),
                 before - l1_error(problem.J, problem.dw, progress.dq))  # fmt: skip
        stall = progress.status == OFF_DIRECTION and is_stall(
            result.p, *gains, result.binding, moving, keeping, progress_scale(problem.dw), speed,
            along, drifting,
        )  # fmt: skip
        if not self.count(stall):
            return result
        dq = stalled_step(result.dq, progress.dq, result.p)
        if dq is not progress.dq:  # blended with the exact step
            progress = progress_result(problem.q0, dq, problem.J, problem.dw, before, 0.0, None,
                                       progress.solve_time, progress.path, drifting)  # fmt: skip
        return dataclasses.replace(progress, binding=result.binding)  # what stopped the direction
