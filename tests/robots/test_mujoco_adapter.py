"""The MuJoCo adapter held equal to the built-in chain."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from robot_cases import MIXED_URDF, random_configurations

from lpik.robots.mujoco_adapter import INSTALL_HINT, MujocoChain, kinematic_urdf
from lpik.robots.registry import ROBOTS, load_chain, urdf_path
from lpik.robots.tasks import PoseTask
from lpik.robots.urdf import load_urdf

mujoco = pytest.importorskip("mujoco")

TOOL = (0.01, -0.03, 0.12, 0.2, 0.0, -0.4)

# MuJoCo cannot load a floating joint from URDF; the off-chain branch is dropped.
MIXED_NO_FLOAT = MIXED_URDF.replace(
    '<joint name="float" type="floating"><origin xyz="0 0 0.1" rpy="0 0 0"/>'
    '<parent link="l2"/><child link="branch"/><axis xyz="0 0 1"/></joint>',
    "",
).replace('<link name="branch"/>', "")


def test_adapter_equals_chain_on_bundled_robots(robot_name: str) -> None:
    spec = ROBOTS[robot_name]
    chain = load_chain(robot_name, tool=TOOL)
    adapter = MujocoChain.from_urdf(urdf_path(robot_name), spec.tip_link, spec.base_link, TOOL)
    assert adapter.joint_names == chain.joint_names
    np.testing.assert_array_equal(adapter.q_min, chain.q_min)
    np.testing.assert_array_equal(adapter.q_max, chain.q_max)
    np.testing.assert_array_equal(adapter.qd_max, chain.qd_max)
    for q in random_configurations(chain, 200, seed=21):
        np.testing.assert_allclose(adapter.fk(q), chain.fk(q), atol=1e-10)
        np.testing.assert_allclose(adapter.jacobian(q), chain.jacobian(q), atol=1e-10)


def test_adapter_on_every_joint_type_and_an_inner_base() -> None:
    assert "floating" not in MIXED_NO_FLOAT
    chain = load_urdf(MIXED_NO_FLOAT, "tool", base_link="l1", tool=TOOL)
    adapter = MujocoChain.from_urdf(MIXED_NO_FLOAT, "tool", "l1", TOOL)
    assert adapter.joint_names == chain.joint_names
    assert np.isinf(adapter.q_max[2]) and adapter.qd_max[1] == 0.5
    for q in random_configurations(chain, 50, seed=22):
        np.testing.assert_allclose(adapter.fk(q), chain.fk(q), atol=1e-10)
        np.testing.assert_allclose(adapter.jacobian(q), chain.jacobian(q), atol=1e-10)
    assert PoseTask(adapter).jacobian(np.zeros(4)).shape == (6, 4)


def test_kinematic_urdf_drops_geometry_and_keeps_links() -> None:
    text = MIXED_NO_FLOAT.replace(
        '<link name="l3"/>',
        '<link name="l3"><visual><geometry><mesh filename="package://x/y.stl"/></geometry>'
        '</visual><inertial><mass value="-1"/></inertial></link>',
    )
    assert "mesh" not in kinematic_urdf(text) and "fusestatic" in kinematic_urdf(text)
    MujocoChain.from_urdf(text, "tool")


def test_adapter_errors_name_the_body() -> None:
    model = mujoco.MjModel.from_xml_string(kinematic_urdf(urdf_path("panda").read_text()))
    with pytest.raises(ValueError, match="tip body 'nope' is not in the MuJoCo model"):
        MujocoChain(model, "nope")
    with pytest.raises(ValueError, match="do not form a chain"):
        MujocoChain(model, "panda_leftfinger", "panda_rightfinger")
    with pytest.raises(ValueError, match="qd_max: expected one number or shape"):
        MujocoChain(model, "panda_link8", qd_max=np.ones(2))
    with pytest.raises(ValueError, match="velocity limits are needed .*panda_joint1"):
        MujocoChain(model, "panda_link8")  # MuJoCo keeps none: never a silent inf
    assert MujocoChain(model, "panda_link8", qd_max=np.inf).qd_max[0] == np.inf


def test_missing_mujoco_raises_the_install_command(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(ImportError) as info:
        MujocoChain(None, "tool0")
    assert str(info.value) == 'pip install "lpik[mujoco]"' == INSTALL_HINT
