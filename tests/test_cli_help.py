"""``lpik simulate --help`` describes every scenario (planar and 3-D), its defaults and refusals."""

from __future__ import annotations

import contextlib
import io

import pytest

from lpik.cli.main import main
from lpik.methods.registry import METHODS
from lpik.paper.scenarios import SCENARIOS
from lpik.robots.registry import robot_names


def _help() -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit):
        main(["simulate", "--help"])
    return " ".join(out.getvalue().split())  # unwrapped


def test_every_scenario_is_described_on_both_kinds_of_arm_with_its_defaults() -> None:
    text = _help()
    for scenario in SCENARIOS.values():
        described = " ".join(scenario.describe().split())
        assert described in text
        assert f"Default {scenario.steps} steps at dt = {scenario.dt:g} s" in described
        assert "Planar (--robot planar)" in described
        # a scenario without a 3-D run says so
        assert ("3-D (--robot NAME)" in described) == (scenario.arm is not None)
        assert ("The planar arm only." in described) == (scenario.arm is None)
    for name in robot_names():
        assert name in text
    assert "empty when none" in text and "x, y, z [m]" in text
    assert "reach: " in text and "--target X,Y,Z" in text and "--scene SCENE.json" in text
    assert "min_distance" in text and "closest" in text


def test_each_refused_combination_is_explained_and_refused_in_one_line() -> None:
    text = _help()
    unbounded = next(name for name, spec in METHODS.items() if not spec.bounds_multipliers)
    assert "refused combinations" in text and "--animate with a 3-D --robot" in text
    for args, option in (
        (["--method", unbounded, "--lambda-bound", "1"], "--lambda-bound"),
        (["--robot", "panda", "--animate", "x.gif"], "--animate"),
    ):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            assert main(["simulate", "pull-in", *args]) == 2
        assert err.getvalue().count("\n") == 1 and option in err.getvalue()
