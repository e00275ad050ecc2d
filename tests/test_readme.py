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
        exec(compile(block, str(README), "exec"), namespace)  # noqa: S102
    assert 0.0 <= namespace["result"].p <= 1.0
    assert namespace["log"].binding[-1] == "joint 1 upper end-stop"
    assert (tmp_path / "pull-in-lp2.csv").is_file()


def test_readme_two_commands_match_ci() -> None:
    text = README.read_text(encoding="utf-8")
    commands = re.findall(r"```sh\n(.*?)\n```", text, re.S)[:2]
    ci = (README.parent / ".ci" / "run").read_text(encoding="utf-8")
    assert "lpik reproduce" in commands[0]
    assert commands[1] in ci, "'.ci/run' must run exactly the README's test command"
