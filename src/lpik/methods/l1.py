"""Ho's LP: the least-L1 joint step (paper sec. 2.3, ref. [11])."""

from __future__ import annotations

import time

import numpy as np

from lpik import check
from lpik.continuation import around_motion
from lpik.highs import HighsSolver
from lpik.methods.assembly import finish, lp_over, solver_for
from lpik.methods.lp1 import lp1
from lpik.problem import Problem
from lpik.result import INFEASIBLE, OPTIMAL, SCALED, Result, safe_step
from lpik.tolerances import FULL_P, NO_CHANGE_P, SCALED_P_MARGIN

#: The methods whose step holds the criterion's optimality conditions as rows (eqs. 15-18):
#: where those admit no step within the limits, the controller's criterion stage
#: (:meth:`lpik.control.stepper.Stepper.scaled`) takes :func:`l1`'s step instead.
CRITERION_METHODS = ("lp2", "lp2s")


def past_criterion(result: Result) -> bool:
    """Whether the criterion stage solves Ho's LP after ``result``: an LP2 step with no answer.

    ``infeasible``: LP2's conditions admit no step within the limits (the safe step).
    """
    return result.status == INFEASIBLE and result.method in CRITERION_METHODS


def changes_motion(p):  # type: ignore[no-untyped-def]
    """Whether a step with ``p`` above :data:`~lpik.tolerances.NO_CHANGE_P` moves along the command.

    At or below it, Ho's LP past the full displacement changes the motion toward the
    command by rounding only: the criterion stage keeps the safe step (or the
    controlled stop), as :func:`lpik.continuation.resumed` does. Plain: compiled as it is.
    """
    return p > NO_CHANGE_P


def scaled_status(largest_p: float) -> str:
    """The status of Ho's LP past the full displacement, from LP1's largest ``p``.

    ``optimal`` where that is the full displacement (:data:`~lpik.tolerances.FULL_P`),
    else ``scaled``: :func:`l1`'s and the compiled criterion stage's
    (:meth:`lpik.control.controller.Lp2Controller._scaled`).
    """
    return OPTIMAL if largest_p >= FULL_P else SCALED


@around_motion
def l1(problem: Problem, *, solver: HighsSolver | None = None) -> Result:
    """Minimise ``||q - q0||_1`` subject to the linearised kinematics (eq. 2) and the limits.

    Ho's formulation asks for the full displacement, ``J dq = dw``, with the
    end-stops (eq. 13), step bounds (eq. 14) and extra rows. Written as an LP
    with ``t >= |dq|``: ``min sum(t)`` s.t. ``J dq = p dw``, ``dq - t <= 0``,
    ``-dq - t <= 0``.

    When the full displacement is infeasible, Ho's LP has no answer. lpik then
    returns, lexicographically, the least-L1 step among those achieving the
    largest feasible fraction ``p*`` (found by LP1, eqs. 11-14), with status
    ``"scaled"`` and ``binding`` naming the limit that stops ``p`` (LP1's).
    The multipliers are not defined: ``lam`` is ``None``.

    Args:
        problem: The step to solve.
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across steps (warm start).
    """
    start = time.perf_counter()
    n = problem.n
    solver = solver_for(solver)
    sol, x = _least_l1(problem, solver, 1.0, 1.0)
    if sol == OPTIMAL:
        return finish(problem, "l1", x[:n], 1.0, None, None, start, "highs")
    if sol != INFEASIBLE:
        return safe_step(problem, "l1", sol, solve_time=time.perf_counter() - start, path="highs")
    best = lp1(problem, solver=solver)
    if not best.moved or check.check_step(problem, best.dq, best.p, None) is not None:
        # LP1 had no answer (its safe step, e.g. while recovering): neither has Ho's LP
        return safe_step(
            problem,
            "l1",
            best.status if not best.moved else INFEASIBLE,
            best.binding,
            solve_time=time.perf_counter() - start,
            path="highs",
        )
    sol, x = _least_l1(problem, solver, max(0.0, best.p - SCALED_P_MARGIN), best.p)
    if sol != OPTIMAL:  # the LP1 step itself is feasible at p*: keep it rather than fail
        x = np.concatenate([best.dq, np.abs(best.dq), [best.p]])
    # at p* = 1 the first solve misjudged a nearly singular program: p = 1 holds
    binding = None if best.p >= FULL_P else best.binding
    return finish(problem, "l1", x[:n], float(x[-1]), None, binding, start, "highs",
                  status=scaled_status(best.p))  # fmt: skip


def _least_l1(
    problem: Problem, solver: HighsSolver, p_lo: float, p_hi: float
) -> tuple[str, np.ndarray]:
    """Solve ``min sum t`` with ``p`` in ``[p_lo, p_hi]``; variables ``(dq, t, p)``."""
    n, m = problem.n, problem.m
    lower, upper = problem.step_bounds()[:2]
    eye = np.eye(n)
    A_eq = np.hstack([problem.J, np.zeros((m, n)), -problem.dw[:, None]])
    A_ub = np.block([[eye, -eye, np.zeros((n, 1))], [-eye, -eye, np.zeros((n, 1))]])
    c = np.concatenate([np.zeros(n), np.ones(n), [0.0]])
    col_lower = np.concatenate([lower, np.zeros(n), [p_lo]])
    col_upper = np.concatenate([upper, np.full(n, np.inf), [p_hi]])
    lp = lp_over(problem, c, A_eq, np.zeros(m), col_lower, col_upper, A_ub, np.zeros(2 * n))
    sol = solver.solve(lp)
    return sol.status, sol.x
