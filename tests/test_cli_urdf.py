"""``--urdf FILE --tip LINK [--base LINK]`` wherever ``--robot`` is taken: runs and one-line errors.

The arm is a tiny 7-joint URDF written here (with a fixed mount and a gripper
branch off the chain), or a bundled arm's URDF file read as any other URDF.
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from lpik.cli.main import build_parser, main
from lpik.cli.robots import robot_from_arguments
from lpik.robots.arm import Arm
from lpik.robots.registry import urdf_path

#: (name, axis, origin z [m], lower, upper [rad]) of the tiny arm's revolute joints.
JOINTS = (
    ("j1", "0 0 1", 0.3, -2.0, 2.0),
    ("j2", "0 1 0", 0.0, -1.5, 1.0),
    ("j3", "0 0 1", 0.3, -2.5, 2.5),
    ("j4", "0 1 0", 0.3, 0.2, 2.4),
    ("j5", "0 0 1", 0.2, -2.0, 2.6),
    ("j6", "0 1 0", 0.1, -1.8, 1.8),
    ("j7", "0 0 1", 0.1, -3.0, 3.0),
)


def tiny_urdf() -> str:
    """A 7-joint arm ``tiny``: world, fixed to base_link, l1 .. l6, tool; a finger off the chain."""
    links = ["world", "base_link", *(f"l{k}" for k in range(1, 7)), "tool", "finger"]
    parts = ['<?xml version="1.0"?>', '<robot name="tiny">']
    parts += [f'  <link name="{name}"/>' for name in links]
    parts.append(
        '  <joint name="mount" type="fixed"><parent link="world"/><child link="base_link"/></joint>'
    )
    chain = ["base_link", *(f"l{k}" for k in range(1, 7)), "tool"]
    for (name, axis, z, lower, upper), parent, child in zip(JOINTS, chain, chain[1:]):
        parts.append(
            f'  <joint name="{name}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="0 0 {z}"/><axis xyz="{axis}"/>'
            f'<limit lower="{lower}" upper="{upper}" velocity="2" effort="1"/></joint>'
        )
    parts.append(
        '  <joint name="grip" type="prismatic"><parent link="tool"/><child link="finger"/>'
        '<axis xyz="1 0 0"/><limit lower="0" upper="0.04" velocity="0.1" effort="1"/></joint>'
    )
    return "\n".join([*parts, "</robot>", ""])


@pytest.fixture
def urdf(tmp_path):
    path = tmp_path / "tiny.urdf"
    path.write_text(tiny_urdf(), encoding="utf-8")
    return path


def read_csv(path) -> list[list[str]]:
    with open(path, newline="") as handle:
        return list(csv.reader(handle))


def test_simulate_reach_runs_a_urdf_arm_from_the_middle_of_its_end_stops(
    urdf, tmp_path, capsys
) -> None:
    out = tmp_path / "run.csv"
    args = ["simulate", "reach", "--urdf", str(urdf), "--tip", "tool", "--target", "0.3,0.1,0.6"]
    assert main([*args, "--steps", "40", "--out", str(out)]) == 0
    rows = read_csv(out)
    assert rows[0][:11] == ["t", *(f"q{k}" for k in range(1, 8)), "x", "y", "z"]
    middle = [(lower + upper) / 2 for *_, lower, upper in JOINTS]
    assert np.allclose([float(v) for v in rows[1][1:8]], middle)
    start, end = (np.array([float(v) for v in row[8:11]]) for row in (rows[1], rows[-1]))
    goal = np.array([0.3, 0.1, 0.6])
    assert np.linalg.norm(end - goal) < np.linalg.norm(start - goal) - 0.05, "it did not move"
    assert "reach tiny, lp2s: 40 steps" in capsys.readouterr().out


def test_a_bundled_arms_file_read_as_any_urdf_with_base_and_tip(tmp_path) -> None:
    out = tmp_path / "run.csv"
    args = ["simulate", "pull-in", "--urdf", str(urdf_path("panda")), "--tip", "panda_link8"]
    assert main([*args, "--base", "panda_link0", "--steps", "5", "--out", str(out)]) == 0
    rows = read_csv(out)
    assert "q7" in rows[0] and "q8" not in rows[0] and len(rows) == 6


def test_the_parsed_options_name_the_arm(urdf) -> None:
    parser = build_parser()
    args = parser.parse_args(["simulate", "pull-in", "--urdf", str(urdf), "--tip", "l6"])
    arm = robot_from_arguments(args)
    assert isinstance(arm, Arm) and arm.name == "tiny" and arm.chain.n_joints == 6
    assert arm.chain.base_link == "world" and arm.chain.tip_link == "l6"
    base = robot_from_arguments(
        parser.parse_args(
            ["simulate", "pull-in", "--urdf", str(urdf), "--tip", "l6", "--base", "l2"]
        )  # fmt: skip
    )
    assert isinstance(base, Arm) and base.chain.n_joints == 4
    assert robot_from_arguments(parser.parse_args(["simulate", "pull-in"])) == "planar"
    assert robot_from_arguments(parser.parse_args(["console", "--robot", "ur5e"])) == "ur5e"
    assert robot_from_arguments(parser.parse_args(["console", "--planar"])) == "planar"


ERRORS = (
    (["--urdf", "{dir}/none.urdf", "--tip", "tool"], "--urdf: cannot read", "no such file"),
    (["--urdf", "{dir}", "--tip", "tool"], "--urdf: cannot read", "it is a directory"),
    (["--urdf", "{dir}/bad.urdf", "--tip", "tool"], "--urdf: URDF", "malformed XML"),
    (["--urdf", "{dir}/other.urdf", "--tip", "tool"], "--urdf: URDF", "expected <robot>"),
    (["--urdf", "{urdf}", "--tip", "hand"], "--tip: ", "has no link 'hand'; its links: 'world'"),
    (["--urdf", "{urdf}", "--tip", "tool", "--base", "l9"], "--base: ", "has no link 'l9'"),
    (["--urdf", "{urdf}", "--tip", "base_link"], "--urdf: URDF", "has no moving joint"),
    (["--urdf", "{urdf}", "--tip", "l1", "--base", "tool"], "--urdf: URDF", "do not form a chain"),
    (["--urdf", "{urdf}"], "--tip: --urdf needs", "--tip LINK"),
    (["--tip", "tool"], "--tip: only with --urdf", ""),
    (["--base", "world"], "--base: only with --urdf", ""),
    # not panda: argparse takes bench's default object given again for no choice at all
    (["--robot", "ur5e", "--urdf", "{urdf}"], "--urdf: not allowed with argument --robot", ""),
    (["--urdf", "{urdf}", "--tip", "tool", "--scene", "panda-shelf"], "--scene: ", "'tiny'"),
)


#: The start of every command that takes ``--urdf`` (the errors come before any run).
HEADS = {
    "simulate": ["simulate", "pull-in"],
    "console": ["console", "--port", "0"],
    "map": ["map", "--region=0,1,0,1,0,1", "--resolution", "0.5", "--out", "{dir}/map"],
    "bench": ["bench", "--quick", "--peers", "none", "--no-cold"],
}


@pytest.mark.parametrize("command", list(HEADS))
@pytest.mark.parametrize(("args", "start", "detail"), ERRORS)
def test_bad_urdf_options_are_one_line_and_exit_2(
    command, args, start, detail, urdf, tmp_path, capsys
) -> None:
    for module in {"console": ["viser"], "map": ["distributed", "zarr", "xarray"]}.get(command, []):
        pytest.importorskip(module)
    if "--scene" in args and command in ("map", "bench"):
        pytest.skip(f"lpik {command} takes no --scene")
    (tmp_path / "bad.urdf").write_text("<robot", encoding="utf-8")
    (tmp_path / "other.urdf").write_text("<sdf/>", encoding="utf-8")
    filled = [a.format(dir=tmp_path, urdf=urdf) for a in args]
    head = [a.format(dir=tmp_path) for a in HEADS[command]]
    if not any(a in ("--urdf", "--robot") for a in args):  # one of them is required
        head += {"console": ["--planar"], "map": ["--robot", "planar"]}.get(command, [])
    assert main([*head, *filled]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err
    assert start in captured.err and detail in captured.err, captured.err


def test_bench_times_a_urdf_arm(urdf, capsys) -> None:
    pytest.importorskip("numba")
    args = ["bench", "--urdf", str(urdf), "--tip", "tool", "--quick", "--rounds", "1"]
    assert main([*args, "--peers", "none", "--no-cold", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    environment = next(r for r in records if r["kind"] == "environment")
    assert environment["workload"].startswith("tiny, 6-D pose task")
    assert {r["robot"] for r in records if r["kind"] == "timing"} == {"tiny", "planar-4"}
    assert not any("singular configurations" in r["what"] for r in records), "the Panda's only"
    first = [r for r in records if r["kind"] in ("first call", "skipped")]
    assert first and all(r["kind"] == "first call" for r in first), first
    checks = [r for r in records if r["kind"] == "agreement"]
    fused = [r["passed"] for r in checks if r["method"] == "lp2 fused (compiled)"]
    assert fused and all(fused), "the URDF arm's fused step is not numpy's lp2"


def test_the_console_drives_a_urdf_arm(urdf) -> None:
    from lpik.console import console_robot

    args = build_parser().parse_args(["console", "--urdf", str(urdf), "--tip", "tool"])
    robot = console_robot(robot_from_arguments(args))
    assert robot.name == "tiny" and robot.model.n_joints == 7 and not robot.planar
    middle = [(lower + upper) / 2 for *_, lower, upper in JOINTS]
    assert np.allclose(robot.q0, middle) and robot.home_target().shape == (4, 4)
    assert robot.capsules, "nothing to draw"
