"""``lpik simulate SCENARIO --robot NAME``: the 3-D scenarios from the command line."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from lpik.cli.main import main


@pytest.mark.parametrize("scenario", ["pull-in", "edge-singularity"])
def test_simulate_writes_the_3d_csv(robot_name: str, scenario: str, tmp_path: Path) -> None:
    out = tmp_path / "run.csv"
    args = ["simulate", scenario, "--robot", robot_name, "--steps", "20", "--out", str(out)]
    assert main(args) == 0
    with out.open(encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    header = rows[0]
    n = sum(1 for h in header if h.startswith("q") and h[1:].isdigit())
    assert header[: n + 5] == ["t", *(f"q{i + 1}" for i in range(n)), "x", "y", "z", "p"]
    m = 6 if scenario == "pull-in" else 3
    assert header[n + 5 : n + 5 + m] == [f"lam{i + 1}" for i in range(m)]
    assert header[n + 5 + m] == "status" and len(rows) == 21


def test_simulate_3d_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    fig = tmp_path / "run.png"
    assert (
        main(["simulate", "pull-in", "--robot", "ur5e", "--steps", "10", "--plot", str(fig)]) == 0
    )
    assert fig.stat().st_size > 10_000
    assert "pull-in ur5e, lp2s: 10 steps" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--robot", "nope"], "unknown robot 'nope'; available: planar, panda, ur5e, iiwa14"),
        (["--robot", "panda", "--animate", "x.gif"], "--animate: draws the planar arm only"),
        (["--robot", "panda", "--method", "foo"], "--method: unknown method 'foo'"),
    ],
)
def test_simulate_3d_errors_are_one_line(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", "pull-in", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and message in captured.err and captured.err.count("\n") == 1
