"""Property tests over random planar arms, configurations, commands and limits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_reference import (
    HARD_TOL,
    HIGHS_SMALL_MATRIX_VALUE,
    Bracket,
    bracket,
    hard_violation,
    kkt_condition,
    kkt_step,
    l1_reference,
    limiting_ratios,
    lp1_reference,
    lp2_reference,
    task_error,
)
from core_strategies import Case, cases, examples
from lpik.check import worst_violation
from lpik.highs import HIGHS_OPTIONS
from lpik.methods import lp2
from lpik.methods.kkt import smoothing
from lpik.result import SCALED, SOLVER_ERROR, STATUSES, Result

#: HiGHS's feasibility tolerance as lpik sets it (:data:`lpik.highs.HIGHS_OPTIONS`).
HIGHS_FEASIBILITY_TOL = float(HIGHS_OPTIONS["primal_feasibility_tolerance"])  # type: ignore[arg-type]
#: Small commands, for which the linearisation is close to the nonlinear kinematics.
DW_SMALL = st.sampled_from([1e-3, 1e-2])

LP_SOLVERS = {
    "lp1": lambda case: case.solve("lp1"),
    "l1": lambda case: case.solve("l1"),
    "lp2-ratio-test": lambda case: lp2(case.problem, path="ratio-test"),
    "lp2-highs": lambda case: lp2(case.problem, path="highs"),
}


def assert_contract(case: Case, res: Result) -> None:
    """What every result promises: a status word, p in [0, 1], a consistent q and dq."""
    P = case.problem
    assert res.status in STATUSES
    assert 0.0 <= res.p <= 1.0
    assert res.q.shape == res.dq.shape == (P.n,)
    np.testing.assert_allclose(res.q, P.q0 + res.dq, rtol=0, atol=1e-12)
    if not res.moved:
        np.testing.assert_array_equal(res.q, P.q0)
        np.testing.assert_array_equal(res.dq, np.zeros(P.n))
        assert res.p == 0.0


@pytest.mark.parametrize("name", list(LP_SOLVERS))
@settings(max_examples=examples(250))
@given(case=cases())
def test_lp_step_keeps_every_hard_limit(name: str, case: Case) -> None:
    res = LP_SOLVERS[name](case)
    assert_contract(case, res)
    if name.startswith("lp2") and not case.criterion_is_zero:
        # With f != 0 or Lambda pulling, even p = 0 may be infeasible: then a safe step.
        assert res.moved or res.status == "infeasible"
    elif res.status == SOLVER_ERROR and res.path == "highs":
        # HiGHS (after its retries) fails on some programs of links aligned to 1e-10 with
        # unbounded joints (a thorough-profile find on LP1): the contract's safe step
        assert not np.any(res.dq) and res.p == 0.0
    else:
        # q0 satisfies every limit, so (dq, p) = (0, 0) is feasible: the LP must move.
        assert res.moved, (res.status, res.binding)
    if res.moved:
        assert hard_violation(case.problem, res.q, res.lam) <= HARD_TOL
        assert task_error(case.problem, res.dq, res.p) <= 1e-7
        if res.p < 1.0 - 1e-9:
            assert res.binding is not None


@settings(max_examples=examples(250))
@given(case=cases())
def test_lp1_achieves_at_least_lp2s_dexterity(case: Case) -> None:
    p1 = case.solve("lp1")
    p2 = case.solve("lp2")
    assert p1.moved
    # A step of more than 1e3 rad (no velocity limit, links aligned to 1e-11: LP2 moves a
    # joint 1e8 rad to keep the command) is beyond what HiGHS resolves on so ill-conditioned
    # a program; it finds p = 0 there (a thorough-profile find).
    # HiGHS drops matrix entries at or below its small_matrix_value (1e-9): a task row of
    # such entries is not in LP1's program, while LP2 keeps it (a thorough-profile find)
    rows_kept = bool((np.abs(case.problem.J).max(axis=1) > HIGHS_SMALL_MATRIX_VALUE).all())
    # HiGHS resolves the task motion only to its feasibility tolerance times the Jacobian's
    # condition: two links aligned to 1e-9 (condition 5e9), LP2's p 9.3e-8 asks a task
    # motion of 1.9e-9 m, and HiGHS finds p = 0 (a CI find)
    resolved = p2.p * np.abs(case.problem.dw).max() > HIGHS_FEASIBILITY_TOL * np.linalg.cond(
        case.problem.J
    )
    if (exact_on_every_row(case.problem, p2) and np.abs(p2.dq).max() <= 1e3 and rows_kept
            and resolved):  # fmt: skip
        assert p1.p >= p2.p - 1e-9


def exact_on_every_row(P, res: Result) -> bool:  # type: ignore[no-untyped-def]
    """True when ``J dq = p dw`` holds on every row to 1e-9 of that row's own scale.

    The contract bounds the residual relative to the whole task (:data:`EQUALITY_RTOL`):
    where a row of ``J`` is tiny (a planar arm stretched along one axis, ``J`` row
    1e-7) LP2's singular path may count it as rank-deficient and move along ``dw``
    with a residual of the row's own size, while HiGHS solves that row exactly and
    finds p = 0. Both are right within the tolerance; only steps exact on every row
    bind LP1 to reach at least as far.
    """
    residual = np.abs(P.J @ res.dq - res.p * P.dw)
    scale = np.abs(P.J) @ np.abs(res.dq) + res.p * np.abs(P.dw)
    return bool(np.all(residual <= 1e-9 * np.maximum(scale, 1e-300) + 1e-15))


#: Agreement of an optimal value with linprog's, beyond the bracket of the tolerances.
VALUE_TOL = 1e-7


def p_tolerance(P) -> float:  # type: ignore[no-untyped-def]
    """How far an LP's p may fall short of a proven one: a solver may stop ``HARD_TOL`` short
    of a bound, which costs ``HARD_TOL / |dw|`` of p (slivers thinner than the tolerance)."""
    return max(VALUE_TOL, HARD_TOL / max(1e-12, float(np.abs(P.dw).max())))


def assert_within(value: float, b: Bracket, sense: float = 1.0, short: float = VALUE_TOL) -> None:
    """``value`` is no better than the relaxed optimum and no worse than a proven one
    (by more than ``short``: what the solvers' tolerances allow)."""
    assert b.loose.feasible
    best = b.loose.objective
    proven = b.attainable(sense)
    if sense > 0:  # maximise
        assert value <= best + VALUE_TOL
        assert proven is None or value >= proven - short
    else:  # minimise
        assert value >= best - VALUE_TOL
        assert proven is None or value <= proven + short


@settings(max_examples=examples(250))
@given(case=cases(well_posed=True))
def test_lp1_and_l1_against_linprog(case: Case) -> None:
    P = case.problem
    res1 = case.solve("lp1")
    assert res1.moved
    assert_within(res1.p, bracket(lp1_reference, P), short=p_tolerance(P))
    resl = case.solve("l1")
    assert resl.moved
    full = bracket(l1_reference, P, 1.0)
    if resl.status == "optimal":
        assert resl.p == 1.0
        assert_within(float(np.abs(resl.dq).sum()), full, sense=-1.0)
    else:
        assert resl.status == SCALED
        assert not full.tight.feasible  # else the full displacement was within reach
        assert resl.p == pytest.approx(res1.p, abs=1e-8)
        l1_short = max(VALUE_TOL, P.n * HARD_TOL)  # each joint within the tolerance
        assert_within(float(np.abs(resl.dq).sum()), bracket(l1_reference, P, resl.p), -1.0,
                      l1_short)  # fmt: skip


@settings(max_examples=examples(250))
@given(case=cases(well_posed=True))
def test_lp2_agrees_with_linprog(case: Case) -> None:
    P = case.problem
    b = bracket(lp2_reference, P, criterion=True)
    res = case.solve("lp2")
    if not res.moved:
        assert res.status == "infeasible"
        assert not b.tight.feasible
        return
    assert_within(res.p, b)
    proven = b.attainable()
    well_determined = proven is not None and b.loose.p - proven <= VALUE_TOL
    if well_determined and b.exact.feasible and kkt_condition(P) < 1e6:
        # q and lam are unique, and well determined
        np.testing.assert_allclose(res.q, b.exact.q, rtol=0, atol=1e-7)
        np.testing.assert_allclose(res.lam, b.exact.lam, rtol=1e-6, atol=1e-7)


def off_the_free_range_within_tolerance(P) -> bool:  # type: ignore[no-untyped-def]
    """Whether ``dw`` lies off the range of the free joints' columns by more than rounding
    but within lpik's equality tolerance (``EQUALITY_RTOL max(1, |dw|)``, as the answer's
    check): there lpik may keep the command (``p`` up to 1, ``J dq = p dw`` within its
    tolerance) where an exact LP solver finds ``p = 0``. Both keep the contract."""
    from lpik.tolerances import EQUALITY_RTOL, SINGULAR_RTOL

    lower, upper = P.step_bounds()[:2]
    J = P.J[:, lower != upper]
    if J.shape[1] == 0:
        return False
    U, sv, _ = np.linalg.svd(J, full_matrices=False)
    basis = U[:, sv > SINGULAR_RTOL * sv.max()] if sv.max() > 0 else U[:, :0]
    off = float(np.linalg.norm(P.dw - basis @ (basis.T @ P.dw)))
    size = float(np.abs(P.dw).max())
    return 1e-12 * size < off <= EQUALITY_RTOL * max(1.0, size)


@settings(max_examples=examples(250))
@given(case=cases(well_posed=True))
def test_lp2_ratio_test_and_highs_paths_agree(case: Case) -> None:
    P = case.problem
    if off_the_free_range_within_tolerance(P):
        return  # both answers keep the contract: a tie at the tolerance (a thorough-profile find)
    fast = lp2(P, path="ratio-test")
    slow = lp2(P, path="highs")
    if fast.status != slow.status and worst_violation(P, slow.dq).amount > 1e-9:
        return  # HiGHS's retry at its looser 1e-7 tolerance kept a step the exact rows refuse
    if fast.status != slow.status and slow.residual > 1e-9:
        # HiGHS's step off the line J dq = p dw within its tolerance: with dw = 0 and J regular
        # (det 2.9e-3) the exact step is dq = 0, whose multipliers J^-T f (-0.7004) break
        # lam_min (-0.6953): the ratio test's infeasible is exact; HiGHS's J dq = 5.3e-8
        # moved lam within bounds (a find of a fresh clone's random examples)
        return
    assert fast.status == slow.status
    if not fast.moved:
        return
    assert fast.p == pytest.approx(slow.p, abs=1e-8)
    if kkt_condition(P) < 1e6:
        np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-8)
        np.testing.assert_allclose(fast.lam, slow.lam, rtol=1e-7, atol=1e-8)


def held_on_a_bound(P) -> bool:
    """Whether a joint stays on one of its step bounds all along eq. 16's path.

    Such a bound is active at the optimum too, a tie with the first limit reached: HiGHS
    may name it (a joint starting exactly on its end-stop, its step 0 for every p).
    """
    dq0, dq1 = kkt_step(P, 0.0)[0], kkt_step(P, 1.0)[0]
    lower, upper = P.step_bounds()[:2]
    still = np.abs(dq1 - dq0) <= 1e-12
    on = (np.abs(dq0 - lower) <= 1e-12) | (np.abs(dq0 - upper) <= 1e-12)
    return bool((still & on).any())


@settings(max_examples=examples(250))
@given(case=cases(well_posed=True))
def test_lp2_stops_at_the_first_limit_on_its_path(case: Case) -> None:
    # Independent of lpik's ratio test: walk eq. 16's solution from p = 0 and find
    # where it first reaches a limit.
    P = case.problem
    if kkt_condition(P) > 1e6:
        return  # the path is not well determined (near a singularity)
    if P.pinned()[0].any() or smoothing(P) < 1.0:
        return  # eq. 16 over the free joints, or a scaled pull: the linprog comparison
    ratios = limiting_ratios(P)
    if ratios is None:
        return  # starts outside a limit: covered by the linprog comparison
    first = ratios[0] if ratios else (np.inf, None)
    expected_p = min(1.0, first[0])
    for res in (lp2(P, path="ratio-test"), lp2(P, path="highs")):
        assert res.status == "optimal"
        assert res.p == pytest.approx(expected_p, abs=1e-8)
        unique = len(ratios) < 2 or ratios[1][0] - first[0] > 1e-6
        if expected_p < 1.0 - 1e-6 and unique and not held_on_a_bound(P):
            assert res.binding == first[1], (res.path, ratios[:3])


@pytest.mark.parametrize("name", ["pinv", "weighted", "robust"])
@settings(max_examples=examples(200))
@given(case=cases())
def test_classical_steps_never_violate_silently(name: str, case: Case) -> None:
    res = case.solve(name)
    assert_contract(case, res)
    assert res.status in {"optimal", "violates_limits", "singular"}
    if res.status == "optimal":
        assert hard_violation(case.problem, res.q) <= HARD_TOL
    elif res.status == "violates_limits":
        assert res.binding is not None
        assert hard_violation(case.problem, res.q) > 0.0
    if name != "robust" and res.moved:
        assert res.p == 1.0
        assert task_error(case.problem, res.dq, 1.0) <= 1e-7


@settings(max_examples=examples(40))
@given(case=cases(max_links=5, rows=False, multipliers=False, dw_sizes=DW_SMALL))
def test_nlp_lands_on_the_scaled_command_within_limits(case: Case) -> None:
    P = case.problem
    res = case.solve("nlp")
    assert_contract(case, res)
    if not res.moved:
        return
    assert hard_violation(P, res.q) <= HARD_TOL
    if res.p < 1.0 - 1e-9:
        assert res.binding is not None
    w0 = case.arm.pose(P.q0)
    moved = case.arm.difference(w0, case.arm.pose(res.q))
    np.testing.assert_allclose(moved, res.p * P.dw, rtol=0, atol=1e-7)
