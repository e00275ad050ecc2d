"""Where no step around the arm's motion exists, the paper's step through rest, same bounds.

Under acceleration limits the step keeps the line ``J dq = (1 - p) J last + p dw``
(:mod:`lpik.continuation`). That line holds no slowing down of the task's motion:
where the last motion itself breaks a row this step, every point of it does, and
the step was the braking safe step although a slower motion within every limit
exists. :func:`lpik.continuation.through_rest` then solves the paper's line
``J dq = p dw`` within the same bounds (the acceleration band around the motion),
on the numpy path and in the fused step alike.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from tests.core_reference import hard_violation, lp1_reference, lp2_reference

from lpik.check import task_residual
from lpik.continuation import continued
from lpik.control.stepper import Stepper
from lpik.result import INFEASIBLE, OPTIMAL
from lpik.robots.planar import planar_arm

pytest.importorskip("numba")

from lpik.control.controller import Lp2Controller  # noqa: E402

DT, QDD_MAX = 0.01, 5.0  # one period of the acceleration limit: 5e-4 rad


def wall_ahead(arm, q0, speed: float, ahead: float):  # type: ignore[no-untyped-def]
    """A last step toward ``x`` (largest joint step ``speed``) and a wall ``G q <= h`` on the
    tool's ``x`` at ``ahead`` times the distance that step covers."""
    J = arm.jacobian(q0)
    toward = np.linalg.pinv(J) @ np.eye(J.shape[0])[0]
    last = speed * toward / np.abs(toward).max()
    G = J[:1].copy()
    return last, G, np.array([G[0] @ q0 + ahead * (G[0] @ last)])


def both_stages(arm, q0, last, G, h, target, saturate=True, **options):  # type: ignore[no-untyped-def]
    """The step around the motion (the method on the stepper's problem), then the
    through-rest stage on it, in the numpy layers and in the fused step; the problem, and
    the stage's own: the same command within the limits and the stops ahead."""
    method = "lp2s" if saturate else "lp2"
    stepper = Stepper(arm, dt=DT, qdd_max=QDD_MAX, rows=(G, h, None), method=method, **options)
    fused = Lp2Controller(arm, dt=DT, qdd_max=QDD_MAX, G=G, h=h, saturate=saturate,
                          compile="now", **options)  # fmt: skip
    q_prev = q0 - last
    problem = stepper.problem(q0, target, q_prev)
    around = stepper.solve(problem)
    rested = stepper.rested(problem, around, q_prev)[1]
    rest_problem = stepper.rest_problem(problem, q_prev)  # the stops ahead kept
    fused.step(q0, target, q_prev)  # the state the stage reads
    # the stage's callers hand it the safe steps only
    rest = (
        fused._through_rest(q0, target, q_prev, around) if around.status == INFEASIBLE else around
    )
    return around, rested, rest, problem, rest_problem


def test_an_arm_slowly_nearing_a_wall_takes_the_step_through_rest_not_the_safe_step() -> None:
    arm = planar_arm([1.0, 1.0, 1.0], qd_max=1.0)
    q0 = np.array([0.4, 0.6, 0.5])
    last, G, h = wall_ahead(arm, q0, 2e-4, 0.5)  # the last step would pass the wall twice over
    target = np.append(arm.position(q0)[:2] + [0.2, 0.0], 0.0)  # beyond the wall
    around, numpy_step, fused_step, problem, rest = both_stages(arm, q0, last, G, h, target)
    # no step along the line around the motion (HiGHS), one through rest
    assert around.status == INFEASIBLE and not lp1_reference(continued(problem)).feasible
    assert lp1_reference(rest).feasible
    for result in (numpy_step, fused_step):
        assert result.status == OPTIMAL and 0.0 < result.p < 1.0
        assert result.binding == "row 1"
        assert hard_violation(rest, result.q) <= 1e-12
        # the paper's line: J dq = p dw (eq. 12), the command itself
        dq = result.q - q0
        assert np.abs(problem.J @ dq - result.p * problem.dw).max() <= 1e-12
    assert fused_step.p == pytest.approx(numpy_step.p, abs=1e-12)
    np.testing.assert_allclose(fused_step.q, numpy_step.q, atol=1e-12, rtol=0)
    # the strict step is the method's own
    strict = Stepper(arm, dt=DT, qdd_max=QDD_MAX, rows=(G, h, None), on_stall=None)
    assert strict.step(q0, target, q0 - last).status == INFEASIBLE


@settings(max_examples=100, deadline=None)
# nearly stretched arms where the stops ahead bind the step through rest (the problem the
# stage solves keeps them: a reference without them found a step the stage may not take)
@example(lengths=[1.0, 0.5, 0.4375], angles=[0.75, 0.025390625, 0.0, 0.0, 0.0],
         speed=0.0012898018640231355, ahead=1.0, reach=(0.5, 0.0))  # fmt: skip
@example(lengths=[1.0, 0.5, 0.5], angles=[0.75, 0.02734375, 0.0, 0.0, 0.0],
         speed=0.0012898018640231355, ahead=1.0, reach=(0.5, 0.0))  # fmt: skip
@given(
    lengths=st.lists(st.floats(0.4, 1.2), min_size=3, max_size=5),
    angles=st.lists(st.floats(-1.2, 1.2), min_size=5, max_size=5),
    speed=st.floats(1e-6, 1.5e-3),
    ahead=st.floats(0.05, 3.0),  # the wall not at q0 itself (g = 0: a degenerate vertex)
    reach=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
)
def test_the_safe_step_only_where_neither_line_has_a_step(
    lengths: list[float], angles: list[float], speed: float, ahead: float,
    reach: tuple[float, float],
) -> None:  # fmt: skip
    """LP2 on both lines cross-checked by HiGHS; the numpy and fused stages held equal."""
    arm = planar_arm(lengths, qd_max=1.0)
    q0 = np.array(angles[: len(lengths)])
    assume(np.linalg.svd(arm.jacobian(q0), compute_uv=False)[-1] > 1e-3)  # the wall: a row of J
    assume(np.hypot(*reach) > 1e-2)  # a command, not rounding (p of a command of 1e-12 m)
    last, G, h = wall_ahead(arm, q0, speed, ahead)
    target = np.append(arm.position(q0)[:2] + np.array(reach), 0.0)
    options = {"lambda_bound": None, "saturate": False}  # LP2 itself
    around, numpy_step, fused_step, problem, rest = both_stages(
        arm, q0, last, G, h, target, **options
    )
    assert (fused_step.status, fused_step.binding) == (numpy_step.status, numpy_step.binding)
    assert fused_step.p == pytest.approx(numpy_step.p, abs=1e-9)
    np.testing.assert_allclose(fused_step.q, numpy_step.q, atol=1e-9, rtol=0)
    if around.status != INFEASIBLE:  # the stage keeps every other step
        assert numpy_step is around
        return
    if numpy_step.status == INFEASIBLE:  # neither line holds a step within tighter limits
        assert not lp2_reference(continued(problem), margin=-1e-9).feasible
        assert not lp2_reference(rest, margin=-1e-9).feasible
        return
    # every limit: the acceleration band, end-stops, velocity limits, rows and the stops
    # ahead of the motion, which the step through rest keeps
    assert hard_violation(rest, numpy_step.q) <= 1e-9
    assert task_residual(problem, numpy_step.q - q0, numpy_step.p) <= 1e-9
    reference = lp2_reference(rest)  # LP2's largest p on the paper's line
    # HiGHS solves to its tolerances (1e-7), which a nearly stretched arm's p amplifies
    assert reference.feasible and numpy_step.p == pytest.approx(reference.p, rel=1e-5, abs=1e-7)


def test_a_stretched_arm_s_whole_step_batch_row_and_step_into_take_the_step_through_rest() -> None:
    """Near a stretched pose the progress step's motion buys too little to move: the stage."""
    arm = planar_arm([0.864, 0.697, 0.494], qd_max=1.0)
    q0 = np.array([-0.2643, 0.003, 0.0039])
    last, G, h = wall_ahead(arm, q0, 3.78e-4, 0.377)
    target = np.append(arm.position(q0)[:2] + [-0.064, 0.307], 0.0)
    q_prev = q0 - last

    def fused() -> Lp2Controller:
        return Lp2Controller(arm, dt=DT, qdd_max=QDD_MAX, G=G, h=h, compile="now")

    stepper = Stepper(arm, dt=DT, qdd_max=QDD_MAX, rows=(G, h, None))
    problem = stepper.problem(q0, target, q_prev)
    assert stepper.solve(problem).status == INFEASIBLE  # the method's step around the motion
    whole = stepper.step(q0, target, q_prev)
    assert whole.status == OPTIMAL and whole.p > 0.0
    assert np.abs(problem.J @ (whole.q - q0) - whole.p * problem.dw).max() <= 1e-12
    out = np.empty(3)
    controller = fused()
    p_into = controller.step_into(q0, target, q_prev, out=out)
    for q, p in ((fused().step(q0, target, q_prev).q, None), (out, p_into),
                 (fused().step_batch([q0], [target], [q_prev]).q[0], None)):  # fmt: skip
        np.testing.assert_allclose(q, whole.q, atol=1e-12, rtol=0)
        assert p is None or p == pytest.approx(whole.p, abs=1e-12)
    assert controller.last_status == OPTIMAL
