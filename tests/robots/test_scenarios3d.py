"""The scenarios on every bundled 3-D arm: the pull-in stops at a limit, the stretch stalls."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from lpik.paper.scenarios import SCENARIOS
from lpik.robots.rotations import log_so3


def test_pull_in_follows_a_straight_line_then_stops(robot_name: str) -> None:
    setup = SCENARIOS["pull-in"].setup(robot_name)
    log = setup.run(on_stall=None)  # the paper's steps: along the line, then a stop
    start, target = log.position[0], setup.target
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
    model = setup.model
    r0 = model.pose(log.q[0])[:3, :3]
    drift = max(np.linalg.norm(log_so3(model.pose(q)[:3, :3] @ r0.T)) for q in log.q[::20])
    assert drift < 1e-3


def test_edge_singularity_stretches_out_and_stalls(robot_name: str) -> None:
    setup = SCENARIOS["edge-singularity"].setup(robot_name)
    log = setup.run()
    radial = np.hypot(log.position[:, 0], log.position[:, 1])
    assert np.hypot(*log.position_end[:2]) > radial[0] + 0.2
    assert log.p[-1] < 0.1
    assert np.linalg.norm(setup.target - log.position_end) > 0.3


def test_csv_columns_of_a_3d_run(tmp_path: Path) -> None:
    log = SCENARIOS["pull-in"].run(robot="panda", steps=5)
    out = log.to_csv(tmp_path / "run.csv")
    with out.open(encoding="utf-8") as handle:
        header = next(csv.reader(handle))
    expected = ["t", *(f"q{i}" for i in range(1, 8)), "x", "y", "z", "p"]
    assert header[:12] == expected
    assert header[12:18] == [f"lam{i}" for i in range(1, 7)]


def test_multiplier_bound_reaches_the_problem() -> None:
    log = SCENARIOS["edge-singularity"].run(robot="ur5e", lambda_bound=5.0, steps=300)
    assert np.nanmax(np.abs(log.lam)) <= 5.0 + 1e-9


def test_tool_path_figure(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from lpik.paper.run_figures import tool_path_figure

    setup = SCENARIOS["edge-singularity"].setup("panda")
    log = setup.run(steps=30)
    out = tool_path_figure(log, tmp_path / "edge.png", model=setup.model, target=setup.target)
    assert out.stat().st_size > 10_000
