"""LP2 (eqs. 15-18, secs. 3.1-3.2): the ratio test against HiGHS and independent references."""

from __future__ import annotations

import numpy as np
import pytest

from core_reference import lp2_reference, weighted_reference
from core_strategies import paper_problem
from lpik import result as st
from lpik.labels import SINGULARITY
from lpik.methods import affine_solution, lp1, lp2, ratio_test, weighted
from lpik.methods.kkt import smoothing, smoothing_scale
from lpik.problem import Problem
from lpik.robots.base import TaskModel
from lpik.robots.planar import planar_arm

PULL_IN = np.array([-0.005, 0.0])  # one step of the paper's pull-in command [m]


def both_paths(P: Problem) -> tuple[st.Result, st.Result]:
    return lp2(P, path="ratio-test"), lp2(P, path="highs")


def assert_paths_agree(P: Problem, *, tol: float = 1e-9, same_binding: bool = True) -> st.Result:
    fast, slow = both_paths(P)
    assert fast.path == "ratio-test" and slow.path == "highs"
    assert fast.status == slow.status
    assert fast.p == pytest.approx(slow.p, abs=tol)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=tol)
    if fast.lam is None or slow.lam is None:
        assert fast.lam is None and slow.lam is None
    else:
        np.testing.assert_allclose(fast.lam, slow.lam, rtol=tol, atol=tol)
    if same_binding:
        assert fast.binding == slow.binding
    return fast


def assert_matches_reference(P: Problem, res: st.Result, tol: float = 1e-7) -> None:
    ref = lp2_reference(P)
    assert ref.feasible
    assert res.p == pytest.approx(ref.p, abs=tol)
    np.testing.assert_allclose(res.q, ref.q, rtol=0, atol=tol)
    np.testing.assert_allclose(res.lam, ref.lam, rtol=tol, atol=tol)


# --- the paper's arm -------------------------------------------------------------------


def test_free_step_equals_eq7s_weighted_step(paper_arm: TaskModel, paper_q0: np.ndarray) -> None:
    P = paper_problem(paper_arm, paper_q0, PULL_IN)
    res = assert_paths_agree(P)
    assert res.status == st.OPTIMAL and res.p == 1.0 and res.binding is None
    w = weighted(P)
    np.testing.assert_allclose(res.q, w.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.lam, w.lam, rtol=1e-10, atol=1e-14)
    q_ref, lam_ref = weighted_reference(P)
    np.testing.assert_allclose(res.q, q_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.lam, lam_ref, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize(
    "weights",
    [
        {"M": [1.0, 2.0, 3.0, 4.0]},
        {"M": [2.0, 1.0, 1.0, 0.5], "f": [0.001, -0.002, 0.0, 0.001]},
        {"Lambda": [0.5, 0.5, 0.5, 0.5]},
        {"Lambda": [1.0, 0.0, 2.0, 0.0], "q_ref": [1.0, -0.5, -0.5, -0.5], "M": [1, 1, 2, 2]},
    ],
    ids=["M", "M-f", "Lambda-midpoint", "Lambda-q_ref"],
)
def test_weighted_lp2_equals_eq7_when_no_bound_is_active(
    paper_arm: TaskModel, paper_q0: np.ndarray, weights: dict[str, object]
) -> None:
    P = paper_problem(
        paper_arm, paper_q0, PULL_IN, dq_min=-np.ones(4), dq_max=np.ones(4), **weights
    )
    res = assert_paths_agree(P)
    assert res.p == 1.0
    q_ref, lam_ref = weighted_reference(P)
    np.testing.assert_allclose(res.q, q_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.lam, lam_ref, rtol=1e-9, atol=1e-12)
    w = weighted(P)
    np.testing.assert_allclose(res.q, w.q, rtol=0, atol=1e-12)


def test_joint_1_at_its_end_stop_stops_the_pull_in(
    paper_arm: TaskModel, paper_q0: np.ndarray
) -> None:
    # Sec. 4: q1 <= 95 deg. With q1 already at 95 deg the pull-in is blocked by joint 1.
    q0 = paper_q0.copy()
    q0[0] = np.radians(95.0)
    q_max = np.full(4, np.pi)
    q_max[0] = np.radians(95.0)
    dw = 0.005 * np.array([-1.0, 0.0])
    P = paper_problem(paper_arm, q0, dw, q_max=q_max)
    res = assert_paths_agree(P)
    assert res.status == st.OPTIMAL
    assert res.p < 1.0
    assert res.binding == "joint 1 upper end-stop"
    assert res.q[0] <= np.radians(95.0)
    assert_matches_reference(P, res)
    assert lp1(P).p >= res.p - 1e-12


def test_a_large_command_is_scaled_by_the_velocity_limit(
    paper_arm: TaskModel, paper_q0: np.ndarray
) -> None:
    P = paper_problem(paper_arm, paper_q0, 10 * PULL_IN)
    res = assert_paths_agree(P)
    assert 0.0 < res.p < 1.0
    assert res.binding is not None and res.binding.endswith("velocity limit")
    i = int(res.binding.split()[1]) - 1
    bound = 0.01 if "upper" in res.binding else -0.01
    assert res.dq[i] == pytest.approx(bound, abs=1e-12)
    assert_matches_reference(P, res)
    # eq. 15: the step achieves p dw, exactly in the linearisation
    np.testing.assert_allclose(P.J @ res.dq, res.p * P.dw, atol=1e-12)


def test_multiplier_bounds_stop_the_step_near_the_edge_singularity(
    paper_arm: TaskModel,
) -> None:
    q0 = np.radians([8.0, -1.0, -1.0, -1.0])
    dw = np.array([0.0048, -0.0014])
    free = paper_problem(paper_arm, q0, dw)
    bounded = paper_problem(paper_arm, q0, dw, lam_min=[-0.01, -0.01], lam_max=[0.01, 0.01])
    unbounded = assert_paths_agree(free)
    res = assert_paths_agree(bounded)
    assert np.abs(unbounded.lam).max() > 0.01
    assert res.p < unbounded.p
    assert res.binding is not None and res.binding.startswith("multiplier")
    assert np.abs(res.lam).max() == pytest.approx(0.01, rel=1e-9)
    assert_matches_reference(bounded, res)


def test_the_stretched_arm_is_solved_by_the_singular_path_and_names_the_singularity(
    paper_arm: TaskModel,
) -> None:
    q0 = np.zeros(4)  # the edge singularity: J has rank 1
    P = paper_problem(paper_arm, q0, np.array([0.005, 0.0]))
    assert affine_solution(P) is None
    for path in ("auto", "ratio-test", "singular", "highs", "compiled"):
        res = lp2(P, path=path)
        # the ratio test hands over to the singular path; HiGHS is the reference
        assert res.path == {"highs": "highs", "compiled": "compiled"}.get(path, "singular")
        assert res.status == st.OPTIMAL
        assert res.p == 0.0
        assert res.binding == SINGULARITY
    along = lp2(paper_problem(paper_arm, q0, np.array([0.0, 0.005])))
    assert along.p == 1.0 and along.binding is None


# --- small problems with known answers, degenerate cases included ----------------------


def test_tie_between_two_bounds() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[2.0], q0=[0.0, 0.0], dq_min=[-1, -1], dq_max=[0.5, 0.5])
    res = assert_paths_agree(P, same_binding=False)
    assert res.p == pytest.approx(0.5)
    for r in both_paths(P):
        assert r.binding in {"joint 1 upper velocity limit", "joint 2 upper velocity limit"}
    assert_matches_reference(P, res)


def test_p_equal_to_one_exactly_at_a_bound_names_nothing() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], q_max=[0.5, 1.0])
    res = assert_paths_agree(P)
    assert res.p == 1.0 and res.binding is None
    assert res.q[0] == pytest.approx(0.5)


@pytest.mark.parametrize(
    ("q0", "q_min", "q_max", "binding"),
    [
        ([1.0, 0.0], [-5.0, -5.0], [1.0, 5.0], "joint 1 upper end-stop"),
        ([1.0, 0.0], [-5.0, 0.0], [1.0, 5.0], "joint 1 upper end-stop"),
    ],
    ids=["on-upper", "on-upper-other-on-lower"],
)
def test_starting_exactly_on_a_bound_gives_p_zero(
    q0: list[float], q_min: list[float], q_max: list[float], binding: str
) -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=q0, q_min=q_min, q_max=q_max)
    res = assert_paths_agree(P)
    assert res.status == st.OPTIMAL
    assert res.p == 0.0
    assert res.binding == binding
    np.testing.assert_array_equal(res.q, q0)
    assert_matches_reference(P, res)


def test_a_fixed_joint_is_pinned_and_the_others_carry_the_command() -> None:
    # Joint 2 cannot move (q_min = q_max): eq. 18 over all joints would tie it to p
    # and give p = 0; pinned, the criterion is resolved over joint 1, which moves.
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, -1.0], q_min=[-5.0, -1.0], q_max=[5.0, -1.0])
    res = assert_paths_agree(P)
    assert (res.status, res.p, res.binding) == (st.OPTIMAL, 1.0, None)
    np.testing.assert_allclose(res.q, [1.0, -1.0])
    assert_matches_reference(P, res)


def test_a_fixed_joint_in_a_planar_arm_no_longer_blocks() -> None:
    # Found by hypothesis before joints were pinned: joint 3 fixed gave p = 0.
    a = planar_arm([1.0, 1.0, 1.0, 0.5])
    q0 = np.array([1.0, 0.0, 0.0, 1.0])
    P = Problem(
        J=a.jacobian(q0),
        dw=[0.0035, 0.0],
        q0=q0,
        q_min=[1.0, -1.0, 0.0, -np.inf],
        q_max=[2.0, 0.0, 0.0, 1.0],
        dq_min=np.full(4, -0.125),
        dq_max=np.full(4, 0.125),
    )
    res = assert_paths_agree(P)
    assert res.p == 1.0 and res.binding is None
    assert res.q[2] == 0.0
    assert_matches_reference(P, res)


def test_starting_on_a_bound_and_moving_away_is_free() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[-1.0], q0=[1.0, 0.0], q_max=[1.0, 5.0])
    res = assert_paths_agree(P)
    assert res.p == 1.0 and res.binding is None


def test_multiplier_bound_binding_on_a_small_problem() -> None:
    # M = I: lam = -(J J^T)^-1 p dw = -p / 2, so |lam| <= 0.25 allows p = 0.5.
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], lam_min=[-0.25], lam_max=[0.25])
    res = assert_paths_agree(P)
    assert res.p == pytest.approx(0.5)
    assert res.binding == "multiplier 1 lower bound"
    np.testing.assert_allclose(res.lam, [-0.25])
    assert_matches_reference(P, res)


def test_a_multiplier_bound_excluding_zero_makes_small_p_infeasible() -> None:
    # lam = -p / 2 must be <= -0.1: p >= 0.2 is needed, and p = 1 is best.
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], lam_max=[-0.1])
    res = assert_paths_agree(P)
    assert res.p == 1.0
    assert_matches_reference(P, res)
    # lam in [-0.6, -0.55] would need p in [1.1, 1.2]: no p in [0, 1] is feasible.
    Q = P.replace(lam_min=[-0.6], lam_max=[-0.55])
    for r in both_paths(Q):
        assert r.status == st.INFEASIBLE and not r.moved
    assert not lp2_reference(Q).feasible


def test_an_extra_row_binds_with_its_label() -> None:
    P = Problem(
        J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], G=[[1.0, 1.0]], h=[0.3], row_labels=["wall"]
    )
    res = assert_paths_agree(P)
    assert res.p == pytest.approx(0.3)
    assert res.binding == "wall"
    assert_matches_reference(P, res)


def test_q0_outside_its_end_stops_by_more_than_a_step_moves_back_at_full_speed() -> None:
    # Joint 1 is 1.0 past its end-stop: pinned at its velocity limit back (-0.1); joint 2
    # carries the command, dq2 = 0.1 - p within [-0.1, 0.1]: p = 0.2.
    P = Problem(
        J=[[1.0, 1.0]],
        dw=[-1.0],
        q0=[2.0, 0.0],
        q_max=[1.0, 1.0],
        dq_min=[-0.1, -0.1],
        dq_max=[0.1, 0.1],
    )
    assert P.recovering() == ("joint 1 upper end-stop",)
    res = assert_paths_agree(P)
    assert (res.status, res.binding) == (st.RECOVERING, "joint 1 upper end-stop")
    assert res.p == pytest.approx(0.2)
    np.testing.assert_allclose(res.q, [1.9, -0.1])
    assert_matches_reference(P, res)


def test_q0_outside_its_end_stops_by_less_than_a_step_returns_onto_it() -> None:
    # Joint 1 returns exactly onto its end-stop (dq1 = -0.05); dq2 = 0.05 - p >= -0.1.
    P = Problem(
        J=[[1.0, 1.0]],
        dw=[-1.0],
        q0=[1.05, 0.0],
        q_max=[1.0, 1.0],
        dq_min=[-0.1, -0.1],
        dq_max=[0.1, 0.1],
    )
    res = assert_paths_agree(P)
    assert (res.status, res.binding) == (st.RECOVERING, "joint 1 upper end-stop")
    assert res.p == pytest.approx(0.15)
    assert res.q[0] == pytest.approx(1.0)
    assert_matches_reference(P, res)


def test_q0_past_its_end_stop_within_the_tolerance_counts_as_on_it() -> None:
    # on it, the joint may stay (p = 0 towards it) or leave (p = 1 away from it)
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[1.0 + 1e-12, 0.0], q_max=[1.0, 1.0])
    assert P.recovering() == ()
    res = assert_paths_agree(P)
    assert (res.status, res.p, res.binding) == (st.OPTIMAL, 0.0, "joint 1 upper end-stop")
    res = assert_paths_agree(P.replace(dw=[-1.0]))
    assert (res.status, res.p) == (st.OPTIMAL, 1.0)


def test_smoothing_that_would_pull_past_a_bound_is_scaled_down() -> None:
    # Joint 1 sits on its end-stop and q_ref pulls it past: the whole pull would make every
    # p infeasible (the paper's term as it stands); scaled to fit, the step is optimal.
    P = Problem(
        J=[[1.0, 1.0, 1.0]],
        dw=[1.0],
        q0=[0.0, 0.0, 0.0],
        q_max=[0.0, 1.0, 1.0],
        Lambda=[1.0, 1.0, 1.0],
        q_ref=[1.0, 0.0, -1.0],
    )
    assert smoothing(P) < 1.0
    fast, slow = both_paths(P)
    assert fast.status == slow.status == st.OPTIMAL
    assert abs(fast.p - slow.p) <= 1e-9
    assert_matches_reference(P, fast)


def test_the_smoothing_pull_takes_at_most_its_share_of_a_joints_band() -> None:
    # a pull of 1 rad (H = M + Lambda = 2) against +-0.1: the step at p = 0 moves 0.05
    P = Problem(J=[[1.0, 0.0, 0.0]], dw=[0.0], q0=[0.0, 0.0, 0.0], dq_min=np.full(3, -0.1),
                dq_max=np.full(3, 0.1), Lambda=[1.0, 1.0, 1.0], q_ref=[0.0, 2.0, 0.0])  # fmt: skip
    aff = affine_solution(P)
    assert aff is not None and aff.smoothing == pytest.approx(0.05)  # H = 2: a pull of 1 rad
    np.testing.assert_allclose(aff.a_q, [0.0, 0.05, 0.0], atol=1e-15)
    assert smoothing_scale(np.zeros(2), np.array([0.01, -0.01]), np.full(2, -0.1),
                           np.full(2, 0.1)) == 1.0  # a pull that fits is whole  # fmt: skip
    # a rate that is 0 to rounding on a joint at its bound does not stop the pull (found by
    # hypothesis: its sign decided between s = 0.28 and s = 0 on the two paths)
    lower, upper = np.array([0.0, 0.0, -0.125]), np.full(3, 0.125)
    e = np.array([-2.8e-17, 0.111, -0.222])
    assert smoothing_scale(np.zeros(3), e, lower, upper) == pytest.approx(0.0625 / 0.222)
    # a joint outside its band (moving): the pull may only take it towards the band
    assert smoothing_scale(np.array([0.2]), np.array([0.1]), np.array([-0.1]),
                           np.array([0.1])) == 0.0  # fmt: skip


def test_a_small_pulls_share_on_a_joint_at_its_end_stop_counts() -> None:
    # Joint 3 sits on its upper end-stop; the pull's share there (1e-11 rad of a 1e-4 rad
    # pull) is genuine, not rounding. Ignored (a threshold of 1e-10 rad), it put the step at
    # p = 0 past the end-stop, and every p was infeasible: the smoothing term froze the arm
    # on its own account (found on the Panda's path through a singularity). Now the pull is
    # scaled away on that joint, and the step is LP2's without it.
    P = Problem(J=[[1.0, 1.0, 0.0], [0.0, 1e-7, 1.0]], dw=[0.0, 1e-3], q0=[0.0, 0.0, 0.0],
                q_min=[-1.0, -1.0, -1.0], q_max=[1.0, 1.0, 0.0], dq_min=np.full(3, -0.01),
                dq_max=np.full(3, 0.01), Lambda=[1e-4] * 3, q_ref=[1.0, -1.0, -1.0])  # fmt: skip
    assert smoothing(P) == 0.0
    res = assert_paths_agree(P)
    assert (res.status, res.p, res.binding) == (st.OPTIMAL, 0.0, "joint 3 upper end-stop")
    compiled = lp2(P, path="compiled")
    assert (compiled.status, compiled.binding) == (res.status, res.binding)
    np.testing.assert_allclose(compiled.q, res.q, rtol=0, atol=1e-15)


def test_a_pull_leaves_the_multipliers_their_share_of_a_bound() -> None:
    # q_ref pulls joint 1 along the task: at p = 0 the pull alone needs lam = 1 against a bound
    # of 0.1 (sec. 3.2), and every p was infeasible on the pull's account (the automatic bound
    # with a smoothing term did this on the Panda). The pull is scaled to half the room.
    P = Problem(J=[[1.0, 0.0]], dw=[0.01], q0=[0.0, 0.0], Lambda=[1.0, 1.0], q_ref=[1.0, 0.0],
                lam_min=[-0.1], lam_max=[0.1])  # fmt: skip
    assert smoothing(P) == pytest.approx(0.05)
    res = assert_paths_agree(P)
    assert res.status == st.OPTIMAL and res.p > 0.0
    compiled = lp2(P, path="compiled")
    assert (compiled.status, compiled.binding) == (res.status, res.binding)
    np.testing.assert_allclose(compiled.q, res.q, rtol=0, atol=1e-15)


def test_zero_command_keeps_the_criterion_step() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[0.0], q0=[0.0, 0.0], Lambda=[1.0, 1.0], q_ref=[0.2, -0.2])
    res = assert_paths_agree(P)
    assert res.p == 1.0
    np.testing.assert_allclose(P.J @ res.dq, [0.0], atol=1e-15)
    # Lambda = I, M = I: dq minimises |dq|^2 + |dq - (0.2, -0.2)|^2 in J's null space.
    np.testing.assert_allclose(res.dq, [0.1, -0.1], atol=1e-12)


_HELD = {
    "criterion": {"f": [0.0, 0.03125]},
    "smoothing pull and a row": {"Lambda": [[1.0, 0.0], [0.0, 0.0]], "q_ref": [-0.5, 0.0078125],
                                 "G": [[0.0, -1.0]], "h": [-0.0078125]},
}  # fmt: skip


@pytest.mark.parametrize("extra", _HELD.values(), ids=list(_HELD))
def test_a_joint_held_at_its_end_stop_by_an_ill_conditioned_square_jacobian_stays_put(
    extra: dict,
) -> None:
    # Found by the thorough hypothesis profile. J is square (no redundancy) with
    # cond(J) ~ 700, joint 2 sits at its upper end-stop and dw = 0: the step is dq = 0
    # exactly, whatever pulls the joints (f, or sec. 3.1's pull). Before affine_solution
    # refined its answer, the numpy ratio test's a_q put joint 2 1e-12 past the stop
    # (rounding of eps cond(S) |H^-1 c|, cond(S) ~ 5e5), beyond SLACK_TOL, and called the
    # step infeasible while the compiled path and HiGHS solved it.
    J = [[1.99212347, 1.25583635], [1.29305413, 0.82028961]]
    P = Problem(J=J, dw=[0.0, 0.0], q0=[-1.0, 0.0078125], q_min=[-1.0, -np.inf],
                q_max=[0.0, 0.0078125], dq_min=[-0.125, -0.125], dq_max=[0.125, 0.125],
                **extra)  # fmt: skip
    assert np.linalg.cond(P.J) > 500
    aff = affine_solution(P)
    assert aff is not None
    assert np.abs(aff.a_q).max() < 1e-20  # the exact answer is 0
    res = assert_paths_agree(P)
    compiled = lp2(P, path="compiled")
    for r in (res, compiled):
        assert r.status == "optimal" and r.p == 1.0
        np.testing.assert_allclose(r.dq, [0.0, 0.0], rtol=0, atol=1e-20)


def test_unknown_path_is_refused() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0])
    with pytest.raises(ValueError, match="^path:"):
        lp2(P, path="simplex")


# --- the pieces ---------------------------------------------------------------------------


def test_affine_solution_satisfies_eq18s_rows_for_every_p() -> None:
    rng = np.random.default_rng(7)
    J = rng.normal(size=(2, 5))
    P = Problem(
        J=J,
        dw=rng.normal(size=2),
        q0=rng.normal(size=5),
        M=rng.uniform(0.5, 2.0, 5),
        f=rng.normal(size=5) * 0.1,
        Lambda=rng.uniform(0.0, 1.0, 5),
        q_ref=rng.normal(size=5),
    )
    aff = affine_solution(P)
    assert aff is not None
    H = P.M + P.Lambda
    for p in (0.0, 0.3, 1.0):
        dq, lam = aff.a_q + p * aff.b_q, aff.a_l + p * aff.b_l
        q = P.q0 + dq
        # eq. 18 with sec. 3.1, in absolute coordinates
        np.testing.assert_allclose(
            H @ q + J.T @ lam, P.M @ P.q0 + P.Lambda @ P.q_ref + P.f, atol=1e-12
        )
        np.testing.assert_allclose(J @ q - p * P.dw, J @ P.q0, atol=1e-12)


def test_ratio_test_on_plain_numbers() -> None:
    labels_lo = ("a lo", "b lo", "c lo")
    labels_hi = ("a hi", "b hi", "c hi")
    a = np.zeros(3)
    inf = np.inf
    # a + p b <= hi: 0.4 limits entry 0 at p = 0.4; entry 1 moves away; entry 2 is flat.
    res = ratio_test(
        a,
        np.array([1.0, -1.0, 0.0]),
        -np.full(3, inf),
        np.array([0.4, 0.1, 0.0]),
        labels_lo,
        labels_hi,
    )
    assert res.feasible and res.p == pytest.approx(0.4) and res.binding == "a hi"
    # ties go to the first entry
    res = ratio_test(
        a,
        np.array([1.0, 1.0, 0.0]),
        -np.full(3, inf),
        np.array([0.4, 0.4, 1.0]),
        labels_lo,
        labels_hi,
    )
    assert res.binding == "a hi"
    # a lower bound reached while moving down
    res = ratio_test(
        a,
        np.array([0.0, -2.0, 0.0]),
        np.array([-1.0, -1.0, -1.0]),
        np.full(3, inf),
        labels_lo,
        labels_hi,
    )
    assert res.p == pytest.approx(0.5) and res.binding == "b lo"
    # nothing limits: p = 1, no binding
    res = ratio_test(
        a, np.array([1.0, -1.0, 0.0]), -np.full(3, inf), np.full(3, inf), labels_lo, labels_hi
    )
    assert res.feasible and res.p == 1.0 and res.binding is None
    # a flat entry outside its bound: infeasible, named
    res = ratio_test(
        np.array([0.0, 0.0, 2.0]),
        np.array([1.0, 1.0, 0.0]),
        -np.full(3, inf),
        np.full(3, 1.0),
        labels_lo,
        labels_hi,
    )
    assert not res.feasible and res.binding == "c hi"
    # needs p >= 0.5 (entry 0) but allows p <= 0.25 (entry 1)
    res = ratio_test(
        np.array([-1.0, 0.0, 0.0]),
        np.array([2.0, 1.0, 0.0]),
        np.array([0.0, -inf, -inf]),
        np.array([inf, 0.25, inf]),
        labels_lo,
        labels_hi,
    )
    assert not res.feasible
    assert res.binding in {"a lo", "b hi"}


def test_highs_names_the_limit_in_conflict_when_no_step_is_feasible() -> None:
    """The elastic program behind an infeasible HiGHS answer names what the ratio test names."""
    cases = [
        (Problem(J=[[1.0, 1.0]], dw=[1.0], q0=[0.0, 0.0], lam_min=[-0.6], lam_max=[-0.55]),
         "multiplier 1 upper bound"),
        (Problem(J=[[1.0, 1.0]], dw=[0.0], q0=[0.0, 0.0], G=[[1.0, 1.0]], h=[-1e-3],
                 row_labels=["wall"]), "wall"),
    ]  # fmt: skip
    for problem, label in cases:
        for res in both_paths(problem):
            assert (res.status, res.binding) == (st.INFEASIBLE, label), res.path
    assert (lp1(cases[1][0]).status, lp1(cases[1][0]).binding) == (st.INFEASIBLE, "wall")


def test_a_singular_step_that_cannot_stop_in_time_names_the_acceleration_limit() -> None:
    from lpik.limits import AccelerationLimits, build_problem, standard_limits

    arm = planar_arm([1.0, 1.0, 1.0], qd_max=1.0)
    q0 = np.zeros(3)  # stretched out: J has rank 1, K is singular
    limits = [*standard_limits(arm), AccelerationLimits(np.full(3, 0.5))]
    moving = q0 - np.array([0.0, 0.0, 1e-4])  # joint 3 at 0.01 rad/s; it may shed 0.005
    P = build_problem(arm.jacobian(q0), np.array([-0.01, 0.0]), q0, limits, dt=0.01,
                      q_prev=moving)  # fmt: skip
    for path, answered_by in (("auto", "singular"), ("highs", "highs"), ("compiled", "compiled")):
        res = lp2(P, path=path)
        assert (res.status, res.path, res.p) == (st.INFEASIBLE, answered_by, 0.0)
        assert res.binding == "joint 3 lower acceleration limit"
