"""Point-to-point moves under low and unequal acceleration limits stop on their goal.

The command's brake counts what keeping the task's motion on its line takes of each
joint (the hold of :func:`lpik.command.braking_scale`). Before it, these moves passed their goal by
6 to 29 mm (``benchmarks/braking.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

from lpik import Lp2Controller, home_configuration, load_robot
from lpik.bands import braking_room
from lpik.command import BRAKING_SHARE, HOLD_SHARE, braking_scale
from lpik.control.stepper import Stepper
from lpik.fast.command_law import braking_scale as compiled_braking_scale
from lpik.result import MOVING

DT = 1e-3
#: (arm, acceleration limits of its joints, the tool's move [m], command clamp off)
#: and the overshoot before the fix [mm].
MOVES = {
    "iiwa14, 2 rad/s^2, clamped (10 mm)": ("iiwa14", "2", (-0.15, -0.1, 0.1), False),
    "iiwa14, 2 rad/s^2, unclamped (17 mm)": ("iiwa14", "2", (0.0, -0.25, 0.0), True),
    "panda, 2 rad/s^2, unclamped (6 mm)": ("panda", "2", (0.0, 0.2, -0.1), True),
    "panda, 1 (base) to 20 (wrist), unclamped (29 mm)": (
        "panda", "rising", (-0.15, -0.1, 0.1), True),
}  # fmt: skip


def _limits(kind: str, n: int) -> np.ndarray:
    return np.full(n, 2.0) if kind == "2" else np.linspace(1.0, 20.0, n)


def _move(
    robot: str, kind: str, move: tuple[float, ...], unclamped: bool, steps: int
) -> tuple[np.ndarray, list, np.ndarray, np.ndarray]:
    model, q = load_robot(robot), home_configuration(robot)
    qdd = _limits(kind, q.size)
    clamp = {"v_max": 1e6, "w_max": 1e6} if unclamped else {}
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd, **clamp)
    goal = model.pose(q)
    goal[:3, 3] += move
    prev, path, results = q.copy(), [q.copy()], []
    for _ in range(steps):
        result = controller.step(q, goal, prev)
        results.append(result)
        prev, q = q, result.q
        path.append(q.copy())
    return np.asarray(path), results, goal, qdd


@pytest.mark.parametrize("case", list(MOVES))
def test_a_move_under_low_or_unequal_acceleration_limits_stops_on_its_goal(case: str) -> None:
    robot, kind, move, unclamped = MOVES[case]
    path, results, goal, qdd = _move(robot, kind, move, unclamped, 2000)
    model = load_robot(robot)
    error = np.array([np.linalg.norm(model.pose(q)[:3, 3] - goal[:3, 3]) for q in path])
    overshoot = np.max(error - np.minimum.accumulate(error))
    assert overshoot <= 1e-3  # the bound: at most 1 mm
    assert error[-1] < 1e-5  # settled within 0.01 mm in 2 s
    assert all(r.status in MOVING for r in results)  # no safe step, no infeasible step
    acceleration = np.abs(path[2:] - 2 * path[1:-1] + path[:-2]) / DT**2
    assert np.all(acceleration <= qdd * (1 + 1e-9) + 1e-9)


#: Moves to the tool pose of a configuration near home, turning the tool as it goes, the
#: command clamp off: (arm, acceleration limit [rad/s^2], goal configuration [rad]), and
#: the overshoot with BRAKING_SHARE at 0.8 [mm] (benchmarks/braking.py, rows "turning").
TURNS = {
    "panda, 3 rad/s^2 (47 mm)": (
        "panda", 3.0, (0.006368, -0.710502, 0.6937, -1.946468, 0.171051, 2.255341, 0.38683)),
    "iiwa14, 5 rad/s^2 (13 mm)": (
        "iiwa14", 5.0, (-0.196805, 0.477097, -0.365958, -1.144085, -0.296545, 0.809511, 0.250365)),
    "ur5e, 10 rad/s^2 (6.3 mm)": (
        "ur5e", 10.0, (-0.692629, -1.121077, 1.986694, -1.615687, -1.846551, -0.310204)),
}  # fmt: skip


@pytest.mark.parametrize("case", list(TURNS))
def test_a_move_that_turns_the_tool_stops_on_its_goal(case: str) -> None:
    robot, qdd, goal_q = TURNS[case]
    model, q = load_robot(robot), home_configuration(robot)
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd, v_max=1e6, w_max=1e6)
    goal = model.pose(np.asarray(goal_q))
    prev, error, results = q.copy(), [], []
    for _ in range(2500):
        result = controller.step(q, goal, prev)
        results.append(result)
        prev, q = q, result.q
        error.append(np.linalg.norm(model.pose(q)[:3, 3] - goal[:3, 3]))
    error = np.asarray(error)
    assert np.max(error - np.minimum.accumulate(error)) <= 1e-3  # at most 1 mm past
    assert error[-1] < 1e-5
    assert all(r.status in MOVING for r in results)


def test_the_numpy_engine_steers_and_brakes_as_the_compiled_step_does() -> None:
    """Step by step on the compiled loop's states: the numpy Stepper takes the same steps."""
    model, q = load_robot("iiwa14"), home_configuration("iiwa14")
    qdd = _limits("2", q.size)
    compiled = Lp2Controller(model, dt=DT, qdd_max=qdd)
    numpy_engine = Stepper(model, dt=DT, method="lp2s", qdd_max=qdd)
    goal = model.pose(q)
    goal[:3, 3] += (-0.15, -0.1, 0.1)
    prev = q.copy()
    for _ in range(600):
        fast, slow = compiled.step(q, goal, prev), numpy_engine.step(q, goal, prev)
        assert (fast.status, fast.binding) == (slow.status, slow.binding)
        np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-9)
        prev, q = q, fast.q


def test_a_joint_the_tasks_own_motion_slows_down_brakes_with_what_is_left() -> None:
    motion = np.array([0.3, 1.0, -0.5])  # joint motion per unit of the error
    qdd_max, qd_max = np.full(3, 2.0), np.full(3, 10.0)
    free = braking_scale(motion, np.zeros(3), qdd_max, qd_max, DT)
    # joint 1 already slowed down by the motion's own turn: half of its brake taken
    slowed = np.array([0.0, -0.5 * BRAKING_SHARE * 2.0 * DT**2, 0.0])
    half = braking_scale(motion, slowed, qdd_max, qd_max, DT)
    assert half < free
    assert half == pytest.approx(braking_room(1.0, 0.5 * BRAKING_SHARE * 2.0 * DT**2))
    # a turn that speeds joint 1 up does not add to its brake (it fades as the arm slows)
    assert braking_scale(motion, -slowed, qdd_max, qd_max, DT) == free
    # all of it taken: counted up to HOLD_SHARE, the joint still brakes with the rest
    rest = braking_scale(motion, 4 * slowed, qdd_max, qd_max, DT)
    brake = (1 - HOLD_SHARE) * BRAKING_SHARE * 2.0 * DT**2
    assert 0.0 < rest == pytest.approx(braking_room(1.0, brake))
    for hold in (np.zeros(3), slowed, -slowed, 4 * slowed):
        assert compiled_braking_scale(motion, hold, qdd_max, qd_max, DT) == braking_scale(
            motion, hold, qdd_max, qd_max, DT
        )
