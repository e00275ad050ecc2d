"""Every method of lpik runs one step on every bundled arm and every task."""

from __future__ import annotations

import numpy as np
import pytest

from lpik.methods import ALL_METHODS, METHODS, solve
from lpik.problem import Problem
from lpik.result import STATUSES
from lpik.robots.registry import home_configuration, load_robot
from lpik.robots.rotations import rpy_to_matrix

LIMIT_AWARE = frozenset(name for name, spec in METHODS.items() if spec.limit_aware)


DT = 0.01  # [s]
#: A command reachable in one step: 2 mm, and 0.005 rad about the task point.
SMALL = ((0.0015, -0.001, 0.001), (0.005, 0.0, -0.0025))
#: A command far beyond one step's velocity limits: 20 cm.
LARGE = ((0.2, 0.0, 0.0), (0.0, 0.0, 0.0))


def step_problem(name: str, task: str, command: tuple) -> tuple[object, Problem]:
    model = load_robot(name, task=task)
    q0 = home_configuration(name)
    pose = model.kinematics.fk(q0)
    goal = pose.copy()
    goal[:3, 3] += command[0]  # translate the task point, turn the frame about it
    goal[:3, :3] = rpy_to_matrix(command[1]) @ pose[:3, :3]
    target = {"position": goal[:3, 3], "orientation": goal[:3, :3], "pose": goal}[task]
    problem = Problem(
        J=model.jacobian(q0),
        dw=model.difference(model.pose(q0), target),
        q0=q0,
        q_min=model.q_min,
        q_max=model.q_max,
        dq_min=-model.qd_max * DT,
        dq_max=model.qd_max * DT,
        joint_names=model.joint_names,
    )
    return model, problem


@pytest.mark.parametrize("method", ALL_METHODS)
@pytest.mark.parametrize("task", ["position", "orientation", "pose"])
def test_every_method_on_every_robot(robot_name: str, task: str, method: str) -> None:
    model, problem = step_problem(robot_name, task, SMALL)
    result = solve(problem, method, model=model)
    assert result.status in STATUSES
    assert result.q.shape == (model.n_joints,) and np.all(np.isfinite(result.q))
    assert 0.0 <= result.p <= 1.0
    if method in LIMIT_AWARE:
        assert result.moved
        assert np.all(result.q >= model.q_min - 1e-9) and np.all(result.q <= model.q_max + 1e-9)
        assert np.all(np.abs(result.dq) <= model.qd_max * DT + 1e-9)
    if method in ("lp1", "lp2", "nlp"):
        assert result.p == pytest.approx(1.0)
        assert np.allclose(
            problem.J @ result.dq, problem.dw, atol=1e-6 if method != "nlp" else 1e-3
        )
    if method in ("lp2", "nlp"):
        # The step lands on the command: to first order (lp2) or exactly (nlp).
        moved = model.difference(model.pose(problem.q0), model.pose(result.q))
        tol = 0.02 * np.linalg.norm(problem.dw) if method == "lp2" else 1e-7
        assert np.allclose(moved, problem.dw, atol=tol)


@pytest.mark.parametrize("method", sorted(LIMIT_AWARE - {"l1"}))
def test_velocity_limits_bind_a_large_command(robot_name: str, method: str) -> None:
    model, problem = step_problem(robot_name, "pose", LARGE)
    result = solve(problem, method, model=model)
    assert 0.0 < result.p < 1.0
    assert result.binding is not None and any(n in result.binding for n in model.joint_names)
    assert np.all(np.abs(result.dq) <= model.qd_max * DT + 1e-9)
