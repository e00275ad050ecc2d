"""Task spaces: difference() and jacobian() agree to first order; masks; the protocol."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robot_cases import MIXED_URDF, random_configurations

from lpik.robots.base import TaskModel
from lpik.robots.chain import ChainJoint, SerialChain
from lpik.robots.registry import load_chain, load_robot
from lpik.robots.rotations import exp_so3, transform
from lpik.robots.tasks import (
    OrientationTask,
    PoseTask,
    PositionTask,
    make_task,
)
from lpik.robots.urdf import load_urdf

TASK_KINDS = ("position", "orientation", "pose")
MASKS = {"position": "xz", "orientation": "rx rz", "pose": (1, 1, 1, 0, 0, 1)}


def first_order_error(task: TaskModel, q: np.ndarray, dq: np.ndarray, eps: float) -> float:
    """| difference(pose(q), pose(q + eps dq)) - eps J(q) dq |."""
    moved = task.difference(task.pose(q), task.pose(q + eps * dq))
    return float(np.linalg.norm(moved - eps * task.jacobian(q) @ dq))


@pytest.mark.parametrize("kind", TASK_KINDS)
@pytest.mark.parametrize("masked", [False, True], ids=["all-rows", "masked"])
def test_difference_is_jacobian_times_dq_to_first_order(
    robot_name: str, kind: str, masked: bool
) -> None:
    task = load_robot(robot_name, task=kind, mask=MASKS[kind] if masked else None)
    rng = np.random.default_rng(5)
    for q in random_configurations(task.kinematics, 10, seed=6):
        dq = rng.normal(size=task.n_joints)
        e1 = first_order_error(task, q, dq, 1e-3)
        e2 = first_order_error(task, q, dq, 5e-4)
        assert e1 < 1e-5
        assert e2 < 0.3 * e1 + 1e-12  # the remainder is second order: halving eps quarters it


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4),
    st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4),
)
def test_pose_first_order_on_every_joint_type(q: list[float], dq: list[float]) -> None:
    task = PoseTask(load_urdf(MIXED_URDF, "tool"))
    qa = np.array(q)
    qa[1] = np.clip(qa[1], -0.29, 0.29)  # the prismatic joint's end-stops
    assert first_order_error(task, qa, np.array(dq), 1e-4) < 1e-6


def test_orientation_difference_is_the_world_frame_log() -> None:
    task = OrientationTask(load_chain("iiwa14"))
    a = exp_so3((0.3, -0.2, 0.5))
    w = np.array([0.1, 0.7, -0.4])
    b = exp_so3(w) @ a
    assert np.allclose(task.difference(a, b), w)
    assert np.allclose(task.difference(b, a), -w)
    assert np.allclose(task.difference(a, a), 0.0)


def test_pose_difference_stacks_translation_and_rotation() -> None:
    task = PoseTask(load_chain("ur5e"))
    a = transform((0.1, 0.2, 0.3), (0.2, 0.1, -0.3))
    b = transform((0.4, 0.0, 0.1), (0.0, 0.5, 0.2))
    d = task.difference(a, b)
    assert np.allclose(d[:3], (0.3, -0.2, -0.2))
    assert np.allclose(exp_so3(d[3:]) @ a[:3, :3], b[:3, :3])


@pytest.mark.parametrize(
    ("kind", "mask", "rows"),
    [
        ("position", "xy", ("x", "y")),
        ("position", "z", ("z",)),
        ("position", (0, 1, 1), ("y", "z")),
        ("orientation", "rz", ("rz",)),
        ("pose", "x y z rz", ("x", "y", "z", "rz")),
        ("pose", "x,rx", ("x", "rx")),
        ("pose", None, ("x", "y", "z", "rx", "ry", "rz")),
    ],
)
def test_masks_select_rows(kind: str, mask: object, rows: tuple[str, ...]) -> None:
    full = load_robot("panda", task=kind)
    task = load_robot("panda", task=kind, mask=mask)  # type: ignore[arg-type]
    assert task.row_names == rows and task.task_dim == len(rows)
    q = np.array(load_chain("panda").q_min + 0.5)
    keep = [full.row_names.index(r) for r in rows]
    assert np.allclose(task.jacobian(q), full.jacobian(q)[keep])
    a, b = full.pose(q), full.pose(q + 0.01)
    assert np.allclose(task.difference(a, b), full.difference(a, b)[keep])


@pytest.mark.parametrize(
    ("kind", "mask", "message"),
    [
        ("position", "xq", "unknown row name"),
        ("position", (1, 0), "expected 3 flags"),
        ("pose", (0, 0, 0, 0, 0, 0), "keeps no row"),
        ("orientation", "x", "unknown row name"),
        ("speed", None, "unknown task 'speed'; available: position, orientation, pose"),
    ],
)
def test_bad_masks_and_tasks_are_named(kind: str, mask: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make_task(load_chain("panda"), kind, mask)  # type: ignore[arg-type]


@pytest.mark.parametrize("cls", [PositionTask, OrientationTask, PoseTask])
def test_tasks_implement_the_protocol(cls: type) -> None:
    task = cls(load_chain("panda"))
    assert isinstance(task, TaskModel)
    assert task.n_joints == 7 and task.q_min.shape == (7,)
    q = np.zeros(7) + 0.1
    assert task.position(q).shape == (3,)
    assert task.jacobian(q).shape == (task.task_dim, 7)


def test_planar_arm_is_a_masked_position_task() -> None:
    from lpik.robots.planar import planar_arm

    planar = planar_arm([1.0, 1.0, 1.0, 1.0])
    joints = [
        ChainJoint(f"joint {i + 1}", "revolute", transform((1.0 if i else 0.0, 0, 0)), (0, 0, 1))
        for i in range(4)
    ]
    chain = SerialChain(joints, tip_offset=transform((1.0, 0, 0)), name="planar-4")
    task = PositionTask(chain, mask="xy")
    q = np.deg2rad([60.0, -30.0, -30.0, -30.0])
    assert np.allclose(task.pose(q), planar.pose(q))
    assert np.allclose(task.pose(q)[:2], planar.position(q))
    assert np.allclose(task.jacobian(q), planar.jacobian(q))
    w0, w1 = planar.pose(q), planar.pose(q + 0.01)
    assert np.allclose(
        task.difference(np.append(w0, 0.0), np.append(w1, 0.0)), planar.difference(w0, w1)
    )


@pytest.mark.parametrize("kind", TASK_KINDS)
def test_difference_jacobian_is_the_derivative_away_from_the_reference(kind: str) -> None:
    task = load_robot("panda", task=kind, mask=MASKS[kind])
    q0, q = random_configurations(task.kinematics, 2, seed=9)
    a = task.pose(q0)
    h = 1e-6
    numeric = np.column_stack(
        [
            (task.difference(a, task.pose(q + h * e)) - task.difference(a, task.pose(q - h * e)))
            / (2 * h)
            for e in np.eye(task.n_joints)
        ]
    )
    assert np.allclose(task.difference_jacobian(a, q), numeric, atol=1e-7)
    assert np.allclose(task.difference_jacobian(task.pose(q), q), task.jacobian(q), atol=1e-12)
