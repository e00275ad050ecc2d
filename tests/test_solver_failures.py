"""A solver that fails, or claims success with a wrong answer, never moves the robot."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from core_strategies import paper_problem
from lpik import result as st
from lpik.highs import HighsSolver, LinearProgram, LpSolution
from lpik.methods import l1, lp1, lp2, solve
from lpik.methods.lp2 import AffineSolution
from lpik.problem import Problem
from lpik.robots.base import TaskModel
from lpik.robots.planar import planar_arm

Q0 = np.radians([60.0, -30.0, -30.0, -30.0])
LP_CALLS = {
    "lp1": lambda P: lp1(P),
    "l1": lambda P: l1(P),
    "lp2-highs": lambda P: lp2(P, path="highs"),
}


def arm() -> TaskModel:
    return planar_arm([1.0, 1.0, 1.0, 1.0], q_min=-np.pi, q_max=np.pi, qd_max=1.0)


def problem() -> Problem:
    return paper_problem(arm(), Q0, np.array([-0.05, 0.02]))  # velocity-limited: p < 1


def assert_safe(P: Problem, res: st.Result, status: str) -> None:
    assert res.status == status
    assert not res.moved
    np.testing.assert_array_equal(res.q, P.q0)
    np.testing.assert_array_equal(res.dq, np.zeros(P.n))
    assert res.p == 0.0 and res.lam is None


def fake_solve(status: str, x_of: object = None):  # type: ignore[no-untyped-def]
    """A stand-in for HighsSolver.solve: ``status`` with ``x_of(lp)`` (zeros by default)."""

    def solve(self: HighsSolver, lp: LinearProgram) -> LpSolution:
        x = np.zeros(lp.c.size) if x_of is None else x_of(lp)  # type: ignore[operator]
        return LpSolution(status, x, np.zeros(lp.c.size), np.zeros(lp.A.shape[0]), "fake", 0.0)

    return solve


@pytest.mark.parametrize("status", [st.SOLVER_ERROR, st.LIMIT_REACHED, st.INFEASIBLE])
@pytest.mark.parametrize("call", list(LP_CALLS))
def test_a_failed_solve_is_a_safe_step(monkeypatch, call: str, status: str) -> None:
    monkeypatch.setattr(HighsSolver, "solve", fake_solve(status))
    P = problem()
    assert_safe(P, LP_CALLS[call](P), status)


def p_one_without_motion(lp: LinearProgram) -> np.ndarray:
    """Claims p = 1 with dq = 0 (and everything else 0): J dq != p dw."""
    x = np.zeros(lp.c.size)
    x[-1] = 1.0
    return x


def far_beyond_the_bounds(lp: LinearProgram) -> np.ndarray:
    """Claims p = 0 with every variable 10 (dq far past the velocity limits)."""
    x = np.full(lp.c.size, 10.0)
    x[-1] = 0.0
    return x


@pytest.mark.parametrize("bad_x", [p_one_without_motion, far_beyond_the_bounds])
@pytest.mark.parametrize("call", list(LP_CALLS))
def test_a_wrong_answer_claimed_optimal_is_downgraded(monkeypatch, call: str, bad_x) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setattr(HighsSolver, "solve", fake_solve(st.OPTIMAL, bad_x))
    P = problem()
    res = LP_CALLS[call](P)
    assert_safe(P, res, st.CHECK_FAILED)
    assert res.binding  # says what failed


def test_lp2_with_multiplier_bounds_checks_the_multipliers(monkeypatch) -> None:
    # The answer without multiplier bounds satisfies every row of eq. 18 and every bound
    # on dq, but its multipliers break the bounds of sec. 3.2.
    free = lp2(problem())
    bound = 0.5 * float(np.abs(free.lam).max())
    P = problem().replace(lam_min=[-bound, -bound], lam_max=[bound, bound])

    def unbounded_answer(lp: LinearProgram) -> np.ndarray:
        return np.concatenate([free.dq, free.lam, [free.p]])

    monkeypatch.setattr(HighsSolver, "solve", fake_solve(st.OPTIMAL, unbounded_answer))
    res = lp2(P, path="highs")
    assert_safe(P, res, st.CHECK_FAILED)
    assert "multiplier" in res.binding


def test_lp2_checks_the_criterion_rows_of_eq18(monkeypatch) -> None:
    # LP1's step keeps every bound and J dq = p dw, but it is not LP2's: the rows
    # [M + Lambda, J^T] [dq; lam] = c decide which step among those is returned.
    P = problem()
    other = lp1(P)
    assert other.status == st.OPTIMAL

    def lp1_answer(lp: LinearProgram) -> np.ndarray:
        return np.concatenate([other.dq, np.zeros(P.m), [other.p]])

    monkeypatch.setattr(HighsSolver, "solve", fake_solve(st.OPTIMAL, lp1_answer))
    res = lp2(P, path="highs")
    assert_safe(P, res, st.CHECK_FAILED)
    assert "eq. 18" in res.binding


def test_a_wrong_ratio_test_falls_back_to_the_singular_path_then_highs(monkeypatch) -> None:
    P = problem()
    good = lp2(P, path="highs")
    lp2_module = sys.modules["lpik.methods.lp2"]
    n, m = P.n, P.m

    def wrong(problem: Problem) -> AffineSolution:
        # Motion that ignores J: J dq != p dw for every p > 0.
        return AffineSolution(np.zeros(n), np.full(n, 1e-3), np.zeros(m), np.zeros(m))

    monkeypatch.setattr(lp2_module, "affine_solution", wrong)
    for expected in ("singular", "highs"):
        assert lp2(P, path="ratio-test").path == expected
        res = lp2(P)
        assert res.status == st.OPTIMAL and res.path == expected
        assert res.p == pytest.approx(good.p, abs=1e-12)
        np.testing.assert_allclose(res.q, good.q, atol=1e-12)
        # then the singular path fails its check too: HiGHS decides
        monkeypatch.setattr(lp2_module, "singular_core", lambda *args: (3, 0.0, -1, 1.0))


def test_nlp_failure_is_a_safe_step(monkeypatch) -> None:
    nlp_module = sys.modules["lpik.methods.nlp"]
    real = nlp_module.minimize

    def failing(*args, **kwargs):  # type: ignore[no-untyped-def]
        res = real(*args, **kwargs)
        res.success = False
        res.message = "simulated failure"
        return res

    monkeypatch.setattr(nlp_module, "minimize", failing)
    P = problem()
    res = solve(P, "nlp", model=arm())
    assert_safe(P, res, st.SOLVER_ERROR)


def test_nlp_wrong_answer_claimed_successful_is_downgraded(monkeypatch) -> None:
    nlp_module = sys.modules["lpik.methods.nlp"]
    real = nlp_module.minimize

    def lying(*args, **kwargs):  # type: ignore[no-untyped-def]
        res = real(*args, **kwargs)
        res.x = np.zeros_like(res.x)
        res.x[-1] = 1.0  # p = 1 without moving: phi(q) - w0 != p dw
        return res

    monkeypatch.setattr(nlp_module, "minimize", lying)
    P = problem()
    assert_safe(P, solve(P, "nlp", model=arm()), st.CHECK_FAILED)


def test_the_reusable_solver_warm_starts_across_steps() -> None:
    # A sequence of pull-in steps with one solver gives the same answers as fresh solvers.
    solver = HighsSolver()
    a = arm()
    q = Q0.copy()
    for _ in range(20):
        P = paper_problem(a, q, np.array([-0.005, 0.0]))
        warm = lp2(P, path="highs", solver=solver)
        cold = lp2(P, path="highs")
        assert warm.status == cold.status == st.OPTIMAL
        np.testing.assert_allclose(warm.q, cold.q, atol=1e-10)
        warm1, cold1 = lp1(P, solver=solver), lp1(P)
        assert warm1.p == pytest.approx(cold1.p, abs=1e-10)
        q = warm.q
