"""benchmarks/random_goals.py: the draw, one goal's run and the page's section.

No timing and no count of goals reached is asserted: those are the benchmark's
findings (docs/benchmarks.md), not properties of the code.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.robots.registry import home_configuration, load_robot  # noqa: E402
from lpik_bench import random_goals as R  # noqa: E402


def test_the_goal_configurations_lie_in_the_middle_of_every_joint_s_range() -> None:
    model = load_robot("panda")
    goals = R.goal_configurations(model, 200, seed=3)
    margin = 0.5 * (1.0 - R.MIDDLE) * (model.q_max - model.q_min)
    assert goals.shape == (200, model.n_joints)
    assert np.all(goals >= model.q_min + margin) and np.all(goals <= model.q_max - margin)
    assert np.array_equal(goals, R.goal_configurations(model, 200, seed=3))  # seeded


def test_a_goal_near_home_is_reached_and_counted_so() -> None:
    """A goal 0.05 rad from home on two joints: the run reaches it, and a run too short to
    get there is a miss whose text names how far off it ended."""
    home = home_configuration("panda")
    goal = home + np.array([0.05, -0.05, 0, 0, 0, 0, 0])
    run = R.run_goal("panda", 0, goal, qdd_max=10.0, steps=1500)
    assert run.reached and run.reached_at is not None and run.reached_at < 1500
    assert run.goal_ratio > 0.0 and 0 <= run.law_changes <= run.reversals
    assert run.step_times.shape == (1500,) and np.all(run.step_times > 0.0)
    assert run.uncompiled == 0  # every step on the compiled path
    short = R.run_goal("panda", 1, goal, qdd_max=None, steps=3)
    assert not short.reached and short.reached_at is None
    assert short.position_error > R.REACHED[0]
    assert R.miss_text(short).startswith("goal 1: ")


def test_reversals_count_a_joint_whose_acceleration_flips_at_more_than_half_its_limit() -> None:
    """Two joints' accelerations per step (in rad per step squared), limit 1."""
    threshold = R.REVERSAL_SHARE * 1.0
    steps = np.array([[0.9, 0.0], [-0.9, 0.0], [0.9, 0.2], [0.1, -0.2], [-0.1, 0.6], [0.0, -0.6]])
    flips = [R.reverses(now, before, threshold) for before, now in zip(steps[:-1], steps[1:])]
    assert flips == [True, True, False, False, True]


def test_the_section_lists_every_row_and_every_miss(tmp_path) -> None:  # type: ignore[no-untyped-def]
    rows = [("panda", "none", "29 of 30", "2.50 / 4.00", "-"),
            ("panda", "10", "28 of 30", "2.60 / 4.80", "1,920 (1,500)"),
            ("panda", "2", "24 of 30", "3.70 / 7.20", "9,400 (8,300)")]  # fmt: skip
    misses = ["- panda, qdd_max=2: goal 5: 0.09 mm, 0 mrad off, x (sigma ratio at the goal 4e-04)"]
    text = R.section(rows, misses, 30, 0, (10.0, 2.0), "python benchmarks/random_goals.py")
    assert text.startswith(R.HEADING)
    for row in rows:
        assert f"| {' | '.join(row)} |" in text
    assert "with `qdd_max` 10 and 2 rad/s^2 on every joint" in text
    assert misses[0] in text
    assert "- none" in R.section(rows, [], 30, 0, (10.0,), "c")
    timings = [("panda", "qdd_max=10", "9.1 / 90 / 150 / 320", "0 of 300,000")]
    assert "| panda | qdd_max=10 | 9.1 / 90 / 150 / 320 | 0 of 300,000 |" in R.section(
        rows, misses, 30, 0, (10.0,), "c", timings
    )


def test_every_limit_measured_is_a_row_of_each_arm(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """main runs each arm without acceleration limits and with each limit given: one row each."""
    calls = []

    def run_goal(robot, index, goal, qdd_max, steps=R.STEPS):  # type: ignore[no-untyped-def]
        calls.append((robot, qdd_max))
        return R.GoalRun(index, 0.0, 0.0, 10, "optimal", "-", 0.1, 3, np.ones(2), 0, 1)

    monkeypatch.setattr(R, "run_goal", run_goal)
    page = tmp_path / "page.md"
    page.write_text("# page\n", encoding="utf-8")
    R.main(["--goals", "2", "--robots", "panda", "--qdd-max", "10", "2", "--out", str(page)])
    assert calls == [("panda", None)] * 2 + [("panda", 10.0)] * 2 + [("panda", 2.0)] * 2
    text = page.read_text(encoding="utf-8")
    assert "| panda | none | 2 of 2 | 0.01 / 0.01 | - |" in text
    assert "| panda | 2 | 2 of 2 | 0.01 / 0.01 | 6 (2) |" in text


def test_timing_reads_every_step_of_every_run() -> None:
    runs = [
        R.GoalRun(0, 0.0, 0.0, 0, "optimal", "-", 0.1, 0, np.array([1.0, 2.0, 3.0]), 0),
        R.GoalRun(1, 0.0, 0.0, 0, "optimal", "-", 0.1, 0, np.array([4.0, 1000.0]), 2),
    ]
    times, uncompiled = R.timing(runs)
    assert times.startswith("3.0 / ") and times.endswith(" / 1,000")
    assert uncompiled == "2 of 5"


def test_the_summary_gives_the_reversals_at_a_change_of_law_beside_all() -> None:
    runs = [
        R.GoalRun(0, 0.0, 0.0, 1000, "optimal", "-", 0.1, 30, np.ones(2), 0, law_changes=12),
        R.GoalRun(1, 1.0, 0.0, None, "optimal", "-", 0.1, 1970, np.ones(2), 0, law_changes=3),
    ]
    assert R.summary(runs) == ("1 of 2", "1.00 / 1.00", "2,000 (15)")
