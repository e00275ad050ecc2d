"""``lpik reproduce``: the bound's derivation, the figures, the CSV logs and summary.md."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from lpik.cli.main import main
from lpik.exceptions import MissingBackendError
from lpik.paper import figures as plots
from lpik.paper import style
from lpik.paper.reproduce import reproduce
from lpik.paper.runs import FIGURES, SWEEP_BOUNDS, choose_lambda_bound, round_up_1sig
from paper_runs import edge_unbounded, lp2_pull_in

RUNS = (
    "pull-in-lp1",
    "pull-in-lp1-warm-start",
    "pull-in-lp2",
    "pull-in-lp2s",
    "edge-singularity-lp2-unbounded",
    "edge-singularity-lp2-bounded",
)
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    stages: list[str] = []
    return reproduce(out, progress=stages.append), stages


def png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


# --- the multiplier bound --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "expected"),
    [(0.094, 0.1), (0.1, 0.1), (0.23, 0.3), (3.0, 3.0), (3.01, 4.0), (0.0071, 0.008), (95, 100)],
)
def test_round_up_1sig(value: float, expected: float) -> None:
    assert round_up_1sig(value) == pytest.approx(expected)


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf")])
def test_round_up_1sig_rejects(value: float) -> None:
    with pytest.raises(ValueError):
        round_up_1sig(value)


def test_bound_comes_from_the_lambda_history() -> None:
    log = edge_unbounded()
    choice = choose_lambda_bound(log)
    lam = np.nanmax(np.abs(log.lam), axis=1)
    free = log.p >= 1 - 1e-9
    assert choice.free_max == pytest.approx(lam[free].max())
    assert 2 * choice.free_max <= choice.bound < 4 * choice.free_max
    assert choice.peak == pytest.approx(lam.max())
    assert choice.bound < choice.late_median / 10  # well below the chattering level


def test_bound_needs_multipliers_and_a_free_phase() -> None:
    from paper_runs import lp1_warm

    with pytest.raises(ValueError, match="multipliers"):
        choose_lambda_bound(lp1_warm())
    assert lp2_pull_in().p[0] == 1.0  # the pull-in run has a free phase: a bound exists
    assert choose_lambda_bound(lp2_pull_in()).bound > 0


# --- the files -------------------------------------------------------------------------------


def test_every_figure_and_csv_is_written(reproduced) -> None:
    result, stages = reproduced
    names = {p.name for p in result.files}
    assert set(FIGURES) <= names
    assert {f"{r}.csv" for r in RUNS} <= names
    assert "summary.md" in names
    assert all(p.exists() and p.stat().st_size > 0 for p in result.files)
    assert "figures" in stages
    for name in FIGURES:
        width, height = png_size(result.out_dir / name)
        assert width >= 900 and height >= 600  # readable when shown at README width


def test_csv_behind_figures_has_the_contract_header(reproduced) -> None:
    result, _ = reproduced
    for run in RUNS:
        header = (result.out_dir / f"{run}.csv").read_text().splitlines()[0]
        assert header.startswith("t,q1,q2,q3,q4,x,y,p,lam1,lam2,")
    for _, runs in FIGURES.values():
        assert set(runs) <= set(RUNS)


def test_reproduce_uses_the_derived_bound(reproduced) -> None:
    result, _ = reproduced
    bounded = result.logs["edge-singularity-lp2-bounded"]
    assert result.choice == choose_lambda_bound(result.logs["edge-singularity-lp2-unbounded"])
    assert np.nanmax(np.abs(bounded.lam)) <= result.choice.bound * (1 + 1e-9)
    assert set(SWEEP_BOUNDS) | {result.choice.bound} == set(result.sweep)


def test_summary_reports_the_computed_numbers(reproduced) -> None:
    result, _ = reproduced
    text = (result.out_dir / "summary.md").read_text()
    for run, log in result.logs.items():
        m = log.metrics()
        row = next(line for line in text.splitlines() if line.startswith(f"| {run} |"))
        assert f"| {m.jitter:.4g} |" in row
        assert f"{np.rad2deg(m.max_q[0]):.3f}" in row
    assert f"B = {result.choice.bound:g}" in text
    assert f"{result.choice.free_max:.3g}" in text
    for name in FIGURES:
        assert f"`{name}`" in text
    for bound in result.sweep:
        assert f"| {bound:g}" in text


def test_reproduce_bad_out_dir(tmp_path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["reproduce", "--out", str(blocker / "sub")]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "--out" in captured.err


def test_missing_matplotlib_names_the_extra(monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(MissingBackendError, match=r"lpik\[plot\]"):
        style.require_backend()
    with pytest.raises(MissingBackendError):
        plots.xy_figure(lp2_pull_in(), None, "unused.png", title="x")
