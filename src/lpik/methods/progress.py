"""The progress step: the motion that most reduces the task error within every limit.

LP1, LP2 and LP2 with saturation keep the commanded direction exactly
(``J dq = p dw``). From some states that direction is not available at all
(a joint at its end-stop near a singular configuration): every step returns
``p = 0`` although the error could still be reduced. The progress step gives
up the direction for progress: the least-L1 task error (as Ho's LP minimises
the L1 norm of the joint step, paper sec. 2.3)::

    minimise  sum_k |J dq - dw|_k + MOTION_WEIGHT sum_i |dq_i|   within every bound and row;

the small second term picks, among the steps of least error, one of least
motion (without it the LP's vertex choice makes the joints jitter).

It is an opt-in (``on_stall=`` of :func:`lpik.control.simulate.simulate` and
:class:`~lpik.control.controller.Lp2Controller`): used only once ``p = 0`` has
persisted, with the status ``off_direction`` so that the operator knows that
the tool moved but not along the command. The trade-off: the paper's exact
direction (no motion) against progress (motion off the line).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from lpik import check
from lpik.highs import HighsSolver
from lpik.methods.assembly import lp_over, solver_for
from lpik.problem import Problem
from lpik.result import CHECK_FAILED, OFF_DIRECTION, OPTIMAL, Result, safe_step
from lpik.tolerances import EQUALITY_RTOL, FEASIBILITY_TOL

#: Weight of the joint motion ``sum |dq_i|`` against the task error in the progress step.
MOTION_WEIGHT = 1e-6


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
    n, m = problem.n, problem.m
    lower, upper = problem.step_bounds()[:2]
    # variables (dq, t, u): t >= +-(J dq - dw), u >= +-dq
    c = np.concatenate([np.zeros(n), np.ones(m), np.full(n, MOTION_WEIGHT)])
    eye, zeros = np.eye(n), np.zeros
    A_ub = np.block([
        [problem.J, -np.eye(m), zeros((m, n))],
        [-problem.J, -np.eye(m), zeros((m, n))],
        [eye, zeros((n, m)), -eye],
        [-eye, zeros((n, m)), -eye],
    ])  # fmt: skip
    b_ub = np.concatenate([problem.dw, -problem.dw, zeros(2 * n)])
    lp = lp_over(problem, c, zeros((0, 2 * n + m)), zeros(0),
                 np.concatenate([lower, zeros(m + n)]),
                 np.concatenate([upper, np.full(m + n, np.inf)]), A_ub, b_ub)  # fmt: skip
    sol = solver_for(solver).solve(lp)
    elapsed = time.perf_counter() - start
    if sol.status != OPTIMAL:
        return safe_step(problem, "progress", sol.status, solve_time=elapsed, path="highs")
    dq = check.clip_to_bounds(problem, sol.x[:n])
    before = float(np.abs(problem.dw).sum())
    after = float(np.abs(problem.J @ dq - problem.dw).sum())
    scale = max(1.0, float(np.abs(problem.dw).max()))
    violation = check.worst_violation(problem, dq)
    if violation.amount > FEASIBILITY_TOL or not np.isfinite(dq).all():
        return safe_step(problem, "progress", CHECK_FAILED, violation.label,
                         solve_time=elapsed, path="highs")  # fmt: skip
    if before - after <= EQUALITY_RTOL * scale:
        return safe_step(problem, "progress", OPTIMAL, "no progress", solve_time=elapsed,
                         path="highs")  # fmt: skip
    return Result(
        q=problem.q0 + dq,
        dq=dq,
        p=0.0,
        lam=None,
        status=OFF_DIRECTION,
        binding=None,
        method="progress",
        solve_time=elapsed,
        residual=float(np.abs(problem.J @ dq - problem.dw).max()),
        path="highs",
    )


class StallWatch:
    """Counts steps with ``p = 0`` in a row and says when to take the progress step.

    Args:
        after: Steps with ``p = 0`` in a row before the progress step is taken
            (``None``: never, the default of every loop).
    """

    def __init__(self, after: int | None) -> None:
        if after is not None and not (isinstance(after, int | np.integer) and after >= 1):
            raise ValueError(f"on_stall: must be a whole number of steps >= 1, got {after!r}")
        self.after = after
        self.run = 0

    def check(self, result: Result, problem_of: Callable[[], Problem]) -> Result:
        """``result``, or the progress step when ``p = 0`` has lasted ``after`` steps.

        ``problem_of()`` builds the step's :class:`~lpik.problem.Problem` (only when needed).
        """
        if self.after is None:
            return result
        self.run = self.run + 1 if result.p == 0.0 else 0
        if self.run < self.after:
            return result
        progress = progress_step(problem_of())
        return progress if progress.status == OFF_DIRECTION else result
