"""The README's Python blocks run, in order, in one namespace (so none of them rots)."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run(tmp_path, monkeypatch) -> None:
    pytest.importorskip("numba")
    monkeypatch.chdir(tmp_path)  # the blocks write files (e.g. a CSV log): not into the checkout
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert len(blocks) >= 4
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(README), "exec"), namespace)
    assert 0.0 <= namespace["result"].p <= 1.0
    assert namespace["log"].binding[-1] == "joint 1 upper end-stop"  # strict, the default
    assert "off_direction" not in namespace["log"].status  # no stall stage unless asked for
    assert namespace["with_stall_stage"].status[-1] == "off_direction"  # on_stall=1
    assert (tmp_path / "pull-in-lp2.csv").is_file()


def test_readme_two_commands_match_ci() -> None:
    text = README.read_text(encoding="utf-8")
    commands = re.findall(r"```sh\n(.*?)\n```", text, re.S)[:2]
    ci = (README.parent / ".ci" / "run").read_text(encoding="utf-8")
    assert "lpik reproduce" in commands[0]
    assert commands[1] in ci, "'.ci/run' must run exactly the README's test command"


def _table_rows(text: str, first_cells: tuple[str, ...]) -> list[list[str]]:
    rows = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.replace(r"\|", "!").strip().strip("|").split("|")]
        if line.startswith("|") and cells[0].startswith(first_cells):
            rows.append(cells)
    return rows


def test_readme_results_table_is_the_one_of_docs_summary() -> None:
    """The README's table of the paper's runs is copied from docs/summary.md: they must agree."""
    readme = _table_rows(README.read_text(encoding="utf-8"), ("pull-in,", "edge singularity,"))
    summary_text = (README.parent / "docs" / "summary.md").read_text(encoding="utf-8")
    summary = _table_rows(summary_text, ("pull-in-", "edge-singularity-"))
    assert len(readme) == len(summary) == 7
    for ours, theirs in zip(readme, summary):
        assert float(ours[1]) == float(theirs[3]), ours[0]  # jitter, same digits
        assert float(ours[2]) == pytest.approx(float(theirs[4]), abs=0.01), ours[0]  # max q1
        assert float(ours[3]) == pytest.approx(float(theirs[5]), abs=5e-4), ours[0]  # final p
        assert ours[4] == theirs[6], ours[0]  # final end effector
