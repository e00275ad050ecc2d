"""The one HiGHS layer: status table, warm starts, failures that become statuses."""

from __future__ import annotations

import highspy
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from core_strategies import examples, floats, offsets, vectors
from lpik import result
from lpik.highs import HIGHS_STATUS, HighsSolver, LinearProgram
from lpik.robots.planar import planar_arm

INF = np.inf


def program(c, A, lo, hi, col_lo, col_hi) -> LinearProgram:  # type: ignore[no-untyped-def]
    return LinearProgram(*(np.asarray(v, dtype=np.float64) for v in (c, A, lo, hi, col_lo, col_hi)))


def test_the_status_table_speaks_lpik() -> None:
    assert set(HIGHS_STATUS.values()) <= set(result.STATUSES)
    ms = highspy.HighsModelStatus
    assert HIGHS_STATUS[ms.kOptimal] == result.OPTIMAL
    assert HIGHS_STATUS[ms.kInfeasible] == result.INFEASIBLE
    assert HIGHS_STATUS[ms.kIterationLimit] == result.LIMIT_REACHED
    assert HIGHS_STATUS[ms.kTimeLimit] == result.LIMIT_REACHED
    # Only kOptimal means success: nothing else may map to it.
    assert [k for k, v in HIGHS_STATUS.items() if v == result.OPTIMAL] == [ms.kOptimal]


def test_a_small_lp_is_solved() -> None:
    # max x + y s.t. x + 2 y <= 4, 3 x + y <= 6, x, y >= 0: optimum (1.6, 1.2).
    lp = program([-1, -1], [[1, 2], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])
    sol = HighsSolver().solve(lp)
    assert sol.status == result.OPTIMAL
    np.testing.assert_allclose(sol.x, [1.6, 1.2], atol=1e-12)
    assert sol.row_dual.shape == (2,) and sol.col_dual.shape == (2,)
    assert sol.highs_status == "Optimal"


def test_highs_writes_nothing_to_the_process_output(capfd) -> None:
    """Not even the banner highspy >= 1.16 prints when its Python class is built (fd level)."""
    lp = program([-1, -1], [[1, 2], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])
    for _ in range(2):
        assert HighsSolver().solve(lp).status == result.OPTIMAL
    assert capfd.readouterr() == ("", "")


def test_an_infeasible_lp_says_so() -> None:
    lp = program([1, 0], [[1, 1]], [3], [3], [0, 0], [1, 1])
    sol = HighsSolver().solve(lp)
    assert sol.status == result.INFEASIBLE


def test_an_unbounded_lp_is_not_optimal() -> None:
    lp = program([-1, 0], [[1, -1]], [-INF], [0], [0, 0], [INF, INF])
    assert HighsSolver().solve(lp).status != result.OPTIMAL


def test_a_crash_inside_highs_becomes_a_status_and_the_next_solve_recovers(monkeypatch) -> None:
    solver = HighsSolver()
    lp = program([-1, -1], [[1, 2], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])

    def boom() -> None:
        raise RuntimeError("simulated crash")

    with monkeypatch.context() as patch:
        patch.setattr(solver._highs, "run", boom)
        sol = solver.solve(lp)
    assert sol.status == result.SOLVER_ERROR
    assert "simulated crash" in sol.highs_status
    assert sol.x.shape == (2,)
    again = solver.solve(lp)
    assert again.status == result.OPTIMAL
    np.testing.assert_allclose(again.x, [1.6, 1.2], atol=1e-12)


def random_lp(draw: st.DrawFn, pattern: np.ndarray) -> LinearProgram:
    """A bounded, feasible LP whose constraint matrix has the given nonzero pattern."""
    r, n = pattern.shape
    # Coefficients below HiGHS's small_matrix_value (1e-9) would be dropped: none are drawn.
    coefficient = st.one_of(floats(0.01, 2.0), floats(-2.0, -0.01))
    A = np.where(pattern, draw(vectors(r * n, coefficient)).reshape(r, n), 0.0)
    # Numbers far below the tolerances (1e-179 costs, 1e-9 row bounds) would test HiGHS's
    # scaling, not the warm start: none are drawn.
    x0 = draw(vectors(n, offsets(1.0)))  # a feasible point
    slack = draw(vectors(r, st.one_of(st.just(0.0), floats(1e-3, 1.0))))
    width = draw(vectors(n, floats(0.1, 2.0)))
    c = draw(vectors(n, offsets(1.0)))
    return program(c, A, A @ x0 - slack, A @ x0 + slack, x0 - width, x0 + width)


@settings(max_examples=examples(60))
@given(data=st.data())
def test_warm_started_solves_match_fresh_ones(data: st.DataObject) -> None:
    r, n = data.draw(st.integers(1, 4)), data.draw(st.integers(1, 5))
    pattern = np.array(data.draw(vectors(r * n, st.sampled_from([0.0, 1.0])))).reshape(r, n) > 0
    reused = HighsSolver()
    for _ in range(4):
        lp = random_lp(data.draw, pattern)
        warm = reused.solve(lp)
        ref = linprog(
            lp.c,
            A_ub=np.vstack([lp.A, -lp.A]),
            b_ub=np.concatenate([lp.row_upper, -lp.row_lower]),
            bounds=list(zip(lp.col_lower, lp.col_upper)),
            method="highs",
        )
        assert warm.status == result.OPTIMAL
        assert ref.status == 0
        assert lp.c @ warm.x == pytest.approx(ref.fun, abs=1e-8)
        assert np.all(warm.x >= lp.col_lower - 1e-9) and np.all(warm.x <= lp.col_upper + 1e-9)
        assert np.all(lp.A @ warm.x <= lp.row_upper + 1e-9)
        assert np.all(lp.A @ warm.x >= lp.row_lower - 1e-9)


def test_a_changed_pattern_loads_a_new_model() -> None:
    solver = HighsSolver()
    first = program([-1, -1], [[1, 2], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])
    second = program([-1, -1, 0], [[1, 0, 1]], [-INF], [2], [0, 0, 0], [INF, 1, INF])
    np.testing.assert_allclose(solver.solve(first).x, [1.6, 1.2], atol=1e-12)
    sol = solver.solve(second)
    assert sol.status == result.OPTIMAL
    assert -sol.x[0] - sol.x[1] == pytest.approx(-3.0)


def test_coefficients_that_change_within_the_pattern_are_used() -> None:
    solver = HighsSolver()
    lp1 = program([-1, -1], [[1, 2], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])
    lp2 = program([-1, -1], [[1, 1], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])
    solver.solve(lp1)
    np.testing.assert_allclose(solver.solve(lp2).x, [1.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(solver.solve(lp1).x, [1.6, 1.2], atol=1e-12)


def aligned_arm_lp1(q: list[float], lengths: list[float], dw: list[float], lo, hi, G=None, h=None):  # type: ignore[no-untyped-def]
    """LP1 (eqs. 11-14) in dq for an arm whose last links are (nearly) aligned."""
    J = planar_arm(lengths).jacobian(q)
    n = J.shape[1]
    A = np.hstack([J, -np.asarray(dw)[:, None]])
    rows_lo, rows_hi = [0.0, 0.0], [0.0, 0.0]
    if G is not None:
        A = np.vstack([A, np.append(G, 0.0)])
        rows_lo.append(-INF)
        rows_hi.append(h)
    c = np.zeros(n + 1)
    c[-1] = -1.0
    return program(c, A, rows_lo, rows_hi, list(lo) + [0.0], list(hi) + [1.0])


def test_presolve_misjudging_a_nearly_singular_program_is_retried() -> None:
    # Regression: with 1e-10 tolerances HiGHS's presolve called this feasible LP
    # (x = 0 satisfies it) infeasible; links 3 and 4 are aligned to 1e-9 rad.
    lp = aligned_arm_lp1(
        [0.0, 1.0, 0.0, 1e-9],
        [1.0, 1.0, 1.0, 1.0],
        [0.0, 0.0],
        [0.0, 0.0, -INF, -INF],
        [0.0, 0.25, 0.0, 0.0],
        G=[0.0, 0.0, -1.0, 1.0],
        h=0.5,
    )
    sol = HighsSolver().solve(lp)
    assert sol.status == result.OPTIMAL
    assert sol.x[-1] == pytest.approx(1.0)


def test_a_solve_error_near_a_singularity_is_retried() -> None:
    # Regression: a stretched 2-link arm (q2 = 1e-10) made HiGHS stop with a solve error.
    lp = aligned_arm_lp1([1.0, 1e-10], [1.0, 1.0], [-0.002, 0.0], [-INF, 0.0], [0.0, INF])
    sol = HighsSolver().solve(lp)
    assert sol.status == result.OPTIMAL
    J = lp.A[:, :2]
    np.testing.assert_allclose(J @ sol.x[:2], sol.x[-1] * np.array([-0.002, 0.0]), atol=1e-7)


def first_status_unknown(monkeypatch, solver: HighsSolver) -> list[int]:
    """Make the first run of ``solver`` end kUnknown, as a warm start sometimes does."""
    real = solver._highs.getModelStatus
    calls: list[int] = []

    def status():  # type: ignore[no-untyped-def]
        calls.append(1)
        return highspy.HighsModelStatus.kUnknown if len(calls) == 1 else real()

    monkeypatch.setattr(solver._highs, "getModelStatus", status)
    return calls


def test_an_unknown_verdict_on_a_feasible_program_is_retried(monkeypatch) -> None:
    solver = HighsSolver()
    calls = first_status_unknown(monkeypatch, solver)
    lp = program([-1, -1], [[1, 2], [3, 1]], [-INF, -INF], [4, 6], [0, 0], [INF, INF])
    sol = solver.solve(lp)
    assert len(calls) >= 2
    assert sol.status == result.OPTIMAL
    np.testing.assert_allclose(sol.x, [1.6, 1.2], atol=1e-12)


def test_an_unknown_verdict_on_an_infeasible_program_becomes_infeasible(monkeypatch) -> None:
    # Regression: a warm-started run ended kUnknown where a fresh one proves infeasibility;
    # the step was reported as a solver error instead of an infeasible one.
    solver = HighsSolver()
    first_status_unknown(monkeypatch, solver)
    sol = solver.solve(program([1, 0], [[1, 1]], [3], [3], [0, 0], [1, 1]))
    assert sol.status == result.INFEASIBLE


def test_a_reused_solver_keeps_its_time_limit_per_solve() -> None:
    # HiGHS's time_limit counts the instance's whole life; a solver reused over a long
    # control run must not start answering "limit_reached" after SOLVE_TIME_LIMIT seconds.
    import lpik.highs as lp_module

    rng = np.random.default_rng(0)
    original = lp_module.SOLVE_TIME_LIMIT
    lp_module.SOLVE_TIME_LIMIT = 0.05
    try:
        solver = HighsSolver()
        statuses = set()
        while solver._highs.getRunTime() < 0.2:  # four times the limit, in total
            A = rng.normal(size=(3, 5))
            program = LinearProgram(c=rng.normal(size=5), A=A, row_lower=-np.ones(3),
                                    row_upper=np.ones(3), col_lower=-np.ones(5),
                                    col_upper=np.ones(5))  # fmt: skip
            statuses.add(solver.solve(program).status)
    finally:
        lp_module.SOLVE_TIME_LIMIT = original
    assert statuses == {"optimal"}
