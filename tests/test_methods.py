"""One shared suite over every method, and each method against an independent reference."""

from __future__ import annotations

import numpy as np
import pytest

from core_reference import (
    HARD_TOL,
    hard_violation,
    l1_reference,
    lp1_reference,
    task_error,
    weighted_reference,
)
from core_strategies import paper_problem
from lpik import result as st
from lpik.labels import SINGULARITY
from lpik.methods import ALL_METHODS, METHODS, solve, yoshikawa_manipulability
from lpik.problem import Problem
from lpik.robots.base import TaskModel
from lpik.robots.planar import planar_arm

LIMIT_AWARE = frozenset(name for name, spec in METHODS.items() if spec.limit_aware)

#: Methods whose step satisfies J dq = p dw exactly (the linearisation, eqs. 2, 12, 15).
LINEARISED = ("pinv", "weighted", "lp1", "l1", "lp2")
CLASSICAL = ("pinv", "weighted", "robust")

Q0 = np.radians([60.0, -30.0, -30.0, -30.0])
Q0_AT_STOP = np.radians([95.0, -30.0, -30.0, -30.0])


def arm() -> TaskModel:
    return planar_arm([1.0, 1.0, 1.0, 1.0], q_min=-np.pi, q_max=np.pi, qd_max=1.0)


def scenario(name: str) -> Problem:
    """Steps of the paper's 4-link arm: free, velocity-limited, at an end-stop, with a row."""
    a = arm()
    if name == "free":
        return paper_problem(a, Q0, np.array([-0.005, 0.0]))
    if name == "velocity-limited":
        return paper_problem(a, Q0, np.array([-0.05, 0.02]))
    if name == "at-end-stop":
        q_max = np.full(4, np.pi)
        q_max[0] = np.radians(95.0)
        return paper_problem(a, Q0_AT_STOP, np.array([-0.005, 0.0]), q_max=q_max)
    if name == "obstacle-row":
        # the elbow (joint 2's angle sum) may not grow: q1 + q2 <= q1_0 + q2_0 + 0.001
        G = np.array([[1.0, 1.0, 0.0, 0.0]])
        return paper_problem(
            a, Q0, np.array([-0.005, 0.005]), G=G, h=G @ Q0 + 0.001, row_labels=["obstacle"]
        )
    if name == "weighted-smoothing":
        return paper_problem(
            a, Q0, np.array([-0.005, 0.0]), M=[1.0, 2.0, 2.0, 4.0], Lambda=[0.002] * 4
        )
    raise KeyError(name)


SCENARIOS = ["free", "velocity-limited", "at-end-stop", "obstacle-row", "weighted-smoothing"]


@pytest.fixture(scope="module")
def results() -> dict[tuple[str, str], st.Result]:
    """Every method on every scenario, solved once for the shared suite."""
    return {
        (method, name): solve(scenario(name), method, model=arm())
        for method in ALL_METHODS
        for name in SCENARIOS
    }


@pytest.mark.parametrize("name", SCENARIOS)
@pytest.mark.parametrize("method", ALL_METHODS)
def test_every_method_keeps_the_result_contract(
    results: dict[tuple[str, str], st.Result], method: str, name: str
) -> None:
    P = scenario(name)
    res = results[method, name]
    assert res.method == method
    assert res.status in st.STATUSES
    assert res.moved, (res.status, res.binding)
    assert res.q.shape == res.dq.shape == (P.n,)
    np.testing.assert_allclose(res.q, P.q0 + res.dq, rtol=0, atol=1e-15)
    assert isinstance(res.p, float) and 0.0 <= res.p <= 1.0
    if res.lam is not None:
        assert res.lam.shape == (P.m,)
    if res.p < 1.0 - 1e-9 and method != "robust":
        assert res.binding is not None
    d = res.to_dict()
    assert set(d) == {"q", "dq", "p", "lam", "status", "binding", "pull_scale"}


@pytest.mark.parametrize("name", SCENARIOS)
@pytest.mark.parametrize("method", LINEARISED)
def test_linearised_methods_achieve_p_dw(
    results: dict[tuple[str, str], st.Result], method: str, name: str
) -> None:
    P = scenario(name)
    res = results[method, name]
    assert task_error(P, res.dq, res.p) <= 1e-9
    assert res.residual == pytest.approx(np.abs(P.J @ res.dq - res.p * P.dw).max(), abs=1e-15)


@pytest.mark.parametrize("name", SCENARIOS)
def test_robust_reports_the_achieved_fraction(
    results: dict[tuple[str, str], st.Result], name: str
) -> None:
    # Docstring: p = (dw . J dq) / |dw|^2 clipped to [0, 1]; residual = max |J dq - p dw|.
    P = scenario(name)
    res = results["robust", name]
    achieved = float(P.dw @ (P.J @ res.dq) / (P.dw @ P.dw))
    assert res.p == pytest.approx(min(1.0, max(0.0, achieved)), abs=1e-15)
    assert res.p < 1.0  # the damping always gives up a little of dw
    assert res.residual == pytest.approx(np.abs(P.J @ res.dq - res.p * P.dw).max(), abs=1e-15)


@pytest.mark.parametrize("name", SCENARIOS)
@pytest.mark.parametrize("method", sorted(LIMIT_AWARE))
def test_limit_aware_methods_break_no_hard_limit(
    results: dict[tuple[str, str], st.Result], method: str, name: str
) -> None:
    res = results[method, name]
    assert hard_violation(scenario(name), res.q, res.lam) <= HARD_TOL


@pytest.mark.parametrize("name", SCENARIOS)
@pytest.mark.parametrize("method", CLASSICAL)
def test_classical_methods_never_violate_silently(
    results: dict[tuple[str, str], st.Result], method: str, name: str
) -> None:
    P = scenario(name)
    res = results[method, name]
    violation = hard_violation(P, res.q)
    if violation > HARD_TOL:
        assert res.status == st.VIOLATES_LIMITS
        assert res.binding is not None
    else:
        assert res.status == st.OPTIMAL


def test_classical_step_into_the_end_stop_is_flagged() -> None:
    for method in CLASSICAL:
        res = solve(scenario("at-end-stop"), method)
        assert res.status == st.VIOLATES_LIMITS
        assert res.binding == "joint 1 upper end-stop"
        assert res.q[0] > np.radians(95.0)  # the step is the method's own, never clamped


def test_the_paper_ordering_of_dexterity(results: dict[tuple[str, str], st.Result]) -> None:
    for name in SCENARIOS:
        assert results["lp1", name].p >= results["lp2", name].p - 1e-12
        assert results["l1", name].p == pytest.approx(results["lp1", name].p, abs=1e-8)
    assert results["lp2", "at-end-stop"].binding == "joint 1 upper end-stop"
    assert results["lp2", "obstacle-row"].binding == "obstacle"


# --- independent references ---------------------------------------------------------------


def random_problem(seed: int, m: int = 2, n: int = 5, **fields: object) -> Problem:
    rng = np.random.default_rng(seed)
    return Problem(
        J=rng.normal(size=(m, n)), dw=rng.normal(size=m) * 0.01, q0=rng.normal(size=n), **fields
    )


@pytest.mark.parametrize("seed", range(5))
def test_pinv_is_numpys_pseudo_inverse(seed: int) -> None:
    P = random_problem(seed, M=np.diag(np.arange(1.0, 6.0)), f=np.ones(5))  # M, f ignored
    res = solve(P, "pinv")
    np.testing.assert_allclose(res.dq, np.linalg.pinv(P.J) @ P.dw, rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(res.lam, -np.linalg.solve(P.J @ P.J.T, P.dw), rtol=1e-10)
    assert res.p == 1.0


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("k", [None, 0.01, 0.5])
def test_robust_is_the_damped_least_squares_step(seed: int, k: float | None) -> None:
    P = random_problem(seed, k=k)
    res = solve(P, "robust")
    kk = yoshikawa_manipulability(P.J) if k is None else k
    if k is None:  # the default damping is Yoshikawa's measure
        assert kk == pytest.approx(np.sqrt(np.linalg.det(P.J @ P.J.T)), rel=1e-12)
    expected = P.J.T @ np.linalg.solve(P.J @ P.J.T + kk * np.eye(P.m), P.dw)
    np.testing.assert_allclose(res.dq, expected, rtol=1e-10, atol=1e-15)


def test_robust_with_zero_damping_is_the_weighted_step() -> None:
    P = random_problem(3, k=0.0)
    np.testing.assert_allclose(solve(P, "robust").dq, solve(P, "weighted").dq, atol=1e-14)


@pytest.mark.parametrize("seed", range(5))
def test_weighted_is_a_direct_kkt_solve(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    B = rng.normal(size=(5, 5))
    P = random_problem(
        seed,
        M=B @ B.T + np.eye(5),
        f=rng.normal(size=5) * 0.1,
        Lambda=rng.uniform(0, 2, 5),
        q_ref=rng.normal(size=5),
    )
    res = solve(P, "weighted")
    q, lam = weighted_reference(P)
    np.testing.assert_allclose(res.q, q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.lam, lam, rtol=1e-9, atol=1e-12)
    assert res.p == 1.0


@pytest.mark.parametrize("method", ["pinv", "weighted", "robust"])
def test_classical_methods_at_a_singularity_return_a_safe_step(method: str) -> None:
    P = paper_problem(arm(), np.zeros(4), np.array([0.005, 0.0]))  # stretched: rank 1
    res = solve(P, method)
    assert res.status == st.SINGULAR
    assert not res.moved and res.p == 0.0 and res.lam is None
    np.testing.assert_array_equal(res.q, P.q0)


@pytest.mark.parametrize("method", sorted(LIMIT_AWARE))
def test_the_edge_singularity_is_named(method: str) -> None:
    # Stretched arm, commanded along itself: no limit is active, the kinematics stops p.
    P = paper_problem(arm(), np.zeros(4), np.array([0.005, 0.0]))
    res = solve(P, method, model=arm())
    assert res.moved
    assert res.p == pytest.approx(0.0, abs=1e-9)
    assert res.binding == SINGULARITY


@pytest.mark.parametrize("name", SCENARIOS)
def test_lp1_against_linprog(results: dict[tuple[str, str], st.Result], name: str) -> None:
    ref = lp1_reference(scenario(name))
    assert results["lp1", name].p == pytest.approx(ref.p, abs=1e-9)


@pytest.mark.parametrize("name", SCENARIOS)
def test_l1_against_linprog(results: dict[tuple[str, str], st.Result], name: str) -> None:
    P = scenario(name)
    res = results["l1", name]
    full = l1_reference(P)
    if full.feasible:
        assert res.status == st.OPTIMAL and res.p == 1.0
        assert np.abs(res.dq).sum() == pytest.approx(full.objective, rel=1e-7, abs=1e-12)
    else:
        assert res.status == st.SCALED
        assert res.p == pytest.approx(results["lp1", name].p, abs=1e-8)
        scaled = l1_reference(P, res.p)
        assert np.abs(res.dq).sum() == pytest.approx(scaled.objective, rel=1e-7, abs=1e-12)
        assert res.binding == results["lp1", name].binding


def test_l1_is_sparse_where_the_2_norm_is_not() -> None:
    P = scenario("free")
    l1_step = solve(P, "l1").dq
    assert np.count_nonzero(np.abs(l1_step) > 1e-12) <= P.m  # an LP vertex
    assert np.abs(l1_step).sum() <= np.abs(solve(P, "pinv").dq).sum() + 1e-15


# --- the nonlinear baseline -----------------------------------------------------------------


@pytest.mark.parametrize("name", SCENARIOS)
def test_nlp_lands_on_the_scaled_command_with_the_nonlinear_kinematics(
    results: dict[tuple[str, str], st.Result], name: str
) -> None:
    P = scenario(name)
    res = results["nlp", name]
    a = arm()
    w0 = a.position(P.q0)
    np.testing.assert_allclose(a.position(res.q), w0 + res.p * P.dw, rtol=0, atol=1e-9)
    assert res.residual <= 1e-7


@pytest.mark.parametrize("name", SCENARIOS)
def test_nlp_dexterity_is_close_to_lp1s_for_small_steps(
    results: dict[tuple[str, str], st.Result], name: str
) -> None:
    # The linearisation error of one small step is second order in the step.
    assert results["nlp", name].p == pytest.approx(results["lp1", name].p, rel=1e-2, abs=1e-6)


def test_nlp_needs_the_model_and_a_matching_one() -> None:
    P = scenario("free")
    with pytest.raises(ValueError, match="^method:"):
        solve(P, "nlp")
    with pytest.raises(ValueError, match="^model:"):
        solve(P, "nlp", model=planar_arm([1.0, 1.0, 1.0]))


def test_nlp_on_the_pose_task() -> None:
    a = planar_arm([1.0, 1.0, 1.0, 1.0], task="pose")
    P = Problem(
        J=a.jacobian(Q0), dw=[-0.005, 0.002, 0.01], q0=Q0, dq_min=[-0.01] * 4, dq_max=[0.01] * 4
    )
    res = solve(P, "nlp", model=a)
    assert res.status == st.OPTIMAL
    np.testing.assert_allclose(a.difference(a.pose(Q0), a.pose(res.q)), res.p * P.dw, atol=1e-9)


# --- failures become safe steps --------------------------------------------------------------


def crossed_problem() -> Problem:
    """q0 lies 0.5 rad beyond joint 1's upper end-stop, and one step moves at most 0.01 rad."""
    q0 = Q0.copy()
    q0[0] = np.pi + 0.5
    return paper_problem(arm(), q0, np.array([-0.005, 0.0]))


@pytest.mark.parametrize("method", sorted(LIMIT_AWARE))
def test_a_state_past_an_end_stop_moves_back_with_every_method(method: str) -> None:
    P = crossed_problem()
    res = solve(P, method, model=arm())
    assert res.status == st.RECOVERING and res.moved
    assert res.binding == "joint 1 upper end-stop"
    # back at joint 1's full speed (one step: 0.01 rad), never further out
    assert res.q[0] == pytest.approx(P.q0[0] + P.dq_min[0])
    lower, upper = P.step_bounds()[:2]
    assert np.all(res.dq >= lower - 1e-12) and np.all(res.dq <= upper + 1e-12)


@pytest.mark.parametrize("method", sorted(LIMIT_AWARE))
def test_an_infeasible_problem_gives_the_safe_step(method: str) -> None:
    # two rows that no q satisfies (joint 1 below q0 - 0.1 and above q0 + 0.1)
    P = paper_problem(arm(), Q0, np.array([-0.005, 0.0])).replace(
        G=[[1.0, 0.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0]],
        h=[Q0[0] - 0.1, -Q0[0] - 0.1],
        row_labels=None,
    )
    res = solve(P, method, model=arm())
    assert res.status in (st.INFEASIBLE, st.SOLVER_ERROR) and not res.moved
    np.testing.assert_array_equal(res.q, P.q0)  # at rest: the safe step does not move
    assert res.p == 0.0 and res.lam is None


@pytest.mark.parametrize("method", CLASSICAL)
def test_classical_methods_on_an_infeasible_problem_say_they_violate(method: str) -> None:
    res = solve(crossed_problem(), method)
    assert res.status == st.VIOLATES_LIMITS
    assert res.binding is not None and res.binding.startswith("joint 1")


def test_every_method_is_listed() -> None:
    assert set(ALL_METHODS) == {"pinv", "weighted", "robust", "lp1", "l1", "lp2", "lp2s", "nlp"}
    assert set(METHODS) == set(ALL_METHODS)
    assert {name for name, spec in METHODS.items() if spec.needs_model} == {"nlp"}
    assert LIMIT_AWARE <= set(ALL_METHODS)
