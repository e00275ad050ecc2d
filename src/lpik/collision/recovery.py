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
  finds the largest share of it they can give, and the step takes that share.

The step gives up the direction (``p = 0``) for the distance: the tool still
moves towards its target as far as the rows and bounds allow.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

import numpy as np

from lpik import check
from lpik.highs import HighsSolver, LinearProgram
from lpik.labels import Binding, row_label
from lpik.problem import Problem
from lpik.result import MOVING, OFF_DIRECTION, OPTIMAL, RECOVERING, Result, safe_step
from lpik.tolerances import FEASIBILITY_TOL, STALL_P
from lpik.types import FloatArray

#: The name a recovery step gives as its method and path.
RECOVERY = "recovery"
#: The least-L1-error LP, ``least_error(J, target, lower, upper, G, g) -> (status, dq)``
#: (:func:`lpik.methods.progress.least_error_lp`): ``dq`` minimises
#: ``|J dq - target|_1 + MOTION_WEIGHT |dq|_1`` with ``lower <= dq <= upper``,
#: ``G dq <= g``, where the status is ``"optimal"``.
LeastError = Callable[..., tuple[str, FloatArray]]


def inside_pairs(labels, distances, safety: float) -> dict[str, float]:  # type: ignore[no-untyped-def]
    """The pairs closer than ``safety`` by more than the check's tolerance: label -> distance.

    A pair inside by less than :data:`~lpik.tolerances.FEASIBILITY_TOL` demands an
    increase the check cannot tell from none.
    """
    return {
        str(label): float(d) for label, d in zip(labels, distances) if d < safety - FEASIBILITY_TOL
    }


def inside_rows(problem: Problem, inside: Mapping[str, float]) -> list[int]:
    """The problem's rows whose pair is inside, deepest first."""
    rows = [k for k, label in enumerate(problem.row_labels) if str(label) in inside]
    return sorted(rows, key=lambda k: inside[str(problem.row_labels[k])])


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
    problem: Problem, result: Result, inside: Mapping[str, float], least_error: LeastError
) -> Result:
    """The step from a state with pairs inside the safety distance (the module's rule).

    Args:
        problem: The step's problem, with the distance rows of the ``inside`` pairs.
        result: The method's step on ``problem``.
        inside: The pairs inside ``d_s`` (:func:`inside_pairs`).
        least_error: The least-error LP (:data:`LeastError`).

    Returns:
        ``result`` unchanged where no row of ``problem`` is inside; else ``result``
        marked ``recovering`` (naming the deepest pair) where it keeps the rows and
        the direction (``p > STALL_P``) or is the progress step on these rows;
        else the recovery step (:func:`recovery_step`).
    """
    rows = inside_rows(problem, inside) if inside else []
    if not rows or result.method == RECOVERY:
        return result
    binding = row_label(rows[0], problem.row_labels[rows[0]]).outside()
    if keeps_direction(result) and keeps_rows(problem, result.dq, rows):
        return marked_recovering(result, binding)
    return recovery_step(problem, rows, binding, least_error)


def recovery_step(
    problem: Problem, rows: list[int], binding: str, least_error: LeastError
) -> Result:
    """The least-L1-error step within every bound and row, the ``rows`` demanding their increase.

    Where the bounds cannot give the whole demand of ``rows`` (their ``h - G q0 < 0``),
    the largest share of it that they can (:func:`demand_share`). Status
    ``recovering``, ``p = 0``, ``binding`` the pair; the safe step (``recovering``)
    where no LP answers.
    """
    start = time.perf_counter()
    dq = least_error_step(problem, least_error)
    if dq is None:  # the whole demand is beyond the bounds: take the largest share of it
        share = demand_share(problem, rows)
        if share is not None:
            rhs = problem.h - problem.G @ problem.q0
            h = problem.h.copy()
            h[rows] -= (1.0 - share) * rhs[rows]
            problem = problem.replace(h=h)
            dq = least_error_step(problem, least_error)
    elapsed = time.perf_counter() - start
    if dq is None:
        return safe_step(problem, RECOVERY, RECOVERING, binding, solve_time=elapsed, path=RECOVERY)
    return Result(
        q=problem.q0 + dq, dq=dq, p=0.0, lam=None, status=RECOVERING, binding=binding,
        method=RECOVERY, solve_time=elapsed, residual=float(np.abs(problem.J @ dq).max()),
        path=RECOVERY,
    )  # fmt: skip


def least_error_step(problem: Problem, least_error: LeastError) -> FloatArray | None:
    """``least_error`` on the problem's bounds and rows, or None where it has no step.

    The step is clipped to the bounds and checked (bounds and rows within
    :data:`~lpik.tolerances.FEASIBILITY_TOL`).
    """
    lower, upper = problem.step_bounds()[:2]
    G = problem.G
    status, dq = least_error(problem.J, problem.dw, lower, upper, G, problem.h - G @ problem.q0)
    if status != OPTIMAL:
        return None
    dq = check.clip_to_bounds(problem, np.asarray(dq, dtype=np.float64))
    if not np.isfinite(dq).all() or check.worst_violation(problem, dq).amount > FEASIBILITY_TOL:
        return None
    return dq


def demand_share(problem: Problem, rows: list[int]) -> float | None:
    """The largest share ``s`` in [0, 1] of ``rows``' demand that the bounds and rows allow.

    An LP over ``(dq, s)``: maximise ``s`` with ``G_k dq <= s (h - G q0)_k`` for the
    rows inside and ``G dq <= h - G q0`` for the others. None where not even
    ``s = 0`` holds (a joint braking under its acceleration limits).
    """
    n = problem.n
    lower, upper = problem.step_bounds()[:2]
    rhs = problem.h - problem.G @ problem.q0
    demand = np.zeros(rhs.size)
    demand[rows] = rhs[rows]
    b = rhs - demand
    lp = LinearProgram(
        c=np.concatenate([np.zeros(n), [-1.0]]),
        A=np.hstack([problem.G, -demand[:, None]]),
        row_lower=np.full(b.size, -np.inf), row_upper=b,
        col_lower=np.append(lower, 0.0), col_upper=np.append(upper, 1.0),
    )  # fmt: skip
    sol = HighsSolver().solve(lp)
    if sol.status != OPTIMAL:
        return None
    return float(np.clip(sol.x[n], 0.0, 1.0))
