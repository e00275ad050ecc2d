"""The built-in chain held equal to Pinocchio, and the Pinocchio adapter."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from robot_cases import MIXED_URDF, random_configurations

from lpik.robots.pinocchio_adapter import INSTALL_HINT, PinocchioChain
from lpik.robots.registry import ROBOTS, load_chain, urdf_path
from lpik.robots.tasks import PoseTask
from lpik.robots.urdf import load_urdf

pin = pytest.importorskip("pinocchio")

TOOL = (0.01, -0.03, 0.12, 0.2, 0.0, -0.4)
N_CONFIGURATIONS = 300


def test_chain_equals_pinocchio_on_bundled_urdf(robot_name: str) -> None:
    """FK and Jacobian of SerialChain against Pinocchio's own, 300 configurations."""
    spec = ROBOTS[robot_name]
    chain = load_chain(robot_name)
    model = pin.buildModelFromUrdf(str(urdf_path(robot_name)))
    data = model.createData()
    frame = model.getFrameId(spec.tip_link)
    names = list(model.names)
    cols = [model.joints[names.index(n)].idx_v for n in chain.joint_names]
    rows = [model.joints[names.index(n)].idx_q for n in chain.joint_names]
    for q in random_configurations(chain, N_CONFIGURATIONS, seed=11):
        q_pin = pin.neutral(model)
        q_pin[rows] = q
        pin.framesForwardKinematics(model, data, q_pin)
        expected = data.oMf[frame].homogeneous
        jac = pin.computeFrameJacobian(model, data, q_pin, frame, pin.LOCAL_WORLD_ALIGNED)
        pose, ours = chain.fk_jacobian(q)
        np.testing.assert_allclose(pose, expected, rtol=0, atol=1e-10)
        np.testing.assert_allclose(ours, jac[:, cols], rtol=0, atol=1e-10)


def test_limits_equal_pinocchio(robot_name: str) -> None:
    chain = load_chain(robot_name)
    adapter = PinocchioChain.from_urdf(urdf_path(robot_name), ROBOTS[robot_name].tip_link)
    assert adapter.joint_names == chain.joint_names
    np.testing.assert_array_equal(adapter.q_min, chain.q_min)
    np.testing.assert_array_equal(adapter.q_max, chain.q_max)
    np.testing.assert_array_equal(adapter.qd_max, chain.qd_max)


def test_adapter_equals_chain_with_tool_and_base(robot_name: str) -> None:
    spec = ROBOTS[robot_name]
    chain = load_chain(robot_name, tool=TOOL)
    adapter = PinocchioChain.from_urdf(urdf_path(robot_name), spec.tip_link, spec.base_link, TOOL)
    for q in random_configurations(chain, 50, seed=12):
        np.testing.assert_allclose(adapter.fk(q), chain.fk(q), atol=1e-10)
        np.testing.assert_allclose(adapter.jacobian(q), chain.jacobian(q), atol=1e-10)


def test_adapter_on_every_joint_type_and_an_inner_base(tmp_path: Path) -> None:
    chain = load_urdf(MIXED_URDF, "tool", base_link="l1", tool=TOOL)
    path = tmp_path / "mixed.urdf"
    path.write_text(MIXED_URDF)
    model = pin.buildModelFromUrdf(str(path))
    adapter = PinocchioChain(model, "tool", "l1", TOOL)
    assert adapter.joint_names == chain.joint_names
    assert np.isinf(adapter.q_max[2])  # the continuous joint
    for q in random_configurations(chain, 50, seed=13):
        np.testing.assert_allclose(adapter.fk(q), chain.fk(q), atol=1e-10)
        np.testing.assert_allclose(adapter.jacobian(q), chain.jacobian(q), atol=1e-10)
    task = PoseTask(adapter)
    assert task.jacobian(np.zeros(4)).shape == (6, 4)


def test_adapter_errors_name_the_frame() -> None:
    model = pin.buildModelFromUrdf(str(urdf_path("panda")))
    with pytest.raises(ValueError, match="tip frame 'nope' is not in the Pinocchio model"):
        PinocchioChain(model, "nope")
    with pytest.raises(ValueError, match="do not form a chain"):
        PinocchioChain(model, "panda_leftfinger", "panda_rightfinger")
    with pytest.raises(ValueError, match="qd_max: expected shape"):
        PinocchioChain(model, "panda_link8", qd_max=np.ones(3))


def test_missing_pinocchio_raises_the_install_command(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pinocchio", None)
    with pytest.raises(ImportError) as info:
        PinocchioChain(None, "tool0")
    assert str(info.value) == 'pip install "lpik[pinocchio]"' == INSTALL_HINT
