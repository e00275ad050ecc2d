"""The soak of docs/reliability.md, sized for CI: a random walk with acceleration limits.

Every step is checked independently (:mod:`lpik_bench.soak`): no acceleration
limit broken on any step, no end-stop or velocity limit broken from a state
within its limits, never further out while recovering from a glitch past an
end-stop, no NaN. The long run's figures are in docs/reliability.md.
"""

from __future__ import annotations

import pytest

from lpik_bench.closed_loops import run
from lpik_bench.soak import soak

pytest.importorskip("numba")


@pytest.mark.parametrize(("path", "steps", "glitch_every"), [("compiled", 30_000, 5_000),
                                                             ("numpy engine", 1_500, 500),
                                                             ("numpy", 1_500, 500)])  # fmt: skip
def test_a_random_walk_with_acceleration_limits_breaks_no_limit(path, steps, glitch_every) -> None:
    report = soak(steps, path=path, seed=3, glitch_every=glitch_every)
    assert report.broken() == 0, report
    assert report.worst_acceleration_ratio <= 1.0 + 1e-9
    assert report.glitches == (steps - 1) // glitch_every
    assert report.statuses.get("recovering", 0) > 0  # each glitch was recovered from
    assert report.statuses.get("optimal", 0) > 0


def test_the_long_soak_is_in_the_reliability_page() -> None:
    """docs/reliability.md holds the generated soak block, with nothing broken."""
    from pathlib import Path

    from lpik_bench.soak import BEGIN, END

    text = (Path(__file__).parent.parent / "docs" / "reliability.md").read_text(encoding="utf-8")
    block = text.split(BEGIN, 1)[1].split(END, 1)[0]
    assert "Produced by `python -m lpik_bench.soak --steps 1000000" in block
    rows = [line for line in block.splitlines() if line.startswith(("| compiled", "| numpy"))]
    assert [row.split("|")[1].strip() for row in rows] == ["compiled", "numpy engine", "numpy"]
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[2].startswith("0 (") and cells[3] == "0 / 0"  # acceleration, stops/speed
        assert cells[4:7] == ["0", "0", "0"]  # further out, NaN, p outside [0, 1]


@pytest.mark.parametrize(("robot", "setting", "steps"), [
    ("ur5e", "unclamped, qdd_max=10", 3_000),
    ("iiwa14", 'mode="progress", qdd_max=5', 2_000),
    ("panda", "the shelf scene, qdd_max=10", 1_500),
    ("panda", "the shelf scene, unclamped, qdd_max=10", 1_500),
    ("panda", "the shelf scene, field and rows, qdd_max=10", 1_500),
])  # fmt: skip
def test_closed_loops_over_other_arms_and_settings_break_no_limit(robot, setting, steps) -> None:
    """lpik_bench.closed_loops, sized for CI: a bad velocity sample at step 246 (seed 3), the
    walk often out of reach; every step checked, also against the shelf's d_s and each pair's
    damper row."""
    report = run(robot, setting, steps, seed=3)
    assert report.broken() == 0, report
    assert report.past_damper == 0, report  # the stops ahead of d_i: every damper row kept
    assert report.glitches >= 1 and report.statuses.get("recovering", 0) >= 1
    assert report.steps == steps and report.statuses.get("optimal", 0) > 0


def test_a_closed_loop_on_measured_joints_keeps_its_contract() -> None:
    """lpik_bench.closed_loops' encoder-noise setting, sized for CI: every step held to the
    contract of a loop closed on noisy readings (lpik_bench.soak.check_measured_step)."""
    from lpik_bench.closed_loops import SETTINGS

    setting = next(name for name in SETTINGS if "noise" in SETTINGS[name])
    report = run("panda", setting, 2_000, seed=3)
    assert report.broken() == 0, report
    assert report.steps == 2_000 and report.statuses.get("optimal", 0) > 0
    assert report.worst_acceleration_ratio > 0.0  # the band was checked


def test_the_closed_loops_are_in_the_reliability_page() -> None:
    """docs/reliability.md holds the generated table: every arm and setting, nothing broken."""
    from pathlib import Path

    from lpik_bench.closed_loops import BEGIN, END, SETTINGS

    text = (Path(__file__).parent.parent / "docs" / "reliability.md").read_text(encoding="utf-8")
    block = text.split(BEGIN, 1)[1].split(END, 1)[0]
    assert "python -m lpik_bench.closed_loops --steps 40000" in block
    rows = [line for line in block.splitlines() if line.startswith("| ") and "steps |" not in line]
    scenes = sum("scene" in options for options in SETTINGS.values())
    assert len(rows) == 3 * (len(SETTINGS) - scenes) + scenes  # the scenes on the Panda alone
    for row in rows:
        broken = row.strip("|").split("|")[2].strip()
        assert broken == "0 / 0 / 0 / 0 / 0 / 0 / 0", row
