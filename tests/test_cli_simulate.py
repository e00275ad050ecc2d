"""``lpik simulate``: the CSV contract, the figure and the animation, and one-line input errors."""

from __future__ import annotations

import csv
import os

import pytest

from lpik.cli import progress as progress_mod
from lpik.cli.main import main
from lpik.cli.progress import LazyProgress


def read_csv(path) -> list[list[str]]:
    with open(path, newline="") as handle:
        return list(csv.reader(handle))


def test_simulate_writes_the_csv_contract(tmp_path, capsys) -> None:
    out = tmp_path / "run.csv"
    assert main(["simulate", "pull-in", "--method", "lp2", "--out", str(out), "--steps", "30"]) == 0
    rows = read_csv(out)
    assert ",".join(rows[0][:10]) == "t,q1,q2,q3,q4,x,y,p,lam1,lam2"
    assert len(rows) == 31
    assert float(rows[1][0]) == 0.0 and float(rows[2][0]) == pytest.approx(0.01)
    captured = capsys.readouterr()
    assert "30 steps" in captured.out and str(out) in captured.out
    assert captured.err == ""  # no progress bar when stderr is not a terminal


def test_options_reach_the_run(tmp_path) -> None:
    out = tmp_path / "edge.csv"
    args = ["simulate", "edge-singularity", "--out", str(out), "--steps", "12", "--dt", "0.02"]
    assert main([*args, "--lambda-bound", "0.002"]) == 0
    rows = read_csv(out)[1:]
    assert len(rows) == 12 and float(rows[-1][0]) == pytest.approx(11 * 0.02)
    assert max(abs(float(r[c])) for r in rows for c in (8, 9)) <= 0.002 + 1e-12
    assert any("multiplier" in r[11] for r in rows)


def test_lp1_has_nan_multipliers_and_cold_start_runs(tmp_path) -> None:
    out = tmp_path / "lp1.csv"
    assert main(["simulate", "pull-in", "--method", "lp1", "--out", str(out), "--steps", "5",
                 "--cold-start"]) == 0  # fmt: skip
    assert all(r[8] == "nan" and r[9] == "nan" for r in read_csv(out)[1:])


def test_plot_and_animation(tmp_path) -> None:
    fig, gif = tmp_path / "run.png", tmp_path / "run.gif"
    args = ["simulate", "pull-in", "--steps", "20", "--plot", str(fig), "--animate", str(gif)]
    assert main([*args, "--frames", "5"]) == 0
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from PIL import Image

    with Image.open(gif) as image:
        assert image.format == "GIF" and image.n_frames == 5


def test_animation_frame_count_is_capped(tmp_path) -> None:
    gif = tmp_path / "run.gif"
    assert main(["simulate", "pull-in", "--steps", "200", "--animate", str(gif)]) == 0
    from PIL import Image

    with Image.open(gif) as image:
        assert image.n_frames == 60
    assert gif.stat().st_size < 1_000_000


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["pull-out"], ["pull-out", "pull-in", "edge-singularity"]),
        (["pull-in", "--method", "simplex"], ["--method", "simplex", "lp2", "nlp"]),
        (["pull-in", "--steps", "0"], ["--steps"]),
        (["pull-in", "--steps", "-4"], ["--steps"]),
        (["pull-in", "--steps", "ten"], ["--steps"]),
        (["pull-in", "--dt", "0"], ["--dt"]),
        (["pull-in", "--dt", "-0.01"], ["--dt"]),
        (["pull-in", "--dt", "nan"], ["--dt"]),
        (["pull-in", "--lambda-bound", "0"], ["--lambda-bound"]),
        (["pull-in", "--lambda-bound", "-1"], ["--lambda-bound"]),
        (["pull-in", "--lambda-bound", "inf"], ["--lambda-bound"]),
        (["pull-in", "--method", "lp1", "--lambda-bound", "1"], ["--lambda-bound", "lp1"]),
        (["pull-in", "--frames", "1"], ["--frames"]),
        (["pull-in", "--out", "/nonexistent-dir/run.csv"], ["--out", "not found"]),
        (["pull-in", "--plot", "/nonexistent-dir/fig.png"], ["--plot"]),
        (["pull-in", "--animate", "/nonexistent-dir/run.gif"], ["--animate"]),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, words, capsys) -> None:
    assert main(["simulate", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err
    for word in words:
        assert word in captured.err


def test_out_is_a_directory(tmp_path, capsys) -> None:
    assert main(["simulate", "pull-in", "--steps", "2", "--out", str(tmp_path)]) == 2
    assert "directory" in capsys.readouterr().err


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write anywhere")
def test_out_not_writable(tmp_path, capsys) -> None:
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert main(["simulate", "pull-in", "--steps", "2", "--out", str(locked / "r.csv")]) == 2
    assert "permission" in capsys.readouterr().err


def test_lazy_progress_shows_after_a_while_and_cleans_up(monkeypatch) -> None:
    monkeypatch.setattr(progress_mod, "SHOW_AFTER_S", 0.0)
    with LazyProgress("run", enabled=True) as bar:
        for k in range(1, 5):
            bar(k, 10)
        assert bar._progress is not None
    assert bar._progress is None
    quiet = LazyProgress("run", enabled=False)
    quiet(1, 10)
    assert quiet._progress is None


def test_the_help_names_every_method_and_on_stall(capsys) -> None:
    from lpik.methods.registry import METHODS

    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert all(name in text for name in METHODS)
    assert "--on-stall N" in text
    assert "none: never, the paper's strict steps (default 1)" in text


def test_on_stall_must_be_a_positive_step_count(capsys) -> None:
    assert main(["simulate", "pull-in", "--on-stall", "0"]) == 2
    assert "--on-stall: must be in 1.." in capsys.readouterr().err


def test_a_reader_that_closes_the_pipe_ends_lpik_quietly(monkeypatch, capsys) -> None:
    """`lpik robots --json | head`: no 'lpik: error: Broken pipe', SIGPIPE's exit status."""

    class ClosedPipe:
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self) -> None:
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr("sys.stdout", ClosedPipe())
    assert main(["robots", "--json"]) == 141
    assert capsys.readouterr().err == ""


def test_out_dash_writes_clean_csv_on_stdout_and_the_rest_on_stderr(tmp_path) -> None:
    import subprocess

    from cli_documents import LPIK

    fig = tmp_path / "run.png"
    out = subprocess.run(
        [str(LPIK), "simulate", "pull-in", "--steps", "7", "--out", "-", "--plot", str(fig)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    rows = list(csv.reader(out.stdout.splitlines()))
    assert rows[0][:3] == ["t", "q1", "q2"] and len(rows) == 8
    assert all(len(r) == len(rows[0]) for r in rows)
    assert "7 steps" in out.stderr and f"wrote {fig}" in out.stderr
    assert "wrote the CSV on stdout" in out.stderr and fig.exists()


def test_out_dash_in_process_keeps_the_summary_off_stdout(capsys) -> None:
    assert main(["simulate", "pull-in", "--steps", "4", "--out", "-"]) == 0
    captured = capsys.readouterr()
    assert captured.out.splitlines()[0].startswith("t,q1,") and len(captured.out.splitlines()) == 5
    assert "4 steps" in captured.err and "4 steps" not in captured.out


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--plot", "x.csv"], ["--plot", "'x.csv'", ".csv", ".png"]),
        (["--plot", "-"], ["--plot", "stdout"]),
        (["--animate", "x.mp4"], ["--animate", ".gif"]),
        (["--animate", "-"], ["--animate", "stdout"]),
        (["--out", "/dev/full"], ["--out", "/dev/full", "No space left"]),
        (["--animate", "/dev/full"], ["--animate", "/dev/full", "No space left"]),
        (["--plot", "/dev/full"], ["--plot", "/dev/full", "No space left"]),
        (["--out", "{tmp}/a.png", "--plot", "{tmp}/a.png"], ["--plot", "--out"]),
    ],
)
def test_every_output_is_checked_before_the_run_and_named(
    args, words, tmp_path, monkeypatch, capsys
) -> None:
    if "/dev/full" in args and not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    from lpik.paper.setup import Setup

    def ran(*a, **k):
        raise AssertionError("the run started")

    monkeypatch.setattr(Setup, "run", ran)
    args = [a.format(tmp=tmp_path) for a in args]
    assert main(["simulate", "pull-in", "--steps", "3", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err
    for word in words:
        assert word in captured.err


def test_a_figure_and_an_animation_without_extension_are_written_under_that_name(
    tmp_path, capsys
) -> None:
    fig, gif = tmp_path / "overview", tmp_path / "motion"
    args = ["simulate", "pull-in", "--steps", "20", "--plot", str(fig), "--animate", str(gif)]
    assert main([*args, "--frames", "3"]) == 0
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and gif.read_bytes()[:6] == b"GIF89a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["motion", "overview"]
    out = capsys.readouterr().out
    assert f"wrote {fig}\n" in out and f"wrote {gif}\n" in out


def test_a_figure_onto_dev_null_is_written_and_nothing_else(tmp_path, capsys) -> None:
    if not os.path.exists("/dev/null"):
        pytest.skip("no /dev/null here")
    assert main(["simulate", "pull-in", "--steps", "5", "--plot", "/dev/null"]) == 0
    assert "wrote /dev/null" in capsys.readouterr().out
