"""LP2 with saturation in the null space (``lp2s``): exact, never below LP2, one path."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from core_reference import bracket, hard_violation, lp2_reference
from core_strategies import Case, cases, examples
from lpik.methods import solve
from lpik.methods.lp2 import lp2
from lpik.methods.lp2s import lp2s, saturation_passes
from lpik.paper.scenarios import PLANAR, get_scenario
from lpik.problem import Problem
from lpik.result import OPTIMAL


def test_a_joint_at_its_end_stop_hands_the_command_to_the_others() -> None:
    # LP2 ties both joints to p (dq = p/2 each): joint 1's end-stop 0.1 away stops p at 0.2.
    # Saturated, joint 1 stays at 0.1 and joint 2 carries the rest: p = 1.
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], q_max=[0.1, 2.0])
    assert lp2(P).p == pytest.approx(0.2)
    res = lp2s(P)
    assert (res.status, res.method, res.p, res.binding) == (OPTIMAL, "lp2s", 1.0, None)
    np.testing.assert_allclose(res.q, [0.1, 0.9])
    # both at their end-stops before the command is met: the last one names the limit
    Q = P.replace(q_max=[0.1, 0.2])
    res = lp2s(Q)
    assert res.p == pytest.approx(0.3) and res.binding == "joint 2 upper end-stop"


def test_no_free_redundancy_left_stops_the_passes() -> None:
    # m = 2, n = 3: one joint may saturate; the second binding joint then stops the step
    P = Problem(J=[[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]], dw=[1.0, 1.0], q0=[0.0, 0.0, 0.0],
                q_max=[0.1, 0.2, 5.0])  # fmt: skip
    best, final = saturation_passes(P)
    assert int(final.pinned()[0].sum()) == 1
    assert lp2s(P).p == best.p >= lp2(P).p


@settings(max_examples=examples(250), deadline=None)
@given(case=cases(well_posed=True))
def test_lp2s_is_exact_never_below_lp2_and_keeps_every_limit(case: Case) -> None:
    P = case.problem
    res, plain = lp2s(P), lp2(P)
    assert res.moved == plain.moved
    if not res.moved:
        return
    assert res.p >= plain.p - 1e-12  # each pass starts from the last one's answer
    assert hard_violation(P, res.q, res.lam) <= 1e-7
    # (1e-8: a pass over a nearly rank-deficient set of free joints takes the singular path)
    np.testing.assert_allclose(P.J @ res.dq, res.p * P.dw, atol=1e-8)
    if plain.p >= 1.0:
        np.testing.assert_array_equal(res.q, plain.q)  # nothing to saturate: LP2 itself
    # exact: the LP stated directly over the saturated problem (linprog, absolute q)
    _, final = saturation_passes(P)
    b = bracket(lp2_reference, final, criterion=True)
    assert b.loose.feasible and res.p <= b.loose.p + 1e-7
    proven = b.attainable()
    assert proven is None or res.p >= proven - 1e-7


@settings(max_examples=examples(150), deadline=None)
@given(case=cases(well_posed=True))
def test_the_compiled_passes_equal_the_numpy_passes(case: Case) -> None:
    pytest.importorskip("numba")
    P = case.problem
    a, b = lp2s(P), lp2s(P, path="compiled")
    if b.path == "compiled" and a.path == "ratio-test":
        # the same step to rounding: passes over fewer free joints may be ill-conditioned
        # (Schur condition up to 1e10), and a step of 1e-13 may count as infeasible on one
        # path and as a step on the other
        np.testing.assert_allclose(a.q, b.q, atol=1e-7, rtol=0)
        if a.status == b.status:
            assert abs(a.p - b.p) <= 1e-7
            # a limit binds on both or neither; two limits reached at the same p (a tie,
            # common at p = 0) may be named either way by the two paths' rounding
            assert (a.binding is None) == (b.binding is None)


def test_the_paper_pull_in_keeps_p_at_one() -> None:
    """LP2 stops at joint 1's end-stop (p -> 0, x = 1.83 m); saturated, the other joints pull
    the tool in all the way along the commanded line, smoothly."""
    setup = get_scenario("pull-in").setup(PLANAR)
    plain, sat = setup.run("lp2"), setup.run("lp2s")
    assert (plain.p == 0).any() and (sat.p == 1).all()
    assert sat.position_end[0] < 1.3 < plain.position_end[0]
    assert np.allclose(sat.position[:, 1], sat.position[0, 1], atol=1e-3)  # on the line, to 1 mm
    assert sat.metrics().jitter < 2 * plain.metrics().jitter  # no chatter where it saturates
    assert set(sat.status) == {OPTIMAL}


@pytest.mark.parametrize("robot", [PLANAR, "panda"])
def test_the_controller_saturates_as_simulate_does(robot: str) -> None:
    pytest.importorskip("numba")
    setup = get_scenario("pull-in").setup(robot)
    log = setup.run("lp2s")
    controller = setup.controller(saturate=True)
    q, prev = setup.q0.copy(), None
    for k in range(setup.steps):
        res = controller.step(q, setup.target, prev)
        assert res.method == "lp2s"
        expected = log.q[k + 1] if k + 1 < setup.steps else log.q_end
        np.testing.assert_allclose(res.q, expected, rtol=0, atol=1e-9)
        assert res.binding == log.binding[k]
        prev, q = q, res.q


def test_solve_and_the_registry_know_lp2s() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], q_max=[0.1, 2.0])
    assert solve(P, "lp2s").p == 1.0
