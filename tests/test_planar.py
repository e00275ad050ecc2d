"""The paper's planar n-link arm, a serial chain: forward kinematics, Jacobian, task differences."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_strategies import examples, floats, vectors
from lpik.robots import PoseTask, PositionTask, TaskModel, planar_arm
from lpik.robots.rotations import transform


def test_paper_start_configuration(paper_arm: TaskModel, paper_q0: np.ndarray) -> None:
    # Sec. 4: q0 = (60, -30, -30, -30) deg puts the end effector at (3.2321, 0.8660) m.
    np.testing.assert_allclose(paper_arm.position(paper_q0), [3.2321, 0.8660], atol=5e-5)
    np.testing.assert_allclose(
        paper_arm.position(paper_q0), [1.5 + np.sqrt(3), np.sqrt(3) / 2], rtol=1e-14
    )


@pytest.mark.parametrize(
    ("q_deg", "expected"),
    [
        ((0, 0, 0, 0), (4.0, 0.0)),
        ((90, 0, 0, 0), (0.0, 4.0)),
        ((0, 90, 0, 0), (1.0, 3.0)),
        ((0, 90, 90, 0), (-1.0, 1.0)),
        ((0, 180, 0, 0), (-2.0, 0.0)),
        ((45, -45, 0, 0), (np.sqrt(0.5) + 3.0, np.sqrt(0.5))),
    ],
)
def test_closed_form_positions(q_deg: tuple[float, ...], expected: tuple[float, float]) -> None:
    arm = planar_arm([1.0, 1.0, 1.0, 1.0])
    np.testing.assert_allclose(arm.position(np.radians(q_deg)), expected, atol=1e-12)


def test_two_link_closed_form() -> None:
    arm = planar_arm([2.0, 0.5])
    q = np.array([0.3, -1.1])
    x = 2.0 * np.cos(0.3) + 0.5 * np.cos(0.3 - 1.1)
    y = 2.0 * np.sin(0.3) + 0.5 * np.sin(0.3 - 1.1)
    np.testing.assert_allclose(arm.position(q), [x, y], rtol=1e-14)
    J = arm.jacobian(q)
    expected = [
        [-2.0 * np.sin(0.3) - 0.5 * np.sin(-0.8), -0.5 * np.sin(-0.8)],
        [2.0 * np.cos(0.3) + 0.5 * np.cos(-0.8), 0.5 * np.cos(-0.8)],
    ]
    np.testing.assert_allclose(J, expected, rtol=1e-14)


def test_joint_positions_chain_to_the_end_effector(
    paper_arm: TaskModel, paper_q0: np.ndarray
) -> None:
    from lpik.paper.style import arm_points

    pts = arm_points(paper_arm, paper_q0)
    assert pts.shape == (5, 2)
    np.testing.assert_array_equal(pts[0], [0.0, 0.0])
    np.testing.assert_allclose(pts[-1], paper_arm.position(paper_q0), atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(np.diff(pts, axis=0), axis=1), 1.0)
    chain = paper_arm.kinematics
    assert chain.planar and paper_arm.position_dims == 2


def test_the_planar_arm_is_a_masked_task_over_a_serial_chain() -> None:
    position = planar_arm([1.0, 2.0])
    pose = planar_arm([1.0, 2.0], task="pose")
    assert isinstance(position, PositionTask) and position.row_names == ("x", "y")
    assert isinstance(pose, PoseTask) and pose.row_names == ("x", "y", "rz")
    chain = position.kinematics
    assert [j.kind for j in chain.joints] == ["revolute", "revolute"]
    np.testing.assert_array_equal(chain.joints[1].origin, transform((1.0, 0.0, 0.0)))
    np.testing.assert_array_equal(chain.tip_offset, transform((2.0, 0.0, 0.0)))


def test_pose_task_appends_the_tool_angle(paper_q0: np.ndarray) -> None:
    arm = planar_arm([1.0, 1.0, 1.0, 1.0], task="pose")
    assert arm.task_dim == 3
    w = arm.pose(paper_q0)  # a 4 x 4 pose: the tool angle is its rotation about z
    np.testing.assert_allclose(w[:2, 3], arm.position(paper_q0))
    assert np.arctan2(w[1, 0], w[0, 0]) == pytest.approx(np.radians(-30.0))
    np.testing.assert_allclose(arm.jacobian(paper_q0)[2], np.ones(4), rtol=1e-15)


def test_pose_difference_wraps_the_angle() -> None:
    arm = planar_arm([1.0, 1.0, 1.0], task="pose")
    a = transform((0.0, 0.0, 0.0), (0.0, 0.0, np.pi - 0.1))
    b = transform((1.0, 2.0, 0.0), (0.0, 0.0, -np.pi + 0.1))
    np.testing.assert_allclose(arm.difference(a, b), [1.0, 2.0, 0.2], atol=1e-12)
    np.testing.assert_allclose(arm.difference(b, a), [-1.0, -2.0, -0.2], atol=1e-12)
    position = planar_arm([1.0, 1.0])
    np.testing.assert_array_equal(position.difference([1.0, 2.0, 0], [0.5, 3.0, 0]), [-0.5, 1.0])


@pytest.mark.parametrize("task", ["position", "pose"])
@settings(max_examples=examples(100))
@given(data=st.data())
def test_jacobian_matches_central_differences(task: str, data: st.DataObject) -> None:
    n = data.draw(st.integers(1, 8), label="n")
    lengths = data.draw(vectors(n, floats(0.1, 3.0)))
    arm = planar_arm(lengths.tolist(), task=task)
    q = data.draw(vectors(n, floats(-2 * np.pi, 2 * np.pi)), label="q")
    J = arm.jacobian(q)
    assert J.shape == (arm.task_dim, n)
    h = 1e-6
    fd = np.column_stack(
        [arm.difference(arm.pose(q - h * e), arm.pose(q + h * e)) / (2 * h) for e in np.eye(n)]
    )
    np.testing.assert_allclose(J, fd, rtol=0, atol=1e-7 * max(1.0, float(lengths.sum())))


def test_the_arm_is_a_task_model(paper_arm: TaskModel) -> None:
    assert isinstance(paper_arm, TaskModel)
    assert paper_arm.n_joints == 4 and paper_arm.task_dim == 2
    assert paper_arm.joint_names == ("joint 1", "joint 2", "joint 3", "joint 4")
    np.testing.assert_array_equal(paper_arm.q_min, np.full(4, -np.pi))
    np.testing.assert_array_equal(paper_arm.qd_max, np.ones(4))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"link_lengths": []}, "link_lengths"),
        ({"link_lengths": [1.0, -1.0]}, "link_lengths"),
        ({"link_lengths": [1.0, np.nan]}, "link_lengths"),
        ({"link_lengths": [1.0, 1.0], "task": "orientation"}, "task"),
        ({"link_lengths": [1.0, 1.0], "q_min": [0.0, 0.0, 0.0]}, "q_min"),
        ({"link_lengths": [1.0, 1.0], "q_min": 1.0, "q_max": 0.0}, "q_min"),
        ({"link_lengths": [1.0, 1.0], "q_max": [0.0, np.nan]}, "q_max"),
        ({"link_lengths": [1.0, 1.0], "qd_max": 0.0}, "qd_max"),
    ],
)
def test_bad_arguments_name_themselves(kwargs: dict[str, object], name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name}:"):
        planar_arm(**kwargs)  # type: ignore[arg-type]


def test_wrong_configuration_length_is_an_error(paper_arm: TaskModel) -> None:
    with pytest.raises(ValueError, match="^q:"):
        paper_arm.position(np.array([0.0, 0.0]))
    with pytest.raises(ValueError, match="^q:"):
        paper_arm.jacobian(np.zeros(5))
