"""Schlemmer's LP with respect to affine manipulability (LP1, eqs. 11-14)."""

from __future__ import annotations

import time

import numpy as np

from lpik.continuation import around_motion
from lpik.highs import HighsSolver
from lpik.methods.assembly import finish, lp_over, solver_for, unsolved_step
from lpik.methods.duals import binding_from_duals
from lpik.problem import Problem
from lpik.result import OPTIMAL, Result


@around_motion
def lp1(problem: Problem, *, solver: HighsSolver | None = None) -> Result:
    """Maximise the affine dexterity p subject to the linearised kinematics (LP1).

    Implements eqs. 11-14: ``max p`` subject to ``J (q - q0) - p dw = 0`` (eq. 12),
    ``0 <= p <= 1`` and the end-stops (eq. 13), the per-step velocity or
    acceleration bounds (eq. 14) and the problem's extra rows ``G q <= h``.
    Redundancy is not resolved: any optimal vertex may be returned, which is
    why LP1's joint motion jitters (paper, sec. 2.3). ``M``, ``f``, ``Lambda``
    and the multiplier bounds are ignored; ``lam`` is ``None``.

    Args:
        problem: The step to solve.
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across steps (warm start).

    Returns:
        The step, with ``binding`` naming the limit with the largest dual when
        ``p < 1``, or the limit in conflict when no step is feasible
        (:func:`~lpik.methods.duals.conflict_label`).
    """
    start = time.perf_counter()
    n, lower, upper = problem.n, *problem.step_bounds()[:2]
    A_eq = np.hstack([problem.J, -problem.dw[:, None]])
    c = np.zeros(n + 1)
    c[-1] = -1.0
    lp = lp_over(
        problem, c, A_eq, np.zeros(problem.m), np.append(lower, 0.0), np.append(upper, 1.0)
    )
    sol = solver_for(solver).solve(lp)
    if sol.status != OPTIMAL:
        return unsolved_step(problem, "lp1", sol.status, A_eq, np.zeros(problem.m), 0, start)
    p = float(sol.x[-1])
    binding = binding_from_duals(problem, sol, lp, p, problem.m)
    return finish(problem, "lp1", sol.x[:n], p, None, binding, start, "highs")
