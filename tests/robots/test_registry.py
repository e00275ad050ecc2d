"""Bundled robots: names, files, licences, limits, home configurations."""

from __future__ import annotations

import numpy as np
import pytest

from lpik.robots.registry import (
    ROBOTS,
    home_configuration,
    list_robots,
    load_chain,
    load_robot,
    robot_names,
    urdf_path,
)

EXPECTED = {"panda": 7, "ur5e": 6, "iiwa14": 7}


def test_the_three_arms_are_bundled() -> None:
    assert set(robot_names()) == set(EXPECTED)
    for info in list_robots():
        assert info.n_joints == EXPECTED[info.name] == len(info.joint_names)
        assert info.tip_link == ROBOTS[info.name].tip_link
        assert info.urdf.endswith(".urdf")
        assert all(lo < hi for lo, hi in zip(info.q_min, info.q_max))
        assert all(v > 0 for v in info.qd_max)


def test_unknown_robot_lists_the_names() -> None:
    with pytest.raises(ValueError, match="unknown robot 'x'; available: panda, ur5e, iiwa14"):
        load_robot("x")


def test_every_robot_ships_notice_and_licence(robot_name: str) -> None:
    folder = urdf_path(robot_name).parent
    notice = (folder / "NOTICE").read_text()
    licence = (folder / "LICENSE").read_text()
    assert "Upstream:" in notice and "github.com/" in notice and "Licence:" in notice
    assert ("Apache License" in licence) or ("BSD 3-Clause" in licence)
    text = urdf_path(robot_name).read_text()
    assert "<mesh" not in text and "<inertial" not in text


def test_home_is_inside_the_limits_and_not_singular(robot_name: str) -> None:
    chain = load_chain(robot_name)
    home = home_configuration(robot_name)
    assert np.all(chain.q_min < home) and np.all(home < chain.q_max)
    singular_values = np.linalg.svd(chain.jacobian(home), compute_uv=False)
    assert singular_values[-1] > 1e-2


@pytest.mark.parametrize(("task", "m"), [("position", 3), ("orientation", 3), ("pose", 6)])
def test_load_robot_builds_each_task(robot_name: str, task: str, m: int) -> None:
    model = load_robot(robot_name, task=task)
    assert model.name == robot_name and model.task_dim == m
    assert model.jacobian(home_configuration(robot_name)).shape == (m, EXPECTED[robot_name])


def test_load_robot_tip_link_and_tool() -> None:
    flange = load_robot("panda", task="position", tip_link="panda_link8")
    tcp = load_robot("panda", task="position")
    q = home_configuration("panda")
    assert np.linalg.norm(tcp.pose(q) - flange.pose(q)) == pytest.approx(0.1034)
    tooled = load_robot("iiwa14", task="position", tool=(0.0, 0.0, 0.2))
    plain = load_robot("iiwa14", task="position")
    q = home_configuration("iiwa14")
    assert np.linalg.norm(tooled.pose(q) - plain.pose(q)) == pytest.approx(0.2)
    with pytest.raises(ValueError, match="unknown tip link 'nope'"):
        load_robot("ur5e", tip_link="nope")
