"""LP2 with saturation in the null space: the joint that stops the step is fixed, the rest go on.

LP2's criterion rows (eq. 18) fix ``dq`` as an affine function of ``p``: when one
joint reaches a bound at ``p*``, the step stops there although the other joints
could carry the command further. Saturation in the null space (Flacco, De Luca
and Khatib, "Control of redundant robots under hard joint constraints:
saturation in the null space", IEEE Trans. Robotics 31(3), 2015) fixes that
joint at its bound and resolves the criterion over the joints still free:
eqs. 15-18 over the free joints (:func:`lpik.methods.kkt.pinned_system`),
repeated until the command is met, or what stops it is not a joint's bound
(a multiplier bound, an extra row, a singularity), or no free redundancy is left
(fewer free joints than task rows, or a free joints' Jacobian so ill-conditioned
that eq. 18's Schur complement fails :data:`~lpik.tolerances.SATURATION_MAX_CONDITION`:
there the last few free joints would race at their velocity limits for a
sliver of ``p``, and rounding would break ``J dq = p dw``), or the pass does not
pay (:func:`worth_it`): it would swing the joints far more per unit of ``p``
gained than the step so far moves them, a nearly singular free-joint system
whose pass is taken on one step and not on the next (joint-velocity jitter).

Each pass starts from the previous one's answer: at ``p*`` the fixed joint sits
exactly at its bound and the other joints' criterion rows hold, so that answer
is feasible for the next pass. ``p`` therefore never decreases from pass to
pass, the step is continuous where a joint saturates, and with every joint
free it is LP2's step exactly.
"""

from __future__ import annotations

import time

import numpy as np

from lpik.continuation import around_motion
from lpik.highs import HighsSolver
from lpik.methods.assembly import finish
from lpik.methods.engines import compiled_step
from lpik.methods.kkt import affine_solution
from lpik.methods.lp2 import lp2, pulled
from lpik.problem import Problem
from lpik.result import INFEASIBLE, Result, safe_step
from lpik.tolerances import (
    FULL_P,
    INTERVAL_TOL,
    SATURATION_MAX_CONDITION,
    SATURATION_MAX_PRICE,
)


def joint_bound_index(problem: Problem) -> dict[str, tuple[int, int]]:
    """Each joint bound's label, mapped to ``(joint, side)`` (side 0 lower, 1 upper)."""
    lower_labels, upper_labels = problem.step_bounds()[2:]
    index: dict[str, tuple[int, int]] = {}
    for i, (lo, hi) in enumerate(zip(lower_labels, upper_labels)):
        index.setdefault(lo, (i, 0))
        index.setdefault(hi, (i, 1))
    return index


def _names_free_joint(problem: Problem, result: Result, index: dict[str, tuple[int, int]]) -> bool:
    """Whether ``result`` is stopped by a bound of a joint ``problem`` does not hold yet.

    A held joint (saturated, or pinned by its bounds) named along a direction the free
    joints have lost (:func:`lpik.methods.singular._pinned_code`) ends the passes:
    saturating another joint does not give that direction back.
    """
    if result.binding not in index:
        return False
    lower, upper = problem.step_bounds()[:2]
    joint = index[result.binding][0]
    return bool(lower[joint] != upper[joint])


def saturated(problem: Problem, joint: int, side: int) -> Problem:
    """``problem`` with ``joint`` fixed at its lower (``side`` 0) or upper (1) bound on ``dq``."""
    lower, upper = problem.step_bounds()[:2]
    value = upper[joint] if side else lower[joint]
    dq_min, dq_max = problem.dq_min.copy(), problem.dq_max.copy()
    dq_min[joint] = dq_max[joint] = value
    return problem.replace(dq_min=dq_min, dq_max=dq_max)


@around_motion
def lp2s(problem: Problem, *, path: str = "auto", solver: HighsSolver | None = None) -> Result:
    """LP2 (eqs. 15-18) with saturation in the null space; the module docstring tells how.

    Args:
        problem: The step to solve, as for :func:`~lpik.methods.lp2.lp2`.
        path: Each pass's LP2 path (:data:`lpik.methods.lp2.PATHS`); ``"compiled"``
            runs the passes compiled (:mod:`lpik.fast.saturation`).
        solver: A :class:`~lpik.highs.HighsSolver` to reuse across passes and steps.

    Returns:
        The step of the pass with the largest ``p`` (the last one to reach it,
        the most saturated); ``binding`` names the limit that finally stops it.
        Re-checked against ``problem`` itself, so every limit holds.
    """
    if path == "compiled":  # the compiled engine (lpik.methods.engines)
        return compiled_step("lp2s")(problem, solver)
    start = time.perf_counter()
    best, _ = saturation_passes(problem, path=path, solver=solver)
    if best.status == INFEASIBLE:  # no pass feasible: as LP2 names it (recovering or not)
        return safe_step(problem, "lp2s", INFEASIBLE, best.binding,
                         solve_time=time.perf_counter() - start, path=best.path)  # fmt: skip
    if not best.moved or best.lam is None:  # LP2's own safe step: nothing to saturate
        return _renamed(best)
    result = finish(
        problem, "lp2s", best.dq, best.p, best.lam, best.binding, start, best.path, best.status
    )
    return pulled(result, best.pull_scale)  # the best pass's share of sec. 3.1's pull


def saturation_passes(
    problem: Problem, *, path: str = "auto", solver: HighsSolver | None = None
) -> tuple[Result, Problem]:
    """The passes of :func:`lp2s`: the best pass's LP2 result and the problem it solved.

    That problem has the saturated joints' bounds set to the bound where each
    stopped a pass (:func:`saturated`): LP2 on it is the answer.

    A pass with no feasible ``p`` at all (typically a joint whose acceleration
    limits keep it off the line ``dq(p)`` of eq. 18) saturates the joint its
    conflict names in the same way: fixed at that bound, the others resolve the
    criterion, and the first feasible pass starts the ordinary passes. When no
    pass is feasible, the first pass's safe step is the answer.
    """
    # each pass names the limit that stops it, also from a state outside its limits
    best = current_result = lp2(problem, path=path, solver=solver, name_outside=False)
    best_problem = current = problem
    stuck = best.status == INFEASIBLE  # no pass feasible yet
    index = joint_bound_index(problem)
    free = problem.n - int(problem.pinned()[0].sum())
    while (
        (stuck or current_result.moved)
        and current_result.p < FULL_P
        and _names_free_joint(current, current_result, index)
        and free - 1 >= problem.m
    ):
        candidate = saturated(current, *index[current_result.binding])
        if affine_solution(candidate, SATURATION_MAX_CONDITION) is None:  # no redundancy left
            break
        current = candidate
        free -= 1
        current_result = lp2(current, path=path, solver=solver, name_outside=False)
        if current_result.status == INFEASIBLE and stuck:
            continue  # saturate the next conflict
        if not (current_result.moved and (stuck or current_result.p >= best.p - INTERVAL_TOL)):
            break
        if not stuck and not worth_it(best, current_result):
            break
        best, best_problem, stuck = current_result, current, False
    return best, best_problem


def worth_it(before: Result, after: Result) -> bool:
    """Whether a later pass pays for the motion it adds.

    The joint motion it adds per unit of ``p`` gained must be at most
    :data:`~lpik.tolerances.SATURATION_MAX_PRICE` times that of the step before it
    (a nearly singular free-joint system swings the joints for a sliver of ``p``).
    A pass that ties (another joint reached its bound at the same ``p``, within
    :data:`~lpik.tolerances.INTERVAL_TOL`) counts as gaining ``INTERVAL_TOL``: it
    saturates that joint too at the motion's rounding, and the next pass goes on
    (whether two tied passes went on had been left to the last bits of ``p``).
    """
    if before.p <= 0.0:  # from a standstill any motion the pass finds is worth it
        return True
    gain = max(after.p - before.p, INTERVAL_TOL)
    added = float(np.linalg.norm(after.dq - before.dq))
    return added <= SATURATION_MAX_PRICE * gain * float(np.linalg.norm(before.dq)) / before.p


def _renamed(result: Result) -> Result:
    fields = dict(vars(result))
    fields["method"] = "lp2s"
    return Result(**fields)
