"""``lpik robots`` and ``lpik robots --json``."""

from __future__ import annotations

import json

import pytest

from lpik.cli.main import main
from lpik.cli.robots import JSON_KEYS
from lpik.robots.registry import robot_names


def test_json_lists_every_robot_with_the_contract_keys(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "--json"]) == 0
    entries = json.loads(capsys.readouterr().out)
    assert [e["name"] for e in entries] == list(robot_names())
    for entry in entries:
        assert tuple(entry) == JSON_KEYS
        n = entry["n_joints"]
        assert len(entry["joint_names"]) == len(entry["q_min"]) == len(entry["qd_max"]) == n
        assert entry["urdf"].endswith(".urdf")
        with open(entry["urdf"], encoding="utf-8") as handle:
            assert "<robot" in handle.read()


def test_json_for_one_robot(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "--json", "ur5e"]) == 0
    (entry,) = json.loads(capsys.readouterr().out)
    assert entry["name"] == "ur5e" and entry["tip_link"] == "tool0" and entry["n_joints"] == 6


def test_table_shows_joints_and_limits(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    for name in robot_names():
        assert f"{name}: " in out
    assert "panda_joint4      -3.0718      -0.0698" in out
    assert "tip link panda_hand_tcp" in out


def test_unknown_robot_is_one_line_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "nope"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert (
        captured.err.strip() == "lpik: error: unknown robot 'nope'; available: panda, ur5e, iiwa14"
    )
