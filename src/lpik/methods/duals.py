"""Which limit binds: read from an LP's duals, or from the elastic program when none is feasible.

:func:`binding_from_duals` names the limit that keeps ``p`` below 1 at an LP
optimum; :func:`conflict_label` names the limit in conflict when no step is
feasible, not even ``p = 0``. Labels are those of :mod:`lpik.labels`.
"""

from __future__ import annotations

import numpy as np

from lpik.highs import HighsSolver, LinearProgram, LpSolution
from lpik.labels import code_labels
from lpik.methods.singular import held_joint_code, singularity_code
from lpik.problem import Problem
from lpik.result import OPTIMAL
from lpik.tolerances import ACTIVE_RTOL, DUAL_TOL, FULL_P, RELAX, RELAX_GAIN, RELAX_SCALES
from lpik.types import FloatArray


def extra_rows(problem: Problem, n_cols: int) -> tuple[FloatArray, FloatArray]:
    """``G dq <= h - G q0`` padded with zero columns up to ``n_cols``."""
    G = problem.G
    rows = np.zeros((G.shape[0], n_cols))
    rows[:, : problem.n] = G
    return rows, problem.h - G @ problem.q0


def binding_from_duals(
    problem: Problem,
    sol: LpSolution,
    lp: LinearProgram,
    p: float,
    n_eq: int,
    lam_slice: slice | None = None,
    *,
    relaxed: bool = False,
    pinned: FloatArray | None = None,
) -> str | None:
    """Name the limit that keeps ``p`` below 1, from the solver's duals.

    Among the bounds of ``dq`` (and of the multipliers) that are active, and the
    extra rows that are active, the one with the largest dual value (the largest
    sensitivity of the optimum to that limit) is binding. At a degenerate vertex
    (an active limit that is basic, typically ``p = 0`` with several joints on
    bounds) the duals are not unique and may name a limit that does not hold
    ``p`` at all; then the active limits are relaxed outward by tiny, distinct
    amounts and the binding limit of that nondegenerate program is named
    (:func:`_binding_after_relaxing`). When ``p < 1`` and no limit is active,
    the equality rows stop ``p``: :data:`SINGULARITY`.

    The bounds are read from ``lp`` (the columns of ``dq`` first, those of the
    multipliers at ``lam_slice``, ``p`` last) and the labels from ``problem``.
    Joints flagged in ``pinned`` (LP2's joints held at one value, saturated
    ones included) are not limits that stop ``p`` here: LP2's ratio test
    resolves the criterion without them, and so their duals are not read; one is
    named only where it moves the task along a direction the free joints have
    lost (:func:`_held_or_singular`), as on LP2's singular path.
    """
    if p >= FULL_P:
        return None
    n = problem.n
    _, _, lower_labels, upper_labels = problem.step_bounds()
    candidates: list[tuple[float, str]] = []
    # (position among the columns then the rows, label at the lower bound, at the upper)
    active: list[tuple[int, str | None, str | None]] = []
    x = sol.x

    def add_columns(
        sl: slice, lo_labels: tuple[str, ...], hi_labels: tuple[str, ...], skip: object = None
    ) -> None:
        values, duals = x[sl], sol.col_dual[sl]
        lo, hi = lp.col_lower[sl], lp.col_upper[sl]
        for i in range(values.size):
            if skip is not None and skip[i]:
                continue
            near_lo = abs(values[i] - lo[i]) <= ACTIVE_RTOL * max(1.0, abs(lo[i]))
            near_hi = abs(values[i] - hi[i]) <= ACTIVE_RTOL * max(1.0, abs(hi[i]))
            at_lo = np.isfinite(lo[i]) and near_lo
            at_hi = np.isfinite(hi[i]) and near_hi
            if at_hi and (not at_lo or duals[i] <= 0):
                candidates.append((abs(duals[i]), hi_labels[i]))
            elif at_lo:
                candidates.append((abs(duals[i]), lo_labels[i]))
            if at_lo or at_hi:
                active.append(
                    (sl.start + i, lo_labels[i] if at_lo else None, hi_labels[i] if at_hi else None)
                )

    add_columns(slice(0, n), lower_labels, upper_labels, pinned)
    if lam_slice is not None:
        add_columns(lam_slice, *problem.multiplier_labels())
    r = problem.G.shape[0]
    if r:
        activity = lp.A[n_eq : n_eq + r] @ x
        rhs = lp.row_upper[n_eq : n_eq + r]
        for i in range(r):
            if abs(activity[i] - rhs[i]) <= ACTIVE_RTOL * max(1.0, abs(rhs[i])):
                candidates.append((abs(sol.row_dual[n_eq + i]), problem.row_labels[i]))
                active.append((lp.A.shape[1] + n_eq + i, None, problem.row_labels[i]))
    if not candidates:
        return _held_or_singular(problem)
    best = max(candidates, key=lambda item: item[0])
    if not relaxed and (best[0] <= DUAL_TOL or _degenerate(sol, lp, active, p)):
        label = _binding_after_relaxing(problem, lp, active, p, n_eq, lam_slice)
        if label is not None:
            return label
    return best[1]


def _held_or_singular(problem: Problem) -> str:
    """What holds ``p`` where no active limit does: a pinned joint, else :data:`SINGULARITY`.

    A joint held at one value (``lower == upper``) that moves the task along a
    direction the free joints have lost holds ``p`` (:func:`lpik.methods.singular.held_joint_code`,
    the rule of LP2's singular path); otherwise ``J`` cannot produce ``dw``.
    """
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    table = code_labels(lower_labels, upper_labels, problem.m, problem.row_labels)
    sing = singularity_code(problem.n, problem.m, problem.G.shape[0])
    return table[held_joint_code(problem.J, problem.dw, lower, upper, sing)]


def _degenerate(
    sol: LpSolution, lp: LinearProgram, active: list[tuple[int, str | None, str | None]], p: float
) -> bool:
    """True when an active limit, or ``p`` at 0, is basic: the duals are then not unique."""
    basic = sol.basic
    n_row, n_col = lp.A.shape
    if basic is None or basic.size != n_col + n_row:
        return False
    p_basic_at_zero = p <= 0 and bool(basic[n_col - 1])
    return p_basic_at_zero or any(bool(basic[position]) for position, _, _ in active)


def _binding_after_relaxing(
    problem: Problem,
    lp: LinearProgram,
    active: list[tuple[int, str | None, str | None]],
    p: float,
    n_eq: int,
    lam_slice: slice | None,
) -> str | None:
    """The binding limit once every active limit is relaxed outward by a distinct tiny amount.

    Only limits that hold ``p`` can bind the relaxed program, which is
    nondegenerate; a label that was not active before (another limit close by)
    is not trusted, and ``None`` is returned. The relaxation grows by
    :data:`~lpik.tolerances.RELAX_SCALES`: near a singularity a limit that holds
    ``p`` raises it by only a small share of its relaxation. When no relaxation
    of every active limit raises ``p``, none of them holds it: :data:`SINGULARITY`.
    """
    labels = {label for _, lo, hi in active for label in (lo, hi) if label is not None}
    for scale in RELAX_SCALES:
        relaxed_lp = _relaxed(lp, active, RELAX * scale)
        sol = HighsSolver().solve(relaxed_lp)
        if sol.status != OPTIMAL:
            return None
        p_relaxed = float(sol.x[-1])
        if p_relaxed > p + RELAX_GAIN * RELAX:
            label = binding_from_duals(problem, sol, relaxed_lp, p_relaxed, n_eq, lam_slice,
                                       relaxed=True)  # fmt: skip
            return label if label in labels else None
    return _held_or_singular(problem)


def _relaxed(
    lp: LinearProgram, active: list[tuple[int, str | None, str | None]], amount: float
) -> LinearProgram:
    """``lp`` with every active limit moved outward by ``amount`` times its own factor in [1, 2)."""
    col_lower, col_upper = lp.col_lower.copy(), lp.col_upper.copy()
    row_upper = lp.row_upper.copy()
    n_col = lp.A.shape[1]
    for k, (position, lo_label, hi_label) in enumerate(active):
        step = amount * (1.0 + k / len(active))
        if position >= n_col:
            row_upper[position - n_col] += step * max(1.0, abs(row_upper[position - n_col]))
        if position < n_col and lo_label is not None:
            col_lower[position] -= step * max(1.0, abs(col_lower[position]))
        if position < n_col and hi_label is not None:
            col_upper[position] += step * max(1.0, abs(col_upper[position]))
    return LinearProgram(lp.c, lp.A, lp.row_lower, row_upper, col_lower, col_upper)


def conflict_label(problem: Problem, A_eq: FloatArray, b_eq: FloatArray, n_lam: int) -> str | None:
    """Name the limit in conflict when a step's LP is infeasible even at ``p = 0``.

    Solves the elastic program: the method's equality rows ``A_eq x = b_eq``
    over ``x = (dq, lam, p)`` (``n_lam`` multipliers; ``p`` in [0, 1]) hold
    exactly, while every bound on ``dq`` and ``lam`` and every extra row may
    give way by a slack ``s >= 0``; it minimises the slacks, each divided by
    the width of its band (``upper - lower`` where both are finite, else 1),
    so that the narrowest limits (an acceleration band of ``2 qdd_max dt^2``)
    count most. The limit whose weighted slack is largest is named. A pinned
    joint (:meth:`~lpik.problem.Problem.pinned`: its bounds coincide) is held at
    its value without slack: it is not a limit that can give way, and its zero
    width would turn a slack at the solver's tolerance into the largest one.

    Returns:
        Its label (as :meth:`~lpik.problem.Problem.step_bounds`,
        :meth:`~lpik.problem.Problem.multiplier_labels` and ``row_labels``
        write them), or ``None`` when the elastic program finds no violation
        or fails.
    """
    n = problem.n
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    lam_lo_labels, lam_hi_labels = problem.multiplier_labels()
    lo = np.concatenate([lower, problem.lam_min[:n_lam]])
    hi = np.concatenate([upper, problem.lam_max[:n_lam]])
    labels = (
        lower_labels + lam_lo_labels[:n_lam] + upper_labels + lam_hi_labels[:n_lam]
        + tuple(problem.row_labels)
    )  # fmt: skip
    cols = A_eq.shape[1]  # n + n_lam + 1 (p)
    G, g = extra_rows(problem, cols)
    k, r = n + n_lam, G.shape[0]
    width = np.where(np.isfinite(lo) & np.isfinite(hi), hi - lo, 1.0)
    weight = 1.0 / np.maximum(np.concatenate([width, width, np.ones(r)]), 1e-12)
    n_slack = 2 * k + r
    eye = np.eye(k, cols)
    A = np.block(
        [
            [A_eq, np.zeros((A_eq.shape[0], n_slack))],
            [eye, np.eye(k), np.zeros((k, k + r))],  # x + s_lo >= lo
            [eye, np.zeros((k, k)), -np.eye(k), np.zeros((k, r))],  # x - s_hi <= hi
            [G, np.zeros((r, 2 * k)), -np.eye(r)],
        ]
    )
    inf_k, inf_r = np.full(k, np.inf), np.full(r, np.inf)
    give = np.concatenate([np.where(problem.pinned()[0], 0.0, np.inf), np.full(n_lam, np.inf)])
    lp = LinearProgram(
        c=np.concatenate([np.zeros(cols), weight]),
        A=A,
        row_lower=np.concatenate([b_eq, lo, -inf_k, -inf_r]),
        row_upper=np.concatenate([b_eq, inf_k, hi, g]),
        col_lower=np.concatenate([np.full(cols - 1, -np.inf), [0.0], np.zeros(n_slack)]),
        col_upper=np.concatenate([np.full(cols - 1, np.inf), [1.0], give, give, inf_r]),
    )
    sol = HighsSolver().solve(lp)
    if sol.status != OPTIMAL:
        return None
    violation = weight * sol.x[cols:]
    worst = int(np.argmax(violation))
    return labels[worst] if violation[worst] > 0.0 else None
