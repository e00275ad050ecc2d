"""The progress step: the motion that most reduces the task error within every limit.

LP1, LP2 and LP2 with saturation keep the commanded direction exactly
(``J dq = p dw``). From some states that direction is not available at all
(a joint at its end-stop near a singular configuration): every step returns
``p = 0`` (or nearly) although the error could still be reduced. The progress
step gives up the direction for progress: the least-L1 task error (as Ho's LP
minimises the L1 norm of the joint step, paper sec. 2.3)::

    minimise  sum_k |J dq - dw|_k + MOTION_WEIGHT sum_i |dq_i|   within every bound and row;

the small second term picks, among the steps of least error, one of least
motion (without it the LP's vertex choice makes the joints jitter).

Two uses, one LP (:func:`least_error_lp` here through HiGHS,
:func:`lpik.fast.progress.least_error_step` compiled, held equal by tests):

- **the stall stage** (``on_stall``, opt-in: ``on_stall=1`` turns it on; the
  default, :data:`lpik.defaults.DEFAULT_ON_STALL`, is ``None``, the paper's strict
  steps): once the step has stalled (:func:`is_stall`) for ``on_stall`` steps in a
  row, :func:`progress_step` replaces it, with the status ``off_direction`` and
  ``p = 0``, so that the operator knows that the tool moved but not along the
  command. Not the default: with a target beyond reach the least-L1 step jumps
  between vertices (measured: far more joint jitter than the strict step), and
  under acceleration limits a start from rest reads as a stall;
- **``mode="progress"``**: after every exact step with ``p < 1``,
  :func:`further_step` spends what the limits leave on the error that remains
  (status ``off_direction``, ``p`` the exact step's).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from lpik import check
from lpik.highs import HighsSolver, LinearProgram
from lpik.methods.assembly import solver_for
from lpik.problem import Problem
from lpik.result import CHECK_FAILED, OFF_DIRECTION, OPTIMAL, Result, safe_step
from lpik.tolerances import EQUALITY_RTOL, FEASIBILITY_TOL, STALL_P
from lpik.types import FloatArray

#: Weight of the joint motion ``sum |dq_i|`` against the task error in the progress step
#: [m (or rad) of error per rad of motion]: a joint moves only where each radian buys at
#: least 1 cm (10 mrad) less error. Where the error can hardly shrink (a target beyond
#: reach) the LP's optimum otherwise jumps between vertices, the joints at their velocity
#: limits one way and then the other: at 1e-6 the quality suite's scenario 2 with the
#: stage on had a joint-velocity jitter of 26,440 rad/s, at 1e-2 3,207 (strict: 447).
MOTION_WEIGHT = 1e-2


def least_error_lp(
    J: FloatArray, target: FloatArray, lower: FloatArray, upper: FloatArray,
    G: FloatArray, g: FloatArray, solver: HighsSolver | None = None,
) -> tuple[str, FloatArray]:  # fmt: skip
    """``min |J dq - target|_1 + MOTION_WEIGHT |dq|_1``, ``lower <= dq <= upper``, ``G dq <= g``.

    The LP of the module docstring through HiGHS: variables ``(dq, t, u)`` with
    ``t >= +-(J dq - target)`` and ``u >= +-dq``. Returns the solve's status and ``dq``.
    """
    m, n = J.shape
    r = G.shape[0]
    eye, zeros = np.eye(n), np.zeros
    A = np.block([
        [J, -np.eye(m), zeros((m, n))],
        [-J, -np.eye(m), zeros((m, n))],
        [eye, zeros((n, m)), -eye],
        [-eye, zeros((n, m)), -eye],
        [G, zeros((r, m + n))],
    ])  # fmt: skip
    lp = LinearProgram(
        c=np.concatenate([zeros(n), np.ones(m), np.full(n, MOTION_WEIGHT)]), A=A,
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


def is_stall(p: float, along: Callable[[], float]) -> bool:
    """Whether a step stalls: ``p <= STALL_P`` and ``along() <= STALL_P``.

    ``along()`` is the task motion's share of the command, :func:`share_along`
    (asked only when ``p`` is small). See :data:`lpik.tolerances.STALL_P`.
    """
    return p <= STALL_P and along() <= STALL_P


def share_along(J: FloatArray, dw: FloatArray, dq: FloatArray) -> float:
    """``dw . J dq / |dw|^2``: the share of the command the step's task motion follows.

    1 where there is no command (``dw = 0``): nothing to follow, no stall.
    """
    size = float(dw @ dw)
    return 1.0 if size == 0.0 else float(dw @ (J @ dq)) / size


def progress_step(problem: Problem, *, solver: HighsSolver | None = None) -> Result:
    """The step of least L1 task error ``sum |J dq - dw|`` within every limit (an LP).

    Args:
        problem: The step; ``dw`` is the command whose error is reduced.
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across steps.

    Returns:
        Status ``off_direction`` and ``p = 0`` (the direction is not kept) when the
        step reduces the error; ``residual`` is ``max |J dq - dw|``, what remains of
        the command. The safe step (status of the solve) when the LP fails; a
        no-progress answer is returned as the safe step with status ``optimal``
        and binding ``"no progress"``.
    """
    start = time.perf_counter()
    lower, upper = problem.step_bounds()[:2]
    G = problem.G
    status, dq = least_error_lp(problem.J, problem.dw, lower, upper, G, problem.h - G @ problem.q0,
                                solver)  # fmt: skip
    before = float(np.abs(problem.dw).sum())
    return _checked(problem, status, dq, before, 0.0, None, start)


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
    binding: str | None, start: float,
) -> Result:  # fmt: skip
    """The progress LP's answer, checked: ``off_direction``, or the safe step saying why not."""
    elapsed = time.perf_counter() - start
    if status != OPTIMAL:
        return safe_step(problem, "progress", status, solve_time=elapsed, path="highs")
    violation = check.worst_violation(problem, dq)
    if violation.amount > FEASIBILITY_TOL or not np.isfinite(dq).all():
        return safe_step(problem, "progress", CHECK_FAILED, violation.label,
                         solve_time=elapsed, path="highs")  # fmt: skip
    result = progress_result(problem.q0, dq, problem.J, problem.dw, before, p, binding,
                             elapsed, "highs")  # fmt: skip
    if result.status != OFF_DIRECTION:
        return safe_step(problem, "progress", OPTIMAL, "no progress", solve_time=elapsed,
                         path="highs")  # fmt: skip
    return result


def progress_result(
    q0: FloatArray, dq: FloatArray, J: FloatArray, dw: FloatArray, before: float, p: float,
    binding: str | None, elapsed: float, path: str,
) -> Result:  # fmt: skip
    """The progress step as a Result (every path): ``off_direction`` where it gains.

    ``before`` is the L1 task error without it (``sum |dw|``, or the exact step's).
    A gain within :data:`~lpik.tolerances.EQUALITY_RTOL` of ``max(1, |dw|)`` is none:
    status ``optimal``, binding ``"no progress"``, ``dq`` as given.
    """
    after = l1_error(J, dw, dq)
    scale = max(1.0, float(np.abs(dw).max())) if dw.size else 1.0
    if before - after <= EQUALITY_RTOL * scale:
        return Result(q=q0 + dq, dq=dq, p=p, lam=None, status=OPTIMAL, binding="no progress",
                      method="progress", solve_time=elapsed, path=path)  # fmt: skip
    return Result(
        q=q0 + dq, dq=dq, p=p, lam=None, status=OFF_DIRECTION, binding=binding,
        method="progress", solve_time=elapsed,
        residual=float(np.abs(J @ dq - dw).max()) if dw.size else 0.0, path=path,
    )  # fmt: skip


class StallWatch:
    """Counts stalled steps (:func:`is_stall`) in a row and says when to take the progress step.

    Args:
        after: Stalled steps in a row before the progress step is taken
            (``None``: never, the paper's strict steps).
    """

    def __init__(self, after: int | None) -> None:
        if after is not None and not (isinstance(after, int | np.integer) and after >= 1):
            raise ValueError(
                f"on_stall: must be a whole number of steps >= 1 or None, got {after!r}"
            )
        self.after = None if after is None else int(after)
        self.run = 0

    def stalls(self, result: Result, along: Callable[[], float]) -> bool:
        """Count ``result`` (``along()``: :func:`share_along` of its step).

        Returns:
            True when the progress step is due.
        """
        if self.after is None:
            return False
        self.run = self.run + 1 if is_stall(result.p, along) else 0
        return self.run >= self.after

    def clear(self) -> None:
        """A step that did not stall: the count starts again."""
        self.run = 0

    def check(self, result: Result, problem_of: Callable[[], Problem]) -> Result:
        """``result``, or the progress step (HiGHS) once the step has stalled ``after`` times.

        ``problem_of()`` builds the step's :class:`~lpik.problem.Problem` (only when needed).
        """
        problem: list[Problem] = []

        def along() -> float:
            problem.append(problem_of())
            return share_along(problem[0].J, problem[0].dw, result.dq)

        if not self.stalls(result, along):
            return result
        progress = progress_step(problem[0] if problem else problem_of())
        return progress if progress.status == OFF_DIRECTION else result
