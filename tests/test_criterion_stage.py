"""Where LP2's conditions admit no step but a motion along the command exists: Ho's LP.

LP2 keeps the criterion's optimality conditions (eqs. 15-18) as rows. Around the arm's
motion under acceleration limits they can admit no step within the limits although
LP1 (eqs. 11-14, no criterion) has one, and the step through rest has none either:
the step was the braking safe step, a stop where a motion along the command exists.
The criterion stage (:meth:`lpik.control.stepper.Stepper.scaled`, compiled:
:func:`lpik.fast.progress.least_l1_in_state`) takes :func:`lpik.methods.l1.l1`'s step
there: LP1's largest ``p``, the least change of the motion. A step stays ``infeasible``
only where LP1 itself has no step that changes the motion toward the command.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from tests.core_reference import hard_violation, lp1_reference

from lpik import load_robot
from lpik.continuation import continued
from lpik.control.stepper import Stepper
from lpik.result import INFEASIBLE, SCALED
from lpik.robots.planar import planar_arm
from lpik.tolerances import NO_CHANGE_P, SCALED_P_MARGIN

pytest.importorskip("numba")

from lpik.control.controller import Lp2Controller  # noqa: E402

# Two states of the Panda's random goal 5 (benchmarks/random_goals.py, seed 0) under
# qdd_max = 10 rad/s^2, 3 s on: the goal configuration, then (q0, q_prev) at steps 3002
# and 3152, where neither LP2 around the motion nor the step through rest has a step.
GOAL = np.array([-0.9896151850974679, -0.04494497301237987, 2.0312335844268454,
                 -0.3981012285894048, -0.7416179578346598, 2.1102007156660783,
                 -0.928976063824211])  # fmt: skip
STATES = (
    (np.array([0.519893219311269, -0.04322571063831334, 0.5809830843756132,
               -0.4793586608414565, -0.8199395531532804, 2.1343384554163447,
               -0.8904191647222938]),
     np.array([0.519893219311269, -0.04322571063831334, 0.5809830843756132,
               -0.47942420567042415, -0.8199395531532804, 2.1343384554163447,
               -0.8904191647222938])),
    (np.array([0.5173334289660149, -0.03013593078464329, 0.6062733196746248,
               -0.47832851156476835, -0.8451813053534619, 2.123866880969008,
               -0.8903460434389768]),
     np.array([0.5173030345856462, -0.03013487030515209, 0.6063035907312198,
               -0.4783262900285405, -0.8451807880630864, 2.1238662717984136,
               -0.8903467143309521])),
)  # fmt: skip
DT, QDD_MAX = 1e-3, 10.0


def stage_problem(stepper: Stepper, q0: np.ndarray, target: np.ndarray, q_prev: np.ndarray):  # type: ignore[no-untyped-def]
    """The step's problem as the criterion stage gets it, and the method's answer on it."""
    problem = stepper.problem(q0, target, q_prev)
    return stepper.bounded(problem, stepper.solve(problem), q_prev)


def assert_ho_step(problem, result, q0: np.ndarray) -> None:  # type: ignore[no-untyped-def]
    """``result`` is Ho's LP past the full displacement on ``problem`` (around its motion)."""
    around = continued(problem)
    u = result.q - q0 - problem.motion
    reference = lp1_reference(around)  # LP1's largest p, HiGHS through scipy
    assert reference.feasible
    assert reference.p - SCALED_P_MARGIN - 1e-8 <= result.p <= reference.p + 1e-8
    assert hard_violation(problem, result.q) <= 1e-9  # every limit of the step
    assert np.abs(around.J @ u - result.p * around.dw).max() <= 1e-9  # J u = p (dw - J last)
    assert result.lam is None and result.method == "l1"


@pytest.mark.parametrize("index", range(len(STATES)))
def test_where_lp2_has_no_step_around_the_motion_nor_through_rest_the_step_is_ho_s(
    index: int,
) -> None:
    model = load_robot("panda", task="pose")
    target = model.pose(GOAL)
    q0, q_prev = STATES[index]
    stepper = Stepper(model, dt=DT, qdd_max=QDD_MAX)
    problem, around = stage_problem(stepper, q0, target, q_prev)
    assert around.status == INFEASIBLE and problem.last is not None
    numpy_step = stepper.step(q0, target, q_prev)
    assert numpy_step.status == SCALED and numpy_step.p > NO_CHANGE_P
    assert (
        numpy_step.binding == "panda_joint4 upper acceleration limit"
        if index == 0
        else (numpy_step.binding == "panda_joint5 lower acceleration limit")
    )
    assert_ho_step(problem, numpy_step, q0)
    # the compiled engine, by each way to take a step
    out = np.empty(7)
    into = Lp2Controller(model, dt=DT, qdd_max=QDD_MAX, compile="now")
    p_into = into.step_into(q0, target, q_prev, out=out)
    steps = (
        Lp2Controller(model, dt=DT, qdd_max=QDD_MAX, compile="now").step(q0, target, q_prev),
        Lp2Controller(model, dt=DT, qdd_max=QDD_MAX, compile="now").step_batch(
            [q0], [target], [q_prev])[0],
    )  # fmt: skip
    for fused in steps:
        assert (fused.status, fused.binding, fused.method) == (SCALED, numpy_step.binding, "l1")
        assert fused.p == pytest.approx(numpy_step.p, abs=1e-7)
        np.testing.assert_allclose(fused.q, numpy_step.q, atol=1e-9, rtol=0)
    np.testing.assert_allclose(out, numpy_step.q, atol=1e-9, rtol=0)
    assert p_into == pytest.approx(numpy_step.p, abs=1e-7)
    assert into.last_status == SCALED and into.last_binding == numpy_step.binding
    # the strict step (no stall stage) is the method's own
    strict = Stepper(model, dt=DT, qdd_max=QDD_MAX, on_stall=None)
    assert strict.step(q0, target, q_prev).status == INFEASIBLE


@settings(max_examples=100, deadline=None)
@given(
    lengths=st.lists(st.floats(0.4, 1.2), min_size=3, max_size=5),
    angles=st.lists(st.floats(-2.0, 2.0), min_size=5, max_size=5),
    bend=st.floats(0.02, 1.0),
    motion=st.lists(st.floats(-1.0, 1.0), min_size=5, max_size=5),
    speed=st.floats(1e-4, 9.9e-3),
    reach=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
)
def test_a_moving_arm_s_step_is_infeasible_only_where_lp1_has_no_step_either(
    lengths: list[float], angles: list[float], bend: float, motion: list[float], speed: float,
    reach: tuple[float, float],
) -> None:  # fmt: skip
    """Random planar arms moving within their velocity limits under acceleration limits
    (nearly stretched ones too, ``bend`` near 0, where LP2 often has no step), held
    equal on both engines. Where a step stays infeasible, LP1 (HiGHS) has no step
    that changes the motion toward the command either."""
    n = len(lengths)
    arm = planar_arm(lengths, qd_max=1.0)
    q0 = np.array(angles[:n])
    q0[1:] *= bend
    last = np.array(motion[:n])
    assume(np.abs(last).max() > 1e-3)
    assume(np.hypot(*reach) > 1e-2)  # a command, not rounding (p of a command of 1e-12 m)
    # not at a singular configuration itself: there rounding decides the step. At
    # sigma_min 3e-6 and below (1,500 random draws of these arms, none above), eq. 18's
    # Schur complement has a condition of 1e12 on the free joints, the singular path's
    # SVDs (LAPACK, one-sided Jacobi) give p 0 against 1e-10 and other multipliers, and
    # the engines name other bindings (an acceleration limit, a multiplier bound) and
    # make other stall decisions
    assume(np.linalg.svd(arm.jacobian(q0), compute_uv=False)[-1] > 1e-5)
    last *= speed / np.abs(last).max()
    q_prev = q0 - last
    target = np.append(arm.position(q0)[:2] + np.array(reach), 0.0)
    stepper = Stepper(arm, dt=0.01, qdd_max=1.0)
    problem, around = stage_problem(stepper, q0, target, q_prev)
    numpy_step = stepper.step(q0, target, q_prev)
    fused = Lp2Controller(arm, dt=0.01, qdd_max=1.0, compile="now").step(q0, target, q_prev)
    if SCALED in (numpy_step.status, fused.status):  # the stage's steps, held equal
        assert (fused.status, fused.binding) == (numpy_step.status, numpy_step.binding)
        assert fused.p == pytest.approx(numpy_step.p, abs=1e-7)
        np.testing.assert_allclose(fused.q, numpy_step.q, atol=1e-9, rtol=0)
    if numpy_step.status == SCALED:
        assert around.status == INFEASIBLE
        assert_ho_step(problem, numpy_step, q0)
    if numpy_step.status == INFEASIBLE and problem.last is not None and not problem.recovering():
        # HiGHS (lpik's LP1, in u) and the reference (scipy's HiGHS) part by up to a few
        # 1e-6 in p at nearly stretched arms: a draw at 1,500 examples found 3.35e-6
        # against 0 (joints 1 to 3 in line, the fourth bent by 0.125 rad)
        reference = lp1_reference(continued(problem), margin=-1e-9)
        assert not reference.feasible or reference.p <= NO_CHANGE_P + 1e-5


def test_the_engines_take_the_same_step_where_a_joint_moved_by_rounding() -> None:
    """Found by the test above at 1,500 draws: a five-link arm with three joints in line,
    its fifth joint moved by 2e-20 rad. ``sigma_min`` fell by 9e-16 (rounding) on numpy's
    SVD, so a stop before the singular configuration lay 3.6e14 steps ahead, and the stop
    ahead held the fifth joint to 8e-6 rad in its direction: p 0.0108 against the fused
    step's 0.0132. A fall within rounding is no fall, and a joint moved by rounding is at
    rest (lpik.methods.autobound.singular_steps, lpik.bands.fading_band)."""
    arm = planar_arm([1.0] * 5, qd_max=1.0)
    q0 = np.array([0.0, 0.0, 0.0, 0.25, 0.0])
    q_prev = q0 - 1e-4 * np.array([1.0, 0.0, 0.0, 0.0, -2.220446049250313e-16])  # joint 5: 2e-20
    target = np.append(arm.position(q0)[:2] + [0.5, 0.0], 0.0)
    numpy_step = Stepper(arm, dt=0.01, qdd_max=1.0).step(q0, target, q_prev)
    fused = Lp2Controller(arm, dt=0.01, qdd_max=1.0, compile="now").step(q0, target, q_prev)
    assert numpy_step.status == fused.status == "optimal"
    assert fused.p == pytest.approx(numpy_step.p, abs=1e-7)  # 0.0132 against 0.0108
