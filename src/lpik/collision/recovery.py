"""Recovery from inside the safety distance or from penetration: the distance grows back.

A pair closer than the safety distance ``d_s`` (or overlapping) is outside
the limit its distance row keeps, as a joint past its end-stop is outside its
end-stop (:mod:`lpik.bands`). Its row is the velocity damper's, mirrored
(:func:`lpik.collision.avoidance.damper_row`, one rule on each side of
``d_s``)::

    grad . dq >= r (d_s - d),    r = xi dt / (d_i - d_s) <= 1

so that, to first order, ``d_s - d`` shrinks by the share ``r`` each step:
the distance grows back to ``d_s`` smoothly, at the damper's rate, and never
past it. Every step from such a state has status ``recovering`` and names the
deepest pair (its row's label, e.g. ``"collision panda_link4 - ball"``,
marked recovering), as a recovery from past an end-stop names the end-stop:

* where the method's step keeps the commanded direction (``p > 0``) and the
  rows, it is that step (the other joints carry out ``p dw``);
* else (no step keeps the rows at ``p = 0``, or ``p`` at most
  :data:`~lpik.tolerances.STALL_P`: the direction is frozen) it is the
  *recovery step*: the least L1 task error ``sum |J dq - dw|`` within every
  bound and row, the distance rows hard (the progress step's LP, after Ho's
  LP of paper sec. 2.3: :func:`lpik.methods.progress.least_error_lp` or
  :func:`lpik.fast.progress.least_error_step`, which the caller passes as
  ``least_error``). A progress step of the stall stage on the same rows
  (``off_direction``) is that step already, and is kept. Where the joints'
  bounds (eqs. 13-14) cannot give the whole demanded increase, a first LP
  finds the largest share of it they can give, and the step takes that share;
* where that share is at most :data:`~lpik.tolerances.STALL_P` (the pairs'
  gradients contradict each other, or the acceleration limits carry the arm
  deeper whatever the step), the *restoration*: the step of least total
  penetration (:func:`restoration`), then the least task error with each
  pair held to what that step gives it.

The step gives up the direction (``p = 0``) for the distance: the tool still
moves towards its target as far as the rows and bounds allow.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import replace

import numpy as np

from lpik.highs import HighsSolver, LinearProgram
from lpik.labels import COLLISION, Binding, row_label
from lpik.problem import Problem
from lpik.result import MOVING, OFF_DIRECTION, OPTIMAL, RECOVERING, Result, safe_step
from lpik.tolerances import FEASIBILITY_TOL, STALL_P
from lpik.types import FloatArray

#: The name a recovery step gives as its method and path.
RECOVERY = "recovery"
#: A bound beyond this [rad or m] counts as this when :func:`stop_within_rows` asks which
#: rows a step within the bounds can reach (an infinite one times a row's 0 is no number).
REACH = 1e100
#: The least-L1-error LP, ``least_error(J, target, lower, upper, G, g) -> (status, dq)``
#: (:func:`lpik.methods.progress.least_error_lp`): ``dq`` minimises
#: ``|J dq - target|_1 + MOTION_WEIGHT |dq|_1`` with ``lower <= dq <= upper``,
#: ``G dq <= g``, where the status is ``"optimal"``.
LeastError = Callable[..., tuple[str, FloatArray]]
#: The largest-share LP, ``largest_share(G, b, demand, lower, upper) -> s or None``
#: (:func:`highs_largest_share`; compiled: :func:`lpik.fast.progress.largest_share_lp`).
LargestShare = Callable[..., "float | None"]


def inside_pairs(labels, distances, safety: float) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """The pairs closer than ``safety`` by more than the check's tolerance: label -> distance.

    A pair inside by less than :data:`~lpik.tolerances.FEASIBILITY_TOL` demands an
    increase the check cannot tell from none. Where a label names several pairs (a link
    of several capsules), its distance is the smallest.
    """
    inside: dict[str, float] = {}
    distances = np.asarray(distances, dtype=np.float64)
    limit = safety - FEASIBILITY_TOL
    if not distances.size or distances.min() >= limit:  # most steps: none (a step's cost)
        return inside
    for k in (distances < limit).nonzero()[0]:
        label = labels[k]  # the label itself kept: a Binding names the pair
        inside[label] = min(float(distances[k]), inside.get(label, math.inf))
    return inside


def inside_rows(problem: Problem, inside: Mapping[str, float]) -> list[int]:
    """The problem's rows that demand an increase of an inside pair's distance, deepest first."""
    G = problem.G
    return demanding_rows(problem.row_labels, G, problem.h - G @ problem.q0, inside)


def demanding_rows(labels, G: FloatArray, g: FloatArray, inside: Mapping[str, float]) -> list[int]:  # type: ignore[no-untyped-def]
    """The rows ``G dq <= g`` of the ``inside`` pairs that demand an increase (``g < 0``).

    A label may name several rows (a link of several capsules, one row per capsule
    pair): only those of pairs inside ``d_s`` demand (their ``g``, the mirrored
    damper's ``r (d - d_s)``, is negative); the others are the ordinary rows, and a
    reserved row with no pair in reach (``0 dq <= INACTIVE_RHS``) demands nothing.
    Deepest first by the pair's distance (ties in the rows' order).
    """
    active = np.abs(G).max(axis=1, initial=0.0) > 0.0
    rows = [k for k, label in enumerate(labels) if label in inside and g[k] < 0 and active[k]]
    return sorted(rows, key=lambda k: inside[labels[k]])


def keeps_rows(problem: Problem, dq: FloatArray, rows: list[int]) -> bool:
    """Whether ``dq`` keeps the given rows ``G dq <= h - G q0`` (within the check's tolerance)."""
    G = problem.G[rows]
    return rows_kept(G, problem.h[rows] - G @ problem.q0, dq)


def rows_kept(G: FloatArray, rhs: FloatArray, dq: FloatArray) -> bool:
    """Whether ``G dq <= rhs`` within :data:`~lpik.tolerances.FEASIBILITY_TOL` (relative)."""
    return bool(np.all(G @ dq - rhs <= FEASIBILITY_TOL * np.maximum(1.0, np.abs(rhs))))


def keeps_direction(result: Result) -> bool:
    """Whether the recovery may keep ``result`` (where it keeps the rows too).

    A step that moves and keeps the commanded direction (``p`` above
    :data:`~lpik.tolerances.STALL_P`), or the stall stage's progress step
    (``off_direction``), which is the recovery step's LP on the same rows already.
    """
    return result.status in MOVING and (result.p > STALL_P or result.status == OFF_DIRECTION)


def marked_recovering(result: Result, binding: Binding) -> Result:
    """``result`` with status ``recovering`` naming ``binding``, the deepest pair.

    A step already ``recovering`` (from outside another limit, an end-stop) keeps its name.
    """
    if result.status == RECOVERING:
        return result
    return Result(q=result.q, dq=result.dq, p=result.p, lam=result.lam, status=RECOVERING,
                  binding=binding, method=result.method, solve_time=result.solve_time,
                  residual=result.residual, path=result.path)  # fmt: skip


def recovered(
    problem: Problem,
    result: Result,
    inside: Mapping[str, float],
    least_error: LeastError,
    largest_share: LargestShare | None = None,
) -> Result:
    """The step from a state with pairs inside the safety distance (the module's rule).

    Args:
        problem: The step's problem, with the distance rows of the ``inside`` pairs.
        result: The method's step on ``problem``.
        inside: The pairs inside ``d_s`` (:func:`inside_pairs`).
        least_error: The least-error LP (:data:`LeastError`).
        largest_share: The largest-share LP (:data:`LargestShare`; None: HiGHS's).

    Returns:
        ``result`` unchanged where no pair is inside; ``result`` marked ``recovering``
        where no row of an inside pair demands an increase (:func:`unmovable`); else
        ``result`` marked ``recovering`` (naming the deepest pair) where it keeps the rows and
        the direction (``p > STALL_P``) or is the progress step on these rows;
        else the recovery step (:func:`recovery_step`).
    """
    if not inside or result.method == RECOVERY:
        return result
    rows = inside_rows(problem, inside)
    if not rows:  # no joint moves the pairs apart: the step as it is, and why it is inside
        return unmovable(result, inside)
    binding = row_label(rows[0], problem.row_labels[rows[0]]).outside()
    if keeps_direction(result) and keeps_rows(problem, result.dq, rows):
        return marked_recovering(result, binding)
    return recovery_step(problem, rows, binding, least_error, largest_share)


def unmovable(result: Result, inside: Mapping[str, float]) -> Result:
    """``result`` marked ``recovering``, naming the deepest pair, where no row can recover.

    A pair inside ``d_s`` whose distance no joint changes (its closest point on the
    axes of the first joints, where the gradient is 0, e.g. a ball at the Panda's
    shoulder) has no row: no step moves it apart, and the step is the method's. It is
    still inside, and the status says so (the binding has no row index: the pair has
    no row on any path).
    """
    deepest = min(inside, key=lambda label: inside[label])
    return marked_recovering(result, row_label(None, deepest, COLLISION).outside())


def recovery_step(
    problem: Problem, rows: list[int], binding: str, least_error: LeastError,
    largest_share: LargestShare | None = None,
) -> Result:  # fmt: skip
    """The least-L1-error step within every bound and row, the ``rows`` demanding their increase.

    :func:`recovery_motion` on the problem's bounds (eqs. 13-14) and rows. Status
    ``recovering``, ``p = 0``, ``binding`` the pair; the safe step (``recovering``)
    where no LP answers.
    """
    start = time.perf_counter()
    lower, upper = problem.step_bounds()[:2]
    G = problem.G
    dq = recovery_motion(problem.J, problem.dw, lower, upper, G, problem.h - G @ problem.q0, rows,
                         least_error, largest_share or highs_largest_share)  # fmt: skip
    elapsed = time.perf_counter() - start
    if dq is None:
        return safe_step(problem, RECOVERY, RECOVERING, binding, solve_time=elapsed, path=RECOVERY)
    return recovery_result(problem.q0, dq, problem.J, binding, elapsed)


def recovery_motion(
    J: FloatArray, dw: FloatArray, lower: FloatArray, upper: FloatArray, G: FloatArray,
    g: FloatArray, rows: list[int], least_error: LeastError, largest_share: LargestShare,
) -> FloatArray | None:  # fmt: skip
    """The recovery step's ``dq`` on the step's arrays, or None where no LP answers.

    The least-L1-error step (``least_error``) within ``lower <= dq <= upper`` and
    ``G dq <= g``; where the bounds cannot give the whole demand of ``rows``
    (their ``g < 0``), the largest share ``s`` of it that they can
    (``largest_share``), and the least-error step with those rows at ``s g``. The
    one rule for the step's problem (:func:`recovery_step`) and for the arrays a
    compiled step leaves in its state (:func:`lpik.fast.progress.state_rows`).
    """
    dq = least_error_within(J, dw, lower, upper, G, g, least_error)
    if dq is not None:
        return dq
    demand = np.zeros(g.size)
    demand[rows] = g[rows]
    share = largest_share(G, g - demand, demand, lower, upper)
    if share is not None and share > STALL_P:
        dq = least_error_within(J, dw, lower, upper, G, g - (1.0 - share) * demand, least_error)
        if dq is not None:
            return dq
    restored = restoration(G, g, lower, upper, rows, least_error)
    if restored is None:
        return None
    relaxed, dq = restored
    again = least_error_within(J, dw, lower, upper, G, relaxed, least_error)
    return dq if again is None else again


def restoration(
    G: FloatArray, g: FloatArray, lower: FloatArray, upper: FloatArray, rows: list[int],
    least_error: LeastError,
) -> tuple[FloatArray, FloatArray] | None:  # fmt: skip
    """The step of least total penetration and the right-hand sides it relaxes ``rows`` to.

    Where no step moves every pair of ``rows`` apart by a share of their demand above
    :data:`~lpik.tolerances.STALL_P` (their distance gradients contradict each other,
    or the joints' acceleration limits carry them deeper whatever the step), the rows
    are met in the least-L1 sense instead, as the feasibility restoration of SQP
    solvers meets violated constraints: ``dq`` minimises ``sum_rows |G_k dq - g_k|``
    (the rows' demands as a task, by the same least-error LP) within the bounds and
    the other rows, and each row is then held to what that step gives it,
    ``G_k dq <= max(g_k, G_k dq)``: a pair may go deeper by what lets the others come
    apart by more. Returns ``(relaxed right-hand sides, dq)``, or None where no step
    keeps the bounds and the other rows.
    """
    others = np.setdiff1d(np.arange(g.size), rows)
    status, dq = least_error(G[rows], g[rows], lower, upper, G[others], g[others])
    if status != OPTIMAL:
        return None
    dq = np.clip(np.asarray(dq, dtype=np.float64), lower, upper)
    if not np.isfinite(dq).all() or not rows_kept(G[others], g[others], dq):
        return None
    relaxed = g.copy()
    relaxed[rows] = np.maximum(g[rows], G[rows] @ dq)
    return relaxed, dq


def least_error_within(
    J: FloatArray, dw: FloatArray, lower: FloatArray, upper: FloatArray, G: FloatArray,
    g: FloatArray, least_error: LeastError,
) -> FloatArray | None:  # fmt: skip
    """``least_error`` on these bounds and rows, or None where it has no step.

    The step is clipped to the bounds and checked (bounds and rows within
    :data:`~lpik.tolerances.FEASIBILITY_TOL`, relative to ``max(1, |bound|)``, as
    :func:`lpik.check.worst_violation` checks them).
    """
    status, dq = least_error(J, dw, lower, upper, G, g)
    if status != OPTIMAL:
        return None
    dq = np.clip(np.asarray(dq, dtype=np.float64), lower, upper)
    if not np.isfinite(dq).all() or not rows_kept(G, g, dq):
        return None
    with np.errstate(invalid="ignore"):  # an infinite bound: no excess
        crossed = lower - dq > FEASIBILITY_TOL * np.maximum(1.0, np.abs(lower))
    return None if crossed.any() else dq  # bounds that cross (lower > upper) hold no step


def recovery_result(
    q0: FloatArray, dq: FloatArray, J: FloatArray, binding: str, solve_time: float
) -> Result:
    """A recovery step's Result: ``recovering``, ``p = 0``, naming the pair."""
    return Result(
        q=q0 + dq, dq=dq, p=0.0, lam=None, status=RECOVERING, binding=binding,
        method=RECOVERY, solve_time=solve_time, residual=float(np.abs(J @ dq).max()),
        path=RECOVERY,
    )  # fmt: skip


def stop_within_rows(
    dq: FloatArray, lower: FloatArray, upper: FloatArray, G: FloatArray, g: FloatArray,
    least_error: LeastError, largest_share: LargestShare,
) -> FloatArray | None:  # fmt: skip
    """The step nearest to ``dq`` that keeps the rows ``G dq <= g``, where ``dq`` breaks one.

    The safe step is a controlled stop, ``0`` clipped to the joints' bands
    (:func:`lpik.result.safe_step`); it knows nothing of the rows. Under acceleration
    limits the braking joints can carry a link towards an obstacle faster than its
    damper row allows (the rows are a limit too): a Panda under the shelf, its
    command through the shelf's top and no exact step, braked towards it 88 steps in
    a row, up to 0.26 mm per step, and came inside ``d_s``. The stop that keeps
    them is the step within the bounds of least ``|dq' - dq|_1`` (plus
    :data:`~lpik.tolerances.MOTION_WEIGHT` ``|dq'|_1``, the least-error LP with the
    identity as its task, so that the joints brake where the rows let them);
    where no step within the bounds keeps them (the acceleration limits carry the
    pairs on), the least worst excess: with ``e`` the largest excess of ``dq`` over
    a row, the largest share ``s`` of ``e`` that the bounds let every row it breaks
    take back (``largest_share``; the rows it keeps stay kept), and the step nearest
    to ``dq`` within those rows relaxed to ``g + (1 - s) e``. (Each row's own
    excess, taken back by the same share, left two rows that a joint's motion
    trades against each other at their excess: share 0.)

    Args:
        dq: The step, within ``lower <= dq <= upper``.
        lower: The step's lower bounds (eqs. 13-14 after :mod:`lpik.bands`).
        upper: Its upper bounds.
        G: The rows' matrix, ``G dq <= g`` (distance rows, a user's rows).
        g: Their right-hand sides.
        least_error: The least-error LP (:data:`LeastError`).
        largest_share: The largest-share LP (:data:`LargestShare`).

    Returns:
        The step, or None where ``dq`` keeps the rows (or no LP answers: ``dq`` stands).
    """
    if not g.size:
        return None
    excess = G @ dq - g
    broken = excess > FEASIBILITY_TOL * np.maximum(1.0, np.abs(g))
    if not broken.any():
        return None
    far = np.where(G > 0.0, np.minimum(upper, REACH), np.maximum(lower, -REACH))
    rows = (G * far).sum(axis=1) > g  # a row no step within the bounds reaches binds nothing
    G, g, excess, broken = G[rows], g[rows], excess[rows], broken[rows]
    identity = np.eye(dq.size)
    kept = least_error_within(identity, dq, lower, upper, G, g, least_error)
    if kept is not None:
        return kept
    held = g + np.where(broken, 0.0, np.maximum(excess, 0.0))  # the others, as dq keeps them
    demand = np.where(broken, -excess.max(), 0.0)  # the broken rows' worst excess, taken back
    share = largest_share(G, held - demand, demand, lower, upper)
    if share is None or share <= 0.0:
        return None
    return least_error_within(identity, dq, lower, upper, G, held - (1.0 - share) * demand,
                              least_error)  # fmt: skip


def is_stop(result: Result) -> bool:
    """Whether ``result`` is a stop that may break a row.

    A safe step (a status outside ``MOVING``, or ``recovering`` at ``p = 0``), not the
    recovery's own step.
    """
    if result.p != 0.0 or result.method == RECOVERY:
        return False
    return result.status not in MOVING or result.status == RECOVERING


def kept_within_rows(
    result: Result, q0: FloatArray, J: FloatArray, lower: FloatArray, upper: FloatArray,
    G: FloatArray, g: FloatArray, least_error: LeastError, largest_share: LargestShare,
) -> Result:  # fmt: skip
    """The rows stage: a stop that breaks one of the step's rows, moved within them.

    ``result`` as it is where it keeps the rows ``G dq <= g`` and where it is no
    stop: an LP's step (``p > 0``, ``optimal``, ``off_direction``, ``scaled``), which
    holds them, a classical step (``violates_limits``, which reports what it
    breaks) or the recovery's own (which relaxes the rows inside ``d_s`` itself);
    else its stop becomes :func:`stop_within_rows`'s, with the same status and
    binding. The one rule for the numpy engine
    (:meth:`lpik.control.stepper.Stepper.within_rows`) and the compiled one, on the
    arrays its step left in its state.
    """
    if not is_stop(result):
        return result
    start = time.perf_counter()
    dq = stop_within_rows(np.asarray(result.dq, dtype=np.float64), lower, upper, G, g,
                          least_error, largest_share)  # fmt: skip
    if dq is None:
        return result
    return replace(result, q=q0 + dq, dq=dq, residual=float(np.abs(J @ dq).max(initial=0.0)),
                   solve_time=result.solve_time + time.perf_counter() - start)  # fmt: skip


def highs_largest_share(
    G: FloatArray, b: FloatArray, demand: FloatArray, lower: FloatArray, upper: FloatArray
) -> float | None:
    """The largest share ``s`` in [0, 1] of ``demand`` that the bounds and rows allow (HiGHS).

    An LP over ``(dq, s)``: maximise ``s`` with ``G dq - s demand <= b`` and
    ``lower <= dq <= upper`` (``demand``: the rows inside, ``h - G q0``, 0 elsewhere;
    ``b``: the right-hand sides less the demand). None where not even ``s = 0``
    holds (a joint braking under its acceleration limits).
    """
    n = G.shape[1]
    lp = LinearProgram(
        c=np.concatenate([np.zeros(n), [-1.0]]),
        A=np.hstack([G, -demand[:, None]]),
        row_lower=np.full(b.size, -np.inf), row_upper=b,
        col_lower=np.append(lower, 0.0), col_upper=np.append(upper, 1.0),
    )  # fmt: skip
    sol = HighsSolver().solve(lp)
    if sol.status != OPTIMAL:
        return None
    return float(np.clip(sol.x[n], 0.0, 1.0))
