"""Forward kinematics and Jacobian of the built-in serial chain."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robot_cases import MIXED_URDF, random_configurations

from lpik.robots.chain import ChainJoint, SerialChain
from lpik.robots.registry import load_chain, urdf_path
from lpik.robots.rotations import as_transform, exp_so3, log_so3, rpy_to_matrix, transform
from lpik.robots.urdf import load_urdf, parse_urdf

TOOL = (0.02, -0.01, 0.05, 0.3, -0.2, 0.1)


def fd_jacobian(chain: SerialChain, q: np.ndarray, link: str | None = None, h: float = 1e-6):
    """Central differences of the pose: linear part, and the world-frame rotation vector."""
    jac = np.zeros((6, chain.n_joints))
    for i in range(chain.n_joints):
        dq = np.zeros(chain.n_joints)
        dq[i] = h
        plus, minus = chain.fk(q + dq, link), chain.fk(q - dq, link)
        jac[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * h)
        jac[3:, i] = log_so3(plus[:3, :3] @ minus[:3, :3].T) / (2 * h)
    return jac


def test_jacobian_matches_finite_differences_on_bundled_robots(robot_name: str) -> None:
    chain = load_chain(robot_name, tool=TOOL)
    for q in random_configurations(chain, 40, seed=1):
        assert np.allclose(chain.jacobian(q), fd_jacobian(chain, q), atol=1e-8)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=4, max_size=4))
def test_jacobian_matches_finite_differences_on_every_joint_type(values: list[float]) -> None:
    chain = load_urdf(MIXED_URDF, "tool", tool=TOOL)
    q = np.clip(np.array(values), np.maximum(chain.q_min, -3), np.minimum(chain.q_max, 3))
    assert np.allclose(chain.jacobian(q), fd_jacobian(chain, q), atol=1e-8)
    for link in ("l3", "flange"):
        assert np.allclose(chain.jacobian(q, link), fd_jacobian(chain, q, link), atol=1e-8)


def test_mixed_chain_skips_fixed_and_off_chain_joints() -> None:
    chain = load_urdf(MIXED_URDF, "tool")
    assert chain.joint_names == ("rev", "pri", "cont", "rev2")
    assert [j.kind for j in chain.joints] == ["revolute", "prismatic", "revolute", "revolute"]
    assert chain.q_min[2] == -np.inf and chain.q_max[2] == np.inf
    assert chain.qd_max[2] == np.inf and chain.qd_max[1] == 0.5
    assert set(chain.link_names) == {"base", "l1", "l2", "l3", "l4", "l5", "flange", "tool"}


def test_fk_composes_urdf_origins_by_hand() -> None:
    chain = load_urdf(MIXED_URDF, "tool")
    q = np.array([0.4, 0.1, -1.3, 0.7])
    axis_rev = np.ones(3) / np.sqrt(3)
    expected = (
        transform((0.1, 0, 0.2), (0.3, 0, 0.5))
        @ transform((0, 0.1, 0.3), (0.2, -0.4, 0.1))
        @ _rotation(axis_rev * q[0])
        @ transform((0.2, 0, 0), (0, 0.5, 0))
        @ transform((0, -q[1], 0))
        @ transform((0, 0, 0.25), (1.2, 0, -0.3))
        @ _rotation(np.array([0, 0.6, 0.8]) * q[2])
        @ transform((0.15, 0.05, 0))
        @ _rotation(np.array([0, 0, -1.0]) * q[3])
        @ transform((0, 0, 0.1), (3.0, 0.1, 0.2))
        @ transform((0.05, 0, 0.02))
    )
    assert np.allclose(chain.fk(q), expected, atol=1e-12)


def _rotation(w: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = exp_so3(w)
    return out


def test_link_frames_and_joint_frames_agree(robot_name: str) -> None:
    chain = load_chain(robot_name)
    robot = parse_urdf(urdf_path(robot_name))
    q = random_configurations(chain, 1, seed=3)[0]
    frames = chain.joint_frames(q)
    for i, name in enumerate(chain.joint_names):
        assert np.allclose(frames[i], chain.fk(q, robot.joint_map[name].child), atol=1e-14)
    # A link half-way: same frame and Jacobian as the chain that ends there.
    link = robot.joint_map[chain.joint_names[2]].child
    short = load_urdf(urdf_path(robot_name), link, base_link=chain.base_link)
    assert np.allclose(chain.fk(q, link), short.fk(q[:3]))
    jac = chain.jacobian(q, link)
    assert np.allclose(jac[:, :3], short.jacobian(q[:3]))
    assert np.all(jac[:, 3:] == 0)
    assert np.allclose(chain.fk(q, chain.base_link), np.eye(4))


def test_tool_offset_moves_the_task_point() -> None:
    plain = load_chain("panda")
    tooled = load_chain("panda", tool=TOOL)
    q = random_configurations(plain, 1, seed=4)[0]
    assert np.allclose(tooled.fk(q), plain.fk(q) @ as_transform(TOOL))
    assert np.allclose(plain.with_tool(TOOL).jacobian(q), tooled.jacobian(q))
    assert np.allclose(tooled.fk(q, "panda_hand_tcp"), plain.fk(q))


def test_panda_reference_configuration() -> None:
    # All joints at zero: the flange points down, 0.088 m ahead of the base axis.
    chain = load_chain("panda", tip_link="panda_link8")
    pose = chain.fk(np.zeros(7))
    assert np.allclose(pose[:3, 3], (0.088, 0.0, 0.333 + 0.316 + 0.384 - 0.107))
    assert np.allclose(pose[:3, 2], (0.0, 0.0, -1.0))


def test_bad_q_and_unknown_link_are_named() -> None:
    chain = load_chain("ur5e")
    with pytest.raises(ValueError, match=r"q: expected shape \(6,\)"):
        chain.fk(np.zeros(7))
    with pytest.raises(ValueError, match="unknown link 'nope'.*available: base_link"):
        chain.fk(np.zeros(6), "nope")


def test_chain_joint_validation() -> None:
    with pytest.raises(ValueError, match="joint 'a': axis"):
        ChainJoint("a", "revolute", np.eye(4), (0, 0, 0))
    with pytest.raises(ValueError, match="joint 'b': kind"):
        ChainJoint("b", "ball", np.eye(4), (0, 0, 1))
    with pytest.raises(ValueError, match="joint 'c': lower limit"):
        ChainJoint("c", "revolute", np.eye(4), (0, 0, 1), 1.0, -1.0)
    with pytest.raises(ValueError, match="joint 'd': velocity"):
        ChainJoint("d", "revolute", np.eye(4), (0, 0, 1), velocity=0.0)
    with pytest.raises(ValueError, match="no moving joint"):
        SerialChain([])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), st.floats(0.0, np.pi))
def test_log_inverts_exp_over_the_whole_range(direction: list[float], angle: float) -> None:
    axis = np.array(direction)
    if np.linalg.norm(axis) < 1e-3:
        axis = np.array([0.0, 0.0, 1.0])
    w = angle * axis / np.linalg.norm(axis)
    rot = exp_so3(w)
    assert np.allclose(rot.T @ rot, np.eye(3), atol=1e-12)
    back = log_so3(rot)
    assert np.allclose(exp_so3(back), rot, atol=1e-10)
    if angle < np.pi - 1e-6:
        assert np.allclose(back, w, atol=1e-9)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-7, 1e-5, 1e-3, 2.4, 2.6, np.pi - 1e-7, np.pi])
def test_log_near_the_special_angles(angle: float) -> None:
    axis = np.array([0.48, -0.6, 0.64])
    w = angle * axis
    assert np.allclose(exp_so3(log_so3(exp_so3(w))), exp_so3(w), atol=1e-12)
    if angle < np.pi - 1e-6:
        assert np.allclose(log_so3(exp_so3(w)), w, atol=1e-12)


def test_rpy_is_urdf_fixed_axis_convention() -> None:
    r, p, y = 0.3, -0.7, 1.1
    expected = exp_so3((0, 0, y)) @ exp_so3((0, p, 0)) @ exp_so3((r, 0, 0))
    assert np.allclose(rpy_to_matrix((r, p, y)), expected)
    with pytest.raises(ValueError, match="tool: expected a 4 x 4"):
        as_transform(np.zeros(5))
    with pytest.raises(ValueError, match="not a rigid transform"):
        as_transform(np.diag([1.0, 1.0, -1.0, 1.0]))


def test_plain_arrays_reproduce_the_fk() -> None:
    chain = load_urdf(MIXED_URDF, "tool", tool=TOOL)
    origins, axes, revolute, tip = chain.arrays()
    q = np.array([0.3, -0.1, 2.0, -0.7])
    pose = np.eye(4)
    for i in range(chain.n_joints):
        motion = np.eye(4)
        if revolute[i]:
            motion[:3, :3] = exp_so3(axes[i] * q[i])
        else:
            motion[:3, 3] = axes[i] * q[i]
        pose = pose @ origins[i] @ motion
    assert np.allclose(pose @ tip, chain.fk(q), atol=1e-14)
