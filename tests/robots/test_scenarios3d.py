"""The 3-D scenarios on every bundled arm: the pull-in stops at a limit, the stretch stalls."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from lpik.robots.rotations import log_so3
from lpik.scenarios3d import SCENARIOS_3D, Scenario3D, get_scenario_3d, scenario_3d_names


def test_names_match_the_planar_scenarios() -> None:
    from lpik.scenarios import scenario_names

    assert set(scenario_3d_names()) == set(scenario_names())
    with pytest.raises(ValueError, match="unknown 3-D scenario 'x'; available: pull-in"):
        get_scenario_3d("x")
    with pytest.raises(ValueError, match="exactly one of reach, through_axis"):
        Scenario3D("bad", "", "pose")


def test_pull_in_follows_a_straight_line_then_stops(robot_name: str) -> None:
    scenario = SCENARIOS_3D["pull-in"]
    log = scenario.run(robot_name)
    start, target = log.position[0], scenario.target(robot_name)
    line = (target[:3, 3] - start) / np.linalg.norm(target[:3, 3] - start)
    path = log.position - start
    off_line = np.linalg.norm(path - np.outer(path @ line, line), axis=1)
    # First-order steps on a straight command stay on the line while p = 1, and
    # drift a few millimetres at most near the limit or singularity that stops them.
    assert off_line[log.p > 0.99].max() < 5e-3
    assert off_line.max() < 1e-2
    assert log.p[0] == pytest.approx(1.0) and log.p[-1] < 0.05
    assert log.binding[-1] != ""
    moved = float((log.position_end - start) @ line)
    assert 0.1 < moved < np.linalg.norm(target[:3, 3] - start) - 0.05
    # The orientation is held while the tool moves.
    model = scenario.model(robot_name)
    r0 = model.pose(log.q[0])[:3, :3]
    drift = max(np.linalg.norm(log_so3(model.pose(q)[:3, :3] @ r0.T)) for q in log.q[::20])
    assert drift < 1e-3


def test_edge_singularity_stretches_out_and_stalls(robot_name: str) -> None:
    scenario = SCENARIOS_3D["edge-singularity"]
    log = scenario.run(robot_name)
    radial = np.hypot(log.position[:, 0], log.position[:, 1])
    assert np.hypot(*log.position_end[:2]) > radial[0] + 0.2
    assert log.p[-1] < 0.1
    assert np.linalg.norm(scenario.target(robot_name) - log.position_end) > 0.3


def test_csv_columns_of_a_3d_run(tmp_path: Path) -> None:
    log = SCENARIOS_3D["pull-in"].run("panda", steps=5)
    out = log.to_csv(tmp_path / "run.csv")
    with out.open(encoding="utf-8") as handle:
        header = next(csv.reader(handle))
    expected = ["t", *(f"q{i}" for i in range(1, 8)), "x", "y", "z", "p"]
    assert header[:12] == expected
    assert header[12:18] == [f"lam{i}" for i in range(1, 7)]


def test_multiplier_bound_reaches_the_problem() -> None:
    log = SCENARIOS_3D["edge-singularity"].run("ur5e", lambda_bound=5.0, steps=300)
    assert np.nanmax(np.abs(log.lam)) <= 5.0 + 1e-9


def test_tool_path_figure(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from lpik.plots3d import tool_path_figure
    from lpik.robots.registry import load_chain

    scenario = SCENARIOS_3D["edge-singularity"]
    log = scenario.run("panda", steps=30)
    out = tool_path_figure(
        log, tmp_path / "edge.png", chain=load_chain("panda"), target=scenario.target("panda")
    )
    assert out.stat().st_size > 10_000
