"""Every script of examples/ runs (shortened by LPIK_EXAMPLE_STEPS), so that none can rot."""

from __future__ import annotations

import runpy
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SCRIPTS = sorted(p.name for p in EXAMPLES.glob("*.py") if not p.name.startswith("_"))
#: What each example needs beyond lpik itself.
NEEDS = {
    "mujoco_scene.py": ("numba", "mujoco"),
    "pinocchio_loop.py": ("numba", "pinocchio"),
    "dexterity_sweep.py": ("numba", "matplotlib"),
    "own_urdf_1khz.py": ("numba",),
    "trajectory_acceleration.py": ("numba",),
}


def test_the_examples_are_the_ones_the_readme_links() -> None:
    readme = (EXAMPLES.parent / "README.md").read_text(encoding="utf-8")
    assert len(SCRIPTS) >= 6
    for name in SCRIPTS:
        assert f"examples/{name}" in readme, name


@pytest.mark.parametrize("name", SCRIPTS)
def test_an_example_runs(name: str, tmp_path, monkeypatch, capsys) -> None:  # type: ignore[no-untyped-def]
    for module in NEEDS.get(name, ()):
        pytest.importorskip(module)
    monkeypatch.setenv("LPIK_EXAMPLE_STEPS", "60")
    monkeypatch.setenv("LPIK_EXAMPLE_OUT", str(tmp_path))
    monkeypatch.syspath_prepend(str(EXAMPLES))
    runpy.run_path(str(EXAMPLES / name), run_name="__main__")
    out = capsys.readouterr().out
    assert out.strip(), "an example says what it did"
    assert "nan" not in out.lower()
    if name == "dexterity_sweep.py":  # the sweep is worth a plot: p spans 0..1 under both methods
        assert out.count("p from 0.00 to 1.00") == 2, out
