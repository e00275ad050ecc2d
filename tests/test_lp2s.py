"""LP2 with saturation in the null space (``lp2s``): exact, never below LP2, one path."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_reference import SATURATION_ROUNDING, bracket, hard_violation, lp2_reference
from core_strategies import Case, cases, examples
from lpik.methods import solve
from lpik.methods.lp2 import lp2
from lpik.methods.lp2s import joint_bound_index, lp2s, saturated, saturation_passes
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


def test_no_pass_over_nearly_singular_free_joints() -> None:
    """Joints 2 and 3 of this arm are nearly aligned (q3 = 2.5e-5): once joint 1 is saturated,
    the pass over them would race both to a new step for p 0.99999 -> 1, and rounding at
    its Schur condition (~1e10) broke J dq = p dw by 3e-8 (a CI find). It is not taken."""
    from lpik.control.controller import Lp2Controller
    from lpik.robots.planar import planar_arm

    arm = planar_arm([1.0, 1.0, 1.0], q_min=[-1.0, -1.5, -1.0], q_max=[1.0, 0.5, 1.0], qd_max=1.0)
    controller = Lp2Controller(arm, dt=0.01, v_max=1.0, lambda_bound=None)
    q0 = np.array([0.0, -0.5, 2.4574519735179843e-05])
    P = controller.problem(q0, arm.pose(q0) + np.array([0.0, 0.5, 0.0]))
    for res in (lp2s(P), lp2s(P, path="compiled"), controller.step(q0, arm.pose(q0) + [0, 0.5, 0])):
        np.testing.assert_allclose(P.J @ res.dq, res.p * P.dw, rtol=0, atol=1e-15)
        # p as LP2's to the last bits (numpy's and the compiled ratio test round apart by an ulp)
        assert str(res.binding) == "joint 1 upper velocity limit" and res.p == pytest.approx(
            lp2(P).p, abs=1e-15, rel=0
        )


def test_the_condition_of_a_later_pass_is_bounded_not_estimated() -> None:
    """A 5-link arm in the plane (pose task) with joints 3 and 4 nearly aligned: after joint 1
    saturates, the free joints' Schur complement has condition 8e11, which the Cholesky
    estimate puts at 4e7; the pass broke J dq = p dw by 7e-9 (a CI find). It is not taken."""
    from lpik.methods.kkt import condition_bound

    J = [[-3.971151412932255, -3.491725874328052, -2.4942308877239974, -1.496735193797801,
          -0.4992394998716043],
         [1.1173408955669903, 0.23975833367661759, 0.16902113200891467, 0.09829390529461435,
          0.027566678580314363],
         [1.0, 1.0, 1.0, 1.0, 1.0]]  # fmt: skip
    P = Problem(J=J, dw=[0.0, 1e-3, 0.0], q0=[0.5, 1.0, 1e-05, 0.0, 0.015625],
                q_min=[-1.0, 0.0, -0.99999, -1.0, -1.0], q_max=[1.0, 2.0, 1.00001, 1.0, 1.0],
                dq_min=np.full(5, -1e-3), dq_max=np.full(5, 1e-3))  # fmt: skip
    for res in (lp2s(P), lp2s(P, path="compiled")):
        np.testing.assert_allclose(P.J @ res.dq, res.p * P.dw, rtol=0, atol=1e-15)
        assert str(res.binding) == "joint 1 upper velocity limit"
        assert abs(res.p - lp2(P).p) <= 1e-15  # LP2's first pass, on either path
    S = np.array(J) @ np.array(J).T
    assert condition_bound(S, np.linalg.cholesky(S), np.empty(3)) >= np.linalg.cond(S)


def test_a_singular_jacobian_with_rows_of_different_scale_is_singular_on_both_paths() -> None:
    """A planar arm at -pi, stretched (J of rank 1, its rows 1000 times apart), with sec. 3.1's
    pull: the Schur complement is singular (condition 7e18), but the ratio of its Cholesky
    factor's diagonal reads about 4.5e9, under MAX_SCHUR_CONDITION, and rounding put numpy's
    factor on the regular side and the compiled one on the singular side: steps 4e-3 apart
    (a CI find). The shared test, kkt.ill_conditioned, sends both to the singular path."""
    import scipy.linalg as sla

    from lpik.methods.kkt import affine_solution, ill_conditioned

    J = np.array([[1.9999996666667081e-03, 9.9999983333335404e-04],
                  [-1.9999990000000833e00, -9.9999950000004167e-01]])  # fmt: skip
    q0 = [-3.1405926535897932, 0.0]
    P = Problem(J=J, dw=[0.0, 0.0], q0=q0, q_min=[q0[0], -np.inf], q_max=[q0[0] + 1.0, 0.0],
                dq_min=[-0.125, -0.125], dq_max=[0.125, 0.125], Lambda=np.diag([1.0, 0.0]),
                q_ref=[q0[0] + 0.5, 0.0], lam_min=[0.0, -1.0], lam_max=[1.0, 0.0])  # fmt: skip
    S = J @ np.diag([0.5, 1.0]) @ J.T  # J H^-1 J^T with H = M + Lambda
    S = 0.5 * (S + S.T)
    L = np.tril(sla.cho_factor(S, lower=True)[0])  # LAPACK's factor, as the numpy path's
    assert (L[0, 0] / L[1, 1]) ** 2 < 1e10 < np.linalg.cond(S)  # the diagonal ratio misreads
    assert ill_conditioned(S, L, np.empty(2), 1e10)
    assert affine_solution(P) is None
    a, b = lp2s(P), lp2s(P, path="compiled")
    assert a.path == "singular" and b.path == "compiled"
    np.testing.assert_allclose(a.q, b.q, atol=SATURATION_ROUNDING, rtol=0)
    assert a.status == b.status and abs(a.p - b.p) <= SATURATION_ROUNDING


@settings(max_examples=examples(150), deadline=None)
@given(
    lengths=st.lists(st.floats(0.2, 2.0), min_size=2, max_size=5),
    base=st.sampled_from([0.0, np.pi / 2, np.pi, -np.pi / 2]),
    tilt=st.sampled_from([0.0, 1e-6, 1e-4, 1e-3, -1e-3, 1e-2]),
    data=st.data(),
)
def test_a_stretched_arm_takes_one_path_on_both_sides(lengths, base, tilt, data) -> None:
    """A planar arm stretched along an axis, tilted a little: ``J`` has rank 1 and rows
    ``tan(tilt)`` apart, the case where the Cholesky diagonal's ratio of a singular Schur
    complement lands near MAX_SCHUR_CONDITION. Both paths take the same step, whatever
    pull, weights, multiplier bounds and command."""
    pytest.importorskip("numba")
    from core_strategies import LAMBDA_BOUNDS, MARGINS, directions, vectors, weight_fields
    from lpik.robots.planar import planar_arm

    n = len(lengths)
    arm = planar_arm(lengths)
    q0 = np.zeros(n)
    q0[0] = base + tilt
    draw = data.draw
    fields: dict[str, object] = {
        "q_min": q0 - draw(vectors(n, MARGINS)), "q_max": q0 + draw(vectors(n, MARGINS)),
        "dq_min": -draw(vectors(n, st.floats(1e-3, 0.2))),
        "dq_max": draw(vectors(n, st.floats(1e-3, 0.2))),
        "lam_min": -draw(vectors(2, LAMBDA_BOUNDS)), "lam_max": draw(vectors(2, LAMBDA_BOUNDS)),
    }  # fmt: skip
    fields.update(draw(weight_fields(n, q0)))
    dw = draw(directions(2)) * draw(st.sampled_from([0.0, 1e-3, 0.1]))
    P = Problem(J=arm.jacobian(q0), dw=dw, q0=q0, **fields)
    a, b = lp2s(P), lp2s(P, path="compiled")
    if b.path == "compiled" and a.path in ("ratio-test", "singular"):
        np.testing.assert_allclose(a.q, b.q, atol=SATURATION_ROUNDING, rtol=0)
        assert a.status == b.status and abs(a.p - b.p) <= SATURATION_ROUNDING


def test_an_infeasible_pass_never_names_the_joint_it_holds() -> None:
    """Every multiplier held at 0 and joint 2 held at its end-stop: the held pass is infeasible
    on every path (the force f needs a multiplier), and the conflict is the multiplier bound.
    HiGHS's elastic program once named the held joint (its zero-width band turned a slack at
    the solver's tolerance into the largest one; a find of the thorough profile, whose
    problem a smoothing pull made infeasible, until the pull was scaled for the multipliers)."""
    from lpik.robots.planar import planar_arm

    P = Problem(J=planar_arm([1.0, 1.0, 1.0]).jacobian(np.array([0.0, 0.0, 1.0])),
                dw=[0.003, 0.0], q0=[0.0, 0.0, 1.0], q_min=[0.0, 0.0, 1.0], q_max=[1.0, 1.0, 2.0],
                dq_min=np.full(3, -0.125), dq_max=np.full(3, 0.125), f=[0.0, 0.0, 0.5],
                lam_min=[0.0, 0.0], lam_max=[0.0, 0.0])  # fmt: skip
    first = lp2(P, path="ratio-test", name_outside=False)
    assert str(first.binding) == "joint 2 lower end-stop"
    held = saturated(P, *joint_bound_index(P)[first.binding])
    for path in ("ratio-test", "highs"):
        res = lp2(held, path=path, name_outside=False)
        assert (res.status, str(res.binding)) == ("infeasible", "multiplier 1 lower bound"), path


def test_a_row_that_repeats_an_end_stop_is_named_alike_on_every_path() -> None:
    """Joint 3 sits at its upper end-stop and an extra row says the same (0.001 q3 <= 0.001):
    both stop p at 0.2222..., one ulp apart on the two paths. Each path named the one its
    rounding put first, and lp2s then saturated on one path only (p 1 against 0.22; a CI
    find). Limits within INTERVAL_TOL in p tie, and a tie goes to the first entry."""
    from lpik.robots.planar import planar_arm

    P = Problem(J=planar_arm([1.0, 1.0, 1.0]).jacobian(np.array([0.0, 0.0, 1.0])),
                dw=[0.0, -0.003], q0=[0.0, 0.0, 1.0], q_min=[-1.0, 0.0, -np.inf],
                q_max=[0.0, 1.0, 1.0], dq_min=np.full(3, -0.125), dq_max=np.full(3, 0.125),
                f=[0.0, 0.001, 0.0], G=[[0.0, 0.0, 0.0], [0.0, 0.0, 0.001]],
                h=[0.0, 0.001])  # fmt: skip
    for path in ("ratio-test", "compiled", "highs"):
        assert str(lp2(P, path=path).binding) == "joint 3 upper end-stop", path
    a, b = lp2s(P), lp2s(P, path="compiled")
    assert a.p == b.p == 1.0
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-15)


def test_two_joints_that_tie_are_both_saturated_on_every_path() -> None:
    """Joints 2 and 4 have the same Jacobian column and reach their velocity limits at
    the same p (0.3136): the pass that saturates the second gains nothing but rounding.
    Whether the passes went on (to p = 0.3387, joint 5 saturated too) was left to the
    last bits of p, and the two paths parted (a hypothesis find). A tie goes on."""
    J = [[0.4516054941670442, 0.4516054941670442, 0.6334649795321805, 0.4516054941670442,
          0.24123774796507008, 0.0308700017630959],
         [0.9464097056972777, -0.05359029430272233, 0.029639073006706096,
          -0.05359029430272233, 0.0814852821643125, 0.21656085863134744]]  # fmt: skip
    q0 = [0.0, 2.0, -np.pi, -1.0, 0.0, 2.0]
    P = Problem(J=J, dw=[0.42375, 0.0], q0=q0, q_min=q0, q_max=[0.0, np.inf, -np.pi, 0.0, 1.0, 3.0],
                dq_min=np.full(6, -0.125), dq_max=np.full(6, 0.125),
                q_ref=[0.0, 2.0, -np.pi, -0.5, 0.5, 2.5])  # fmt: skip
    a, b = lp2s(P), lp2s(P, path="compiled")
    assert a.p == pytest.approx(0.3386759626565122, abs=1e-12) and b.p == pytest.approx(a.p)
    assert str(a.binding) == str(b.binding) == "joint 5 upper velocity limit"
    np.testing.assert_allclose(a.dq, b.dq, rtol=0, atol=1e-15)
    np.testing.assert_allclose(a.dq[[1, 3, 4]], 0.125, rtol=0, atol=1e-15)


def test_the_reference_holds_where_highs_drops_a_jacobian_entry() -> None:
    """A hypothesis draw: two joints pinned, the third on its end-stop, J[0, 0] = 1e-9 (HiGHS
    drops it). In absolute coordinates the reference's task row moved by 3e-9 and it found
    no point; in the step it finds the step lp2s takes (none: J dq = 0 admits no motion)."""
    q0 = np.array([-3.14059265, 0.0, -3.14059265])
    P = Problem(J=[[9.99999306e-10, -9.99998833e-04, -1.99999867e-03],
                   [-1.00000100e+00, -1.49999937e-06, 9.99998000e-01]],
                dw=[0.0, 0.0], q0=q0, q_min=q0, q_max=[-3.14059265, 0.0, -2.14059265],
                dq_min=np.full(3, -0.125), dq_max=np.full(3, 0.125), Lambda=np.zeros((3, 3)),
                q_ref=[-3.14059265, 0.0, -2.64059265])  # fmt: skip
    res, b = lp2s(P), bracket(lp2_reference, P, criterion=True)
    assert b.loose.feasible and b.exact.feasible
    np.testing.assert_allclose(b.exact.q, q0, rtol=0, atol=1e-9)
    assert res.moved and np.array_equal(res.q, q0) and res.p <= b.loose.p + 1e-7


@settings(max_examples=examples(250), deadline=None)
@given(case=cases(well_posed=True))
def test_lp2s_is_exact_never_below_lp2_and_keeps_every_limit(case: Case) -> None:
    P = case.problem
    res, plain = lp2s(P), lp2(P)
    # lp2s moves wherever LP2 does, and also where LP2 has no feasible p (a joint's
    # conflict saturated, the others resolving the criterion)
    assert res.moved or not plain.moved
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
        # the same step to rounding (SATURATION_ROUNDING), and a step of 1e-13 may count
        # as infeasible on one path and as a step on the other
        np.testing.assert_allclose(a.q, b.q, atol=SATURATION_ROUNDING, rtol=0)
        if a.status == b.status:
            assert abs(a.p - b.p) <= SATURATION_ROUNDING
            # a limit binds on both or neither; two limits reached at the same p (a tie,
            # common at p = 0) may be named either way by the two paths' rounding
            assert (a.binding is None) == (b.binding is None)


def test_the_paper_pull_in_keeps_p_at_one() -> None:
    """LP2 stops at joint 1's end-stop (p -> 0, x = 1.83 m); saturated, the other joints pull
    the tool in all the way along the commanded line, smoothly."""
    setup = get_scenario("pull-in").setup(PLANAR)
    plain, sat = setup.run("lp2", on_stall=None), setup.run("lp2s", on_stall=None)  # strict steps
    assert (plain.p == 0).any() and (sat.p == 1).all()
    assert sat.position_end[0] < 1.3 < plain.position_end[0]
    assert np.allclose(sat.position[:, 1], sat.position[0, 1], atol=1e-3)  # on the line, to 1 mm
    assert sat.metrics().jitter < 2 * plain.metrics().jitter  # no chatter where it saturates
    assert set(sat.status) == {OPTIMAL}


@pytest.mark.parametrize("robot", [PLANAR, "panda"])
def test_the_controller_saturates_as_simulate_does(robot: str) -> None:
    pytest.importorskip("numba")
    setup = get_scenario("pull-in").setup(robot)
    log = setup.run("lp2s", on_stall=None)  # the saturating method itself, no stall stage
    controller = setup.controller(saturate=True, on_stall=None)
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


def test_a_step_lp2_finds_infeasible_is_saturated_too() -> None:
    """A moving arm whose acceleration limits keep LP2's line dq(p) (eq. 18) off their band:
    LP2 has no feasible p; lp2s fixes the joint of the conflict at that bound, the others
    resolve the criterion, and the step goes on, exact, within every limit, on both paths."""
    from lpik.limits import AccelerationLimits, build_problem, standard_limits
    from lpik.robots.planar import planar_arm

    arm = planar_arm([1.0] * 4, q_min=np.full(4, -2.5), q_max=np.full(4, 2.5), qd_max=1.0)
    q = np.array([-0.16669391, -0.06087301, -0.45539972, 0.17496932])
    prev = np.array([-0.16374539, -0.06121909, -0.45944306, 0.17490749])
    limits = [*standard_limits(arm), AccelerationLimits(np.full(4, 5.0))]
    P = build_problem(arm.jacobian(q), np.array([0.00584197, -0.00328419]), q, limits,
                      dt=0.01, q_prev=prev, joint_names=arm.joint_names)  # fmt: skip
    plain, res = lp2(P), lp2s(P)
    assert plain.status == "infeasible" and str(plain.binding) == "joint 4 upper acceleration limit"
    assert res.status == OPTIMAL and res.p > 0.3
    assert hard_violation(P, res.q, res.lam) <= 1e-12
    np.testing.assert_allclose(P.J @ res.dq, res.p * P.dw, atol=1e-15)
    assert res.dq[3] == P.step_bounds()[1][3]  # saturated at the bound of the conflict
    compiled = lp2s(P, path="compiled")
    assert (compiled.status, compiled.binding) == (res.status, res.binding)
    np.testing.assert_allclose(compiled.q, res.q, atol=1e-12, rtol=0)
    _, final = saturation_passes(P)  # exact: the LP stated directly over the saturated problem
    b = bracket(lp2_reference, final, criterion=True)
    assert b.loose.feasible and res.p <= b.loose.p + 1e-7
    proven = b.attainable()
    assert proven is not None and res.p >= proven - 1e-7


@settings(max_examples=examples(150), deadline=None)
@given(case=cases(well_posed=True))
def test_a_saturated_joint_is_named_only_along_a_direction_the_others_lost(case: Case) -> None:
    """A joint held at one value is not a limit that stops p where the free joints can still
    take the command: LP2's ratio test resolves the criterion without it, and HiGHS's duals
    (which may be largest on it) must not name it either, else lp2s's next pass would
    saturate it again. Where the free joints have lost a direction the command (or the held
    joint's own motion) needs, both name the held joint (the passes then end:
    lpik.methods.lp2s._names_free_joint)."""
    P = case.problem
    first = lp2(P, path="ratio-test", name_outside=False)
    index = joint_bound_index(P)
    if first.status != OPTIMAL or first.binding not in index:
        return
    joint, side = index[first.binding]
    held = saturated(P, joint, side)
    lower, upper = held.step_bounds()[:2]
    free = lower != upper
    rank = np.linalg.matrix_rank(held.J[:, free]) if free.any() else 0
    for path in ("ratio-test", "highs"):
        res = lp2(held, path=path, name_outside=False)
        named = res.binding
        if named is not None and named.kind in ("end-stop", "velocity", "acceleration"):
            assert not (named.index == joint and rank == held.m), (path, named, rank)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_a_pass_pays_only_for_motion_in_proportion_to_the_p_it_gains(seed: int) -> None:
    """worth_it (numpy) and the compiled passes' twin decide alike.

    A sliver of p for a large swing of the joints (the step-input jitter of
    benchmarks/quality.py, scenario 4) does not pay.
    """
    from lpik.fast.saturation import _worth_it
    from lpik.methods.lp2s import worth_it
    from lpik.result import Result
    from lpik.tolerances import SATURATION_MAX_PRICE

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 8))
    dq1, dq2 = rng.normal(size=n), rng.normal(size=n) * 10.0 ** rng.uniform(-3, 1)
    p1 = float(rng.uniform(0.0, 1.0))
    p2 = min(1.0, p1 + float(10.0 ** rng.uniform(-6, 0)))

    def result(dq: np.ndarray, p: float) -> Result:
        return Result(status=OPTIMAL, q=dq, dq=dq, p=p, lam=None, binding=None, method="lp2")

    says = worth_it(result(dq1, p1), result(dq2, p2))
    assert says == _worth_it(np.r_[dq1, 0.0], dq2, p1, p2)
    price = np.linalg.norm(dq2 - dq1) / (p2 - p1) / (np.linalg.norm(dq1) / p1)
    if abs(price / SATURATION_MAX_PRICE - 1.0) > 1e-9:  # (not on the edge, where rounding decides)
        assert says == (price <= SATURATION_MAX_PRICE)


def test_a_condition_bound_past_the_largest_float_is_inf_without_a_warning() -> None:
    """Forward substitution through L with small pivots: L^-1's entries reach 1e200, whose
    squares overflow. The bound is inf (singular) on both paths, and numpy warns nothing
    (a hypothesis draw of a fresh-clone run warned 'overflow encountered')."""
    import warnings

    from lpik.methods.kkt import condition_bound

    numba = pytest.importorskip("numba")
    compiled_condition_bound = numba.njit(condition_bound)  # as lpik.fast.lp2_kernel compiles it

    L = np.array([[1e-100, 0.0, 0.0], [1.0, 1e-100, 0.0], [1.0, 1.0, 1e-100]])
    S = L @ L.T
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert condition_bound(S, L, np.empty(3)) == math.inf
    assert compiled_condition_bound(S, L, np.empty(3)) == math.inf
