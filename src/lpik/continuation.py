"""A step solved around the current motion: the continuation form of eq. 12.

The paper's step keeps the commanded direction through the origin,
``J dq = p dw`` (eqs. 12, 16): at ``p = 0`` the joints stop at once. Under
acceleration limits they cannot: the step's band for each joint is centred on
the last step ``last = q0 - q_prev`` (:mod:`lpik.bands`), so the line through
``dq = 0`` may miss it, and every such step falls to the braking safe step,
although a motion within the limits exists (a joint that is moving keeps some
of its speed). The *continuation form* draws the line through the current
motion instead::

    J (dq - last) = p (dw - J last),    that is    J dq = (1 - p) J last + p dw.

At ``p = 0`` the task keeps the last step's motion (always within the
acceleration limits), at ``p = 1`` it moves by the command ``dw``. ``p`` is
then the share of the commanded *change* of the task motion that the limits
allow this step; from rest (``last = 0``) it is the paper's ``p``.

With ``u = dq - last`` the step is an ordinary :class:`~lpik.problem.Problem`
in ``u`` (:func:`continued`), which every method of the paper solves
unchanged: its origin is the configuration the motion would reach,
``q0 + last``; its bounds are the step's bounds (end-stops, velocity and
acceleration limits after :mod:`lpik.bands`' precedence, taken at ``q0``)
less ``last``; its command is ``dw - J last``; and its criterion is the same
function of ``dq`` (eq. 3: ``1/2 dq^T M dq - f^T dq``, so ``f`` becomes
``f - M last``; sec. 3.1's ``Lambda`` term is in ``q`` and needs no change).
The multipliers are those of the step in ``dq``. :func:`resumed` turns the
answer back into a step from ``q0``; :func:`around_motion` wraps LP1, LP2,
LP2 with saturation and Ho's L1 step (which takes LP1's ``p``) so that they do
both for a problem that carries ``last`` (:func:`lpik.limits.build_problem`
sets it where there are acceleration limits and the arm moves).

Where the step around the motion is the safe step even after the stall stage,
the controller's through-rest stage solves the paper's line through ``dq = 0``
within the same bounds (:func:`through_rest`), which holds the slower motions
the line around the motion does not; ``p`` is then the share of the command itself.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from lpik.bands import plausible_step
from lpik.problem import Problem
from lpik.result import INFEASIBLE, MOVING, OPTIMAL, RECOVERING, Result, safe_step
from lpik.tolerances import GAIN_RTOL, MOTION_WEIGHT, NO_CHANGE_P, SLACK_TOL
from lpik.types import FloatArray

#: Share of the narrowest band a step spends on slowing the null-space motion
#: (:func:`motion_decay`).
DECAY_SHARE = 0.5


def around_motion(method: Callable[..., Result]) -> Callable[..., Result]:
    """``method`` (LP1, LP2, LP2 with saturation) on a problem with ``last`` in continuation form.

    A problem without ``last`` goes to ``method`` as it is.
    """

    @functools.wraps(method)
    def solve(problem: Problem, *args: Any, **options: Any) -> Result:
        if problem.last is None:
            return method(problem, *args, **options)
        return resumed(problem, method(continued(problem), *args, **options))

    return solve


def through_rest(around: Result, rest: Result) -> Result:
    """The through-rest stage's choice: ``rest`` where it is a step on the paper's line.

    ``around`` is the step after the stall stage, still the safe step: no step on
    the line ``J dq = (1 - p) J last + p dw`` within the limits, and none that
    makes progress off it. That line holds no slowing down of the task's motion:
    where the last motion itself breaks a row this step (a distance row whose
    damper allows a little less approach each step than the step before took)
    every point of it breaks that row, although a slower motion within every limit
    exists. ``rest`` is the step on the paper's line through ``dq = 0`` (eq. 12)
    with the same command, within the same bounds (the acceleration band around the
    motion and its stops ahead), which holds those motions. Where it is feasible
    (``rest`` optimal, ``p`` the share of the command itself) that is the step;
    else ``around``. An arm that crept along an obstacle toward its safety
    distance otherwise stopped and started again on every other step. Taken after
    the stall stage, not before it: the progress steps that slide an arm around an
    obstacle stay as they were (taken before it, the step through rest pushed 5 of
    40 arms into the obstacle's damper, where they stayed 0.1 to 0.45 m from goals
    they had reached).
    """
    return rest if rest.status == OPTIMAL else around


def continued(problem: Problem) -> Problem:
    """``problem`` in ``u = dq - last``: the continuation form of the module docstring.

    The motion continued is ``last`` as far as the step's bounds allow it
    (clipped to them), so that ``p = 0`` is always within the joints' bounds.

    Args:
        problem: The step from ``q0`` with ``last``, ``q0 - q_prev`` (its bounds
            hold the acceleration limits).

    Returns:
        The same step as a problem in ``u``, with origin ``q0 + last`` (and no ``last``).
    """
    lower, upper = problem.step_bounds()[:2]
    lower_kinds, upper_kinds = problem.step_bound_kinds()
    last = problem.motion
    M = problem.M
    return problem.replace(
        q0=problem.q0 + last,
        dw=problem.dw - problem.J @ last,
        q_min=np.full(problem.n, -np.inf),
        q_max=np.full(problem.n, np.inf),
        dq_min=lower - last,
        dq_max=upper - last,
        dq_min_kind=list(lower_kinds),
        dq_max_kind=list(upper_kinds),
        f=problem.f - motion_decay(lower, upper, last) * (M @ last),
        q_ref=problem.q_ref,
        outside_limits=[],  # the state's own: resumed() names them
        last=None,
    )


def resumed(problem: Problem, result: Result) -> Result:
    """The answer to :func:`continued`'s problem as a step from ``problem.q0``.

    A step that moves keeps its ``q`` (``dq = q - q0``) and, from a state outside
    a limit, is ``recovering``, naming it; one that cannot move (a failure, an
    infeasible step) is the original problem's safe step, a controlled stop,
    with the same status and binding (``recovering`` from outside a limit).
    So is a step that cannot change the motion toward the command at all
    (``p = 0``, within :data:`~lpik.tolerances.NO_CHANGE_P`): it would coast
    along the last motion, ``J dq = J last``, which a command it cannot follow
    never turns (the hand drifts away, ever further); it is ``infeasible``,
    naming what stopped ``p`` (the controller's stages then look for a step
    through rest: :func:`through_rest`), and the arm comes to rest within its
    limits, from where the step is the paper's again.
    """
    if result.status == OPTIMAL and result.p <= NO_CHANGE_P:  # no change toward the command
        return safe_step(problem, result.method, INFEASIBLE, result.binding,
                         solve_time=result.solve_time, path=result.path)  # fmt: skip
    if result.status not in MOVING:
        return safe_step(problem, result.method, result.status, result.binding,
                         solve_time=result.solve_time, path=result.path)  # fmt: skip
    outside = problem.recovering()
    if outside:
        return replace(result, dq=result.q - problem.q0, status=RECOVERING, binding=outside[0])
    return replace(result, dq=result.q - problem.q0)


def motion_decay(lower: FloatArray, upper: FloatArray, last: FloatArray) -> float:
    """How much of the criterion's pull back to the least motion one step may take.

    The criterion (eq. 3) of the step ``dq = last + u`` pulls the joints' motion
    towards the criterion's least motion, at ``p = 0`` by ``-N last`` (``N``:
    the projection onto the null space): a change of the motion that the
    acceleration limits may not allow in one step. It is taken at the rate the
    narrowest moving band allows, :data:`DECAY_SHARE` of its half-width per step
    against the largest joint step, so that the motion in the null space dies
    away within the limits instead of making the step infeasible. Plain loops,
    compiled as they are by the fused step.

    Returns:
        The share, in [0, 1], that multiplies ``M last`` in the criterion's ``f``.
    """
    size, width = 0.0, math.inf
    for i in range(last.shape[0]):
        size = max(size, abs(last[i]))
        half = 0.5 * (upper[i] - lower[i])
        if half > 0.0:
            width = min(width, half)
    if size == 0.0 or not width < math.inf:
        return 0.0
    return min(1.0, DECAY_SHARE * width / size)


def progress_scale(dw):  # type: ignore[no-untyped-def]
    """``max(1, max |dw|)``: the scale of a gain's rounding for the command ``dw``.

    Gains within :data:`~lpik.tolerances.GAIN_RTOL` of it tie: in
    :func:`lpik.methods.progress.makes_progress` and the stall stage's comparison
    (:func:`lpik.methods.progress.stalls`), and in the fall of a motion's gain
    (:func:`fading_steps`).

    Measured and not kept: ``max |dw|`` alone, a gain judged against the command's own
    size. From rest 0.09 mm from the Panda's random goal 5 under acceleration limits
    (``benchmarks/random_goals.py``), where a first step from rest along the command
    takes the L1 error from 1.875e-5 to 1.872e-5, the arm then crept on to 0.03 mm
    (where the motion term stopped it: :data:`~lpik.tolerances.MOTION_WEIGHT`); but
    pushed 1 m beyond reach along +z (``tests/test_fading_motion.py``) it took, where the
    exact step had coasted home, progress steps whose gains the floor of 1 calls
    rounding, and ended 0.31 m off home with joint 4 on its end-stop.

    Plain loops: the compiled stall stage (:mod:`lpik.fast.progress`) and the fused
    step's :func:`fading_steps` run this code.
    """
    scale = 1.0
    for k in range(dw.shape[0]):
        scale = max(scale, abs(dw[k]))
    return scale


def fading_steps(J: FloatArray, dw: FloatArray, last: FloatArray, before: FloatArray) -> float:
    """In how many steps the arm's motion ``last`` stops paying, where it pays less each step.

    The motion's gain is how much it reduces the L1 task error towards the
    command, ``sum |dw| - sum |dw - J last|``, against its price in the progress
    step's terms, ``MOTION_WEIGHT sum |last|`` (:mod:`lpik.methods.progress`:
    there a joint moves only while each radian buys that much). Where the
    Jacobian turns along the motion its gain falls: as the arm stretches towards
    the edge of its workspace, where the task Jacobian is singular and beyond
    which the same motion takes the task point back. ``before = J(q_prev) last``
    is the same motion at the last configuration; from its gain there and at
    ``q0`` the gain is extrapolated linearly to where it meets the price. A step
    that then takes the motion there only as fast as it can stop
    (:func:`lpik.bands.fading_band`) does under acceleration limits what the
    progress step does without them: it stops where moving on buys too little,
    instead of coasting past the singular configuration into a pose from which
    no step that reduces the error leads back (benchmarks/quality.py, scenario 2
    with acceleration limits). Plain loops, compiled as they are by the fused step.

    Returns:
        The steps until the gain meets the price (> 0), or ``inf`` where the
        motion does not pay or its gain does not fall by more than rounding
        (:data:`~lpik.tolerances.GAIN_RTOL` of :func:`progress_scale`, as the stall
        stage's ties).
    """
    total, now, then, size = 0.0, 0.0, 0.0, 0.0
    for k in range(J.shape[0]):
        s = 0.0
        for i in range(J.shape[1]):
            s += J[k, i] * last[i]
        total += abs(dw[k])
        now += abs(dw[k] - s)
        then += abs(dw[k] - before[k])
    for i in range(last.shape[0]):
        size += abs(last[i])
    gain, gain_before, price = total - now, total - then, MOTION_WEIGHT * size
    if not (gain > price and gain_before - gain > GAIN_RTOL * progress_scale(dw)):
        return math.inf
    return (gain - price) / (gain_before - gain)


#: The rows of a loop's memory (:func:`plausible_previous`, :func:`hold_step`), (8, n): the
#: last step's ``q0``, its commanded step ``q - q0``, one period of the lower and upper
#: acceleration limits (``qdd_min dt^2``, ``qdd_max dt^2``), the plausible ``q_prev``, one
#: period of the lower and upper velocity limits (``qd_min dt``, ``qd_max dt``), and each
#: joint's verdict on the implied step against them (:func:`lpik.bands.plausible_step`).
HELD_FROM, HELD_STEP, BAND_LOWER, BAND_UPPER, PLAUSIBLE, SPEED_LOWER, SPEED_UPPER, FAULT = range(8)
MEMORY_ROWS = FAULT + 1


def plausible_previous(q0, q_prev, memory):  # type: ignore[no-untyped-def]
    """The ``q_prev`` whose implied step the drives could have made, where it differs.

    ``memory`` (:data:`MEMORY_ROWS`, n) holds the rows :data:`HELD_FROM` to
    :data:`FAULT`. The memory describes the last period where every coordinate
    is finite and either

    - ``q_prev`` is the last step's ``q0`` (a loop that feeds back its readings), or
    - ``q0`` is where the last step sent the arm, to within one period of the
      acceleration limits, that step moved some joint by more, and the state
      does not read as at rest, every joint's implied step ``q0 - q_prev``
      within that band around 0 (a loop whose ``q_prev`` comes from elsewhere,
      e.g. a velocity reading, ``q0 - qd dt``; a last step within the band is
      no evidence that the loop went on, since a query repeated at the same
      ``q0`` looks the same, and an arm that reads as at rest may have been
      stopped while the loop paused, which the memory cannot know).

    Then each joint whose implied step differs from the commanded step by more
    than one period of the acceleration limits is taken at the motion since the
    last ``q0``, ``q0 - q0_last``, clipped to that band (where ``q_prev`` is the
    last ``q0``, that motion is the implied step). The row :data:`PLAUSIBLE` is
    ``q0`` less the step taken, and :data:`FAULT` each joint's verdict on the
    implied step against its velocity limits (:data:`lpik.bands.MET`, or the
    side it was beyond: :func:`lpik.bands.plausible_step`). Returns True where
    some joint's step was clipped (those rows then hold the plausible ``q_prev``
    and the faults it replaced), False where ``q_prev`` stands as it is.

    Why: :mod:`lpik.control.commanded`, whose :class:`~lpik.control.commanded.CommandedMotion`
    holds the memory. Plain loops: the compiled controller runs this function
    itself (:mod:`lpik.fast.commanded`).
    """
    n = memory.shape[1]
    if q0.shape[0] != n or q_prev.shape[0] != n:
        return False
    exact = sent = resting = True
    moving = False
    for i in range(n):
        if not (math.isfinite(q0[i]) and math.isfinite(q_prev[i])):
            return False
        exact = exact and q_prev[i] == memory[HELD_FROM, i]
        # where the arm is against where the last step sent it (NaN: no step answered yet)
        lo, hi, held = memory[BAND_LOWER, i], memory[BAND_UPPER, i], memory[HELD_STEP, i]
        off, implied = q0[i] - memory[HELD_FROM, i] - held, q0[i] - q_prev[i]
        rounding = SLACK_TOL * max(1.0, abs(q0[i]))
        sent = sent and lo - rounding <= off <= hi + rounding
        moving = moving or not lo - rounding <= held <= hi + rounding
        resting = resting and lo - rounding <= implied <= hi + rounding
    if not (exact or (sent and moving and not resting)):
        return False
    clipped = False
    for i in range(n):
        implied, held = q0[i] - q_prev[i], memory[HELD_STEP, i]
        lo, hi = held + memory[BAND_LOWER, i], held + memory[BAND_UPPER, i]
        speed_lo, speed_hi = memory[SPEED_LOWER, i], memory[SPEED_UPPER, i]
        memory[FAULT, i] = plausible_step(implied, speed_lo, speed_hi)[1]
        step = implied
        if not lo <= implied <= hi:  # the motion since the last q0, as the drives could make it
            step = min(max(q0[i] - memory[HELD_FROM, i], lo), hi)
        clipped = clipped or step != implied
        memory[PLAUSIBLE, i] = q0[i] - step
    return clipped


def hold_step(q0, q, memory):  # type: ignore[no-untyped-def]
    """Remember the step just answered in ``memory``: its ``q0`` and the step ``q - q0``.

    Plain loops, compiled as :func:`plausible_previous` is.
    """
    for i in range(memory.shape[1]):
        memory[HELD_FROM, i] = q0[i]
        memory[HELD_STEP, i] = q[i] - q0[i]
