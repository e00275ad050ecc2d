"""`lpik compile` and compile_kernels: every kernel of lpik.fast readied and reported."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("numba")

from lpik.cli.compile import compile_kernels  # noqa: E402
from lpik.cli.main import main  # noqa: E402

NAMES = [
    "fused step (a serial chain's, or a backend's kinematics)",
    'the stall stage\'s progress step (on_stall, mode="progress")',
    "fused step batch, serial chain",
    "the automatic multiplier bound's rule, after a step on the HiGHS path",
    'LP2 ratio test (lp2, path="compiled")',
    "LP2 batch (lp2_batch, lp2)",
    "LP2 batch (lp2_batch, lp2s)",
    "fused step with distance rows (AvoidingLp2Controller)",
    "the recovery stage's least_error_step (inside a scene's d_s)",
    "the recovery stage's largest_share_lp (inside a scene's d_s)",
    "the recovery stage's state_rows (inside a scene's d_s)",
    "capability map's inverse kinematics and steps (lpik map)",
]


def test_compile_json_lists_every_kernel(capsys) -> None:
    assert main(["compile", "--json"]) == 0
    loads = json.loads(capsys.readouterr().out)
    assert [load["name"] for load in loads] == NAMES
    for load in loads:
        assert set(load) == {"name", "source", "seconds", "cache_path"}
        assert load["source"] in {"compiled", "disk cache", "in memory"}
        assert load["seconds"] >= 0 and load["cache_path"]


def test_a_second_call_finds_every_kernel_in_memory(capsys) -> None:
    compile_kernels()
    again = compile_kernels()
    assert [k.source for k in again] == ["in memory"] * len(NAMES)
    assert main(["compile"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split("  ")[0] for line in lines[: len(NAMES)]] == NAMES
    assert all("in memory" in line for line in lines[: len(NAMES)])
    assert lines[-1].startswith("numba cache: ")


def test_jobs_ready_the_same_kernels_in_child_processes() -> None:
    # The children load (or compile) into the disk cache this process uses.
    loads = compile_kernels(jobs=2)
    assert [load.name for load in loads] == NAMES
    assert {load.source for load in loads} <= {"compiled", "disk cache", "in memory"}
    assert {load.cache_path for load in loads} == {k.cache_path for k in compile_kernels()}


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True, "2"])
def test_jobs_must_be_a_positive_integer(jobs) -> None:
    with pytest.raises(ValueError, match="jobs: must be a positive integer"):
        compile_kernels(jobs=jobs)


def test_the_command_line_refuses_no_jobs_in_one_line(capsys) -> None:
    assert main(["compile", "--jobs", "0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--jobs: must be a whole number >= 1, got 0" in err


def test_the_progress_line_says_what_numba_compiles_and_nothing_from_the_cache() -> None:
    import io

    from numba import njit

    from lpik.fast.compiling import CompileProgress

    def plus_one(x):  # type: ignore[no-untyped-def]
        return x + 1

    stream = io.StringIO()
    kernel = njit(plus_one)
    with CompileProgress("a test", stream, live=False) as progress:
        assert kernel(1) == 2  # compiles
    lines = stream.getvalue().splitlines()
    assert progress.count == 1 and len(lines) == 2
    assert lines[0].startswith("a test: compiling") and "lpik compile" in lines[0]
    assert lines[1].startswith("a test: compiled 1 function in ")
    quiet = io.StringIO()
    with CompileProgress("a test", quiet, live=False):
        assert kernel(2) == 3  # compiled already: nothing to say
    assert quiet.getvalue() == ""
