"""The target's own motion, fed forward under acceleration limits (add_target_motion)."""

from __future__ import annotations

import numpy as np
import pytest

from lpik import Lp2Controller, home_configuration, load_robot
from lpik.command import TargetMotion
from lpik.control.stepper import Stepper

DT = 0.001


def _circle(T0: np.ndarray, t: float, radius: float = 0.05, turns_per_s: float = 0.5) -> np.ndarray:
    """The start pose moved along a horizontal circle through its own position."""
    T, w = T0.copy(), 2 * np.pi * turns_per_s
    T[:3, 3] += radius * np.array([np.cos(w * t) - 1.0, np.sin(w * t), 0.0])
    return T


def _track(step, model, q: np.ndarray, steps: int) -> np.ndarray:
    """Position errors [m] to the next target of a loop that passes q_prev."""
    T0, prev, errors = np.array(model.pose(q)), q.copy(), []
    for k in range(steps):
        result = step(q, _circle(T0, k * DT), prev)
        prev, q = q, result.q
        errors.append(
            np.linalg.norm(np.array(model.pose(q))[:3, 3] - _circle(T0, (k + 1) * DT)[:3, 3])
        )
    return np.array(errors)


def test_a_moving_target_is_tracked_without_the_braking_lag() -> None:
    """0.16 m/s around a circle, 10 rad/s^2: the braked command alone lagged about 4 mm."""
    pytest.importorskip("numba")
    model = load_robot("panda")
    controller = Lp2Controller(model, dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    errors = _track(controller.step, model, home_configuration("panda"), 1500)
    assert errors[1000:].max() < 1e-5


def test_compiled_and_numpy_feed_the_same_motion_forward() -> None:
    """The fused step's memory (lpik.fast.command_law.target_motion) and TargetMotion agree."""
    pytest.importorskip("numba")
    model = load_robot("panda")
    controller = Lp2Controller(model, dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    stepper = Stepper(model, dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    q = home_configuration("panda")
    T0, qa, qb, pa, pb = np.array(model.pose(q)), q.copy(), q.copy(), q.copy(), q.copy()
    for k in range(300):
        target = _circle(T0, k * DT)
        a, b = controller.step(qa, target, pa), stepper.step(qb, target, pb)
        np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-10)
        assert a.status == b.status
        pa, qa, pb, qb = qa, a.q, qb, b.q


def test_only_a_step_that_follows_the_last_one_has_a_target_motion() -> None:
    model = load_robot("panda")
    memory, q = TargetMotion(), home_configuration("panda")
    T0 = np.array(model.pose(q))
    assert memory.motion(model, q, q, T0) is None  # a first step
    q1, T1 = q + 1e-3, _circle(T0, 0.1)
    motion = memory.motion(model, q1, q, T1)
    np.testing.assert_allclose(motion[:3], T1[:3, 3] - T0[:3, 3], atol=1e-15)
    np.testing.assert_allclose(motion[3:], 0.0, atol=1e-15)
    assert memory.motion(model, q1, q, T1) is motion  # the same step asked again
    assert memory.motion(model, q1 + 1.0, q1 + 0.5, T0) is None  # a jump of the state


def test_batch_rows_have_no_target_motion() -> None:
    """Rows of step_batch are independent states: each row is the step of a fresh controller."""
    pytest.importorskip("numba")
    model = load_robot("panda")
    controller = Lp2Controller(model, dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    q = home_configuration("panda")
    T0 = np.array(model.pose(q))
    q0 = np.array([q + 1e-3, q + 2e-3, q + 3e-3])
    q_prev = np.array([q, q + 1e-3, q + 2e-3])  # each row's q_prev is the row before's q0
    targets = np.array([_circle(T0, 0.01 * k) for k in range(3)])
    rows = controller.step_batch(q0, targets, q_prev)
    for b in range(3):
        fresh = Lp2Controller(model, dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
        np.testing.assert_allclose(
            rows[b].q, fresh.step(q0[b], targets[b], q_prev[b]).q, atol=1e-12
        )


@pytest.mark.parametrize("robot", ["panda", "ur5e", "iiwa14"])
def test_a_step_that_moved_by_rounding_feeds_no_motion_forward(robot: str) -> None:
    """Held at the pose the arm holds, then a target creeping at 0.1 mm/s: both engines alike.

    Asked for the pose it already holds, the compiled step moves the Panda's and the UR5e's
    joints by about 2e-16 rad (their kinematics round apart from numpy's), the numpy path
    not at all. An exact test of whether the arm moved fed the target's motion forward on
    the compiled engine only, and the engines parted by 3e-7 rad on the first step of the
    creep; within lpik.tolerances.REST_STEP such a step is rest on both.
    """
    pytest.importorskip("numba")
    model = load_robot(robot)
    options = dict(dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    controller, stepper = Lp2Controller(model, **options), Stepper(model, **options)
    q = home_configuration(robot)
    T0, qa, qb, pa, pb = np.array(model.pose(q)), q.copy(), q.copy(), q.copy(), q.copy()
    for k in range(40):
        target = T0.copy()
        target[0, 3] += 1e-7 * max(0, k - 2)
        a, b = controller.step(qa, target, pa), stepper.step(qb, target, pb)
        np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
        pa, qa, pb, qb = qa, a.q, qb, b.q
    assert np.linalg.norm(np.array(model.pose(qa))[:3, 3] - target[:3, 3]) < 2e-7
