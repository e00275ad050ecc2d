"""The progress step (``on_stall``): least task error within every limit, off the line."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from lpik.methods import solve
from lpik.methods.progress import (
    MOTION_WEIGHT,
    StallWatch,
    is_stall,
    progress_center,
    progress_step,
)
from lpik.paper.scenarios import PLANAR, get_scenario
from lpik.paper.setup import PAPER_COMMAND
from lpik.problem import Problem
from lpik.result import OFF_DIRECTION, OPTIMAL, STATUSES
from lpik.tolerances import (
    COASTING_DRIFT_COSINE,
    STALL_BLEND_P,
    STALL_KEEP_SHARE,
    STALL_P,
    STALL_SHARE,
)


def blocked() -> Problem:
    """x and y each driven by one joint; joint 2 sits on its end-stop: the direction (1, 1)
    is out of reach (p = 0 for every LP), but x can still be reduced."""
    return Problem(J=np.eye(2), dw=[0.01, 0.01], q0=[0.0, 1.0], q_max=[5.0, 1.0],
                   dq_min=[-0.1, -0.1], dq_max=[0.1, 0.1])  # fmt: skip


def test_the_progress_step_reduces_the_error_the_direction_cannot() -> None:
    P = blocked()
    assert solve(P, "lp1").p == solve(P, "lp2").p == 0.0
    res = progress_step(P)
    assert (res.status, res.p, res.method) == (OFF_DIRECTION, 0.0, "progress")
    np.testing.assert_allclose(res.dq, [0.01, 0.0], atol=1e-12)
    assert res.residual == pytest.approx(0.01)  # what remains of the command: y
    assert OFF_DIRECTION in STATUSES


def test_the_progress_step_is_the_least_l1_error_of_an_independent_lp() -> None:
    rng = np.random.default_rng(4)
    for _ in range(30):
        n, m = 4, 2
        J = rng.normal(size=(m, n))
        dw = rng.normal(size=m) * 0.05
        q0 = np.zeros(n)
        lo, hi = -rng.uniform(0, 0.02, n), rng.uniform(0, 0.02, n)
        P = Problem(J=J, dw=dw, q0=q0, q_min=lo, q_max=hi)
        res = progress_step(P)
        # linprog: min sum t + MOTION_WEIGHT sum u, t >= +-(J dq - dw), u >= +-dq, within the bounds
        c = np.concatenate([np.zeros(n), np.ones(m), np.full(n, MOTION_WEIGHT)])
        Z, I_n, I_m = np.zeros, np.eye(n), np.eye(m)
        A = np.block([[J, -I_m, Z((m, n))], [-J, -I_m, Z((m, n))],
                      [I_n, Z((n, m)), -I_n], [-I_n, Z((n, m)), -I_n]])  # fmt: skip
        bounds = [*zip(lo, hi), *[(0, None)] * (m + n)]
        b_ub = np.concatenate([dw, -dw, np.zeros(2 * n)])
        ref = linprog(c, A_ub=A, b_ub=b_ub, bounds=bounds, method="highs")
        value = float(np.abs(J @ res.dq - dw).sum() + MOTION_WEIGHT * np.abs(res.dq).sum())
        assert value == pytest.approx(ref.fun, abs=1e-9)
        assert np.all(res.dq >= P.q_min - 1e-9) and np.all(res.dq <= P.q_max + 1e-9)


def test_the_progress_step_keeps_the_exact_step_where_leaving_it_buys_little() -> None:
    """Without acceleration limits the motion term is measured from the exact step: of two
    steps of the same error the progress step takes the one at the exact step, not the
    least motion; under acceleration limits it is the arm's motion (progress_center)."""
    P = Problem(J=[[1.0, 1.0]], dw=[0.01], q0=[0.0, 0.0], dq_min=[-0.1, -0.1],
                dq_max=[0.1, 0.1])  # fmt: skip
    exact = np.array([0.03, -0.02])  # J exact = dw: no error, as the least-motion (0.005, 0.005)
    np.testing.assert_allclose(progress_step(P, exact=exact).dq, exact, atol=1e-12)
    np.testing.assert_allclose(progress_step(P).dq @ [1.0, 1.0], 0.01, atol=1e-12)
    assert np.abs(progress_step(P).dq).sum() == pytest.approx(0.01)  # the least motion
    lower, upper, zero = np.full(2, -0.1), np.full(2, 0.1), np.zeros(2)

    def center(last: np.ndarray, exact: np.ndarray, moving: bool) -> np.ndarray:
        return progress_center(P.J, P.dw, last, exact, moving, lower, upper, np.empty(2))

    np.testing.assert_array_equal(center(zero, np.array([0.5, 0.0]), False),
                                  [0.1, 0.0])  # clipped to the bounds  # fmt: skip
    last = np.array([0.01, 0.02])
    np.testing.assert_array_equal(center(last, exact, True), last)
    np.testing.assert_array_equal(center(zero, zero, False), 0.0)


def test_the_progress_step_brakes_where_coasting_carries_the_task_away_from_the_command() -> None:
    """Under acceleration limits the motion term is measured from the arm's motion, but from
    the braking step where that motion's task velocity points away from the command by more
    than COASTING_DRIFT_COSINE (its cosine to dw below minus it)."""
    J, dw = np.eye(2), np.array([1.0, 0.0])
    lower, upper = np.array([-0.2, 0.05]), np.array([0.2, 0.3])  # rest is out of reach in y

    def center(last: list[float]) -> np.ndarray:
        return progress_center(J, dw, np.array(last), np.zeros(2), True, lower, upper,
                               np.empty(2))  # fmt: skip

    np.testing.assert_array_equal(center([0.1, 0.1]), [0.1, 0.1])  # along the command
    np.testing.assert_array_equal(center([-0.01, 0.1]), [-0.01, 0.1])  # at 96 degrees: keeps
    cosine = -COASTING_DRIFT_COSINE - 1e-3  # just past the band: brakes, within the bounds
    np.testing.assert_array_equal(center([0.1 * cosine, 0.1 * np.sqrt(1 - cosine**2)]), [0.0, 0.05])


def test_no_progress_possible_is_said_and_moves_nothing() -> None:
    P = blocked().replace(q_max=[0.0, 1.0], q0=[0.0, 1.0])  # both joints on their end-stops
    res = progress_step(P)
    assert (res.status, res.binding) == (OPTIMAL, "no progress")
    np.testing.assert_array_equal(res.dq, 0.0)


def test_the_stall_watch_waits_for_its_steps() -> None:
    for not_steps in (0, True, 1.0):
        with pytest.raises(ValueError, match="on_stall: must be a whole number"):
            StallWatch(not_steps)  # type: ignore[arg-type]
    P = blocked()
    watch = StallWatch(3)
    stalled = solve(P, "lp2")
    statuses = [watch.check(stalled, lambda: P).status for _ in range(4)]
    assert statuses == [OPTIMAL, OPTIMAL, OFF_DIRECTION, OFF_DIRECTION]
    assert StallWatch(None).check(stalled, lambda: P) is stalled


def test_once_engaged_the_stall_stage_keeps_the_progress_step_within_a_band() -> None:
    """Entering the progress step takes an exact step gaining less than STALL_SHARE of it;
    keeping it, less than STALL_KEEP_SHARE, and up to p = STALL_BLEND_P (without
    acceleration limits every flip between the two laws is a jump of the velocities).
    The same step asked again is judged as the first time."""
    assert STALL_SHARE < STALL_KEEP_SHARE
    share = (STALL_SHARE + STALL_KEEP_SHARE) / 2
    assert not is_stall(STALL_P / 2, share, 1.0) and is_stall(STALL_P / 2, share, 1.0, keeping=True)
    # within the band p may stall up to STALL_BLEND_P (blended there: stalled_step)
    assert is_stall(2 * STALL_P, 0.0, 1.0, keeping=True) and not is_stall(2 * STALL_P, 0.0, 1.0)
    assert not is_stall(2 * STALL_BLEND_P, 0.0, 1.0, keeping=True)
    watch = StallWatch(2)
    q = np.zeros(3)
    watch.count(True)
    assert not watch.keeping(q, moving=False)
    watch.count(True)
    assert watch.engaged and not watch.keeping(q, moving=False)  # q asked again: as before
    # the band holds where a flip is a jump of the velocities, not under acceleration limits
    assert watch.keeping(q + 1, moving=False) and not watch.keeping(q + 2, moving=True)
    watch.clear()
    assert not watch.engaged


@pytest.mark.parametrize("robot", [PLANAR, "panda"])
def test_on_stall_gets_the_arm_unstuck_alike_on_both_paths(robot: str) -> None:
    pytest.importorskip("numba")
    setup = get_scenario("pull-in").setup(robot)
    target = setup.target[:3, 3] if setup.target.ndim == 2 else setup.target
    stuck = setup.run("lp2", **PAPER_COMMAND)
    log = setup.run("lp2", **{**PAPER_COMMAND, "on_stall": 20})
    assert (log.status == OFF_DIRECTION).any()
    gap = np.linalg.norm(log.position_end[:2] - target[:2])
    assert gap < np.linalg.norm(stuck.position_end[:2] - target[:2])
    controller = setup.controller()
    controller = type(controller)(setup.model, dt=setup.dt, v_max=setup.v_max, w_max=setup.w_max,
                                  on_stall=20, saturate=False, second_order=False,
                                  **dict(setup.weights))  # fmt: skip
    q, prev = setup.q0.copy(), None
    for k in range(setup.steps):
        res = controller.step(q, setup.target, prev)
        assert res.status == log.status[k], k
        np.testing.assert_allclose(res.q, log.q[k + 1] if k + 1 < setup.steps else log.q_end,
                                   rtol=0, atol=1e-9)  # fmt: skip
        prev, q = q, res.q
