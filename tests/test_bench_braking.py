"""benchmarks/braking.py: one move's run, a row over the moves, and the page's section.

No settle time or overshoot is asserted here beyond one easy move: those are the
benchmark's findings (docs/benchmarks.md); tests/test_braking.py holds the moves that
once passed their goal.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.robots.registry import home_configuration, load_robot  # noqa: E402
from lpik_bench import braking as B  # noqa: E402


def test_every_set_of_limits_gives_each_joint_one_positive_limit() -> None:
    for name, limits in B.LIMITS.items():
        for n in (6, 7):
            qdd = limits(n)
            assert qdd.shape == (n,) and np.all(qdd > 0), name


def test_a_short_move_settles_without_overshoot_within_the_limits() -> None:
    model, q0 = load_robot("panda", task="pose"), home_configuration("panda")
    qdd = B.LIMITS["10 on every joint"](q0.size)
    make = B.contenders("panda", qdd)["lpik (default)"]
    run = B.run(make(), model, q0, B.targets(model, q0)["orientation held"][0], qdd)
    assert run["settle"] is not None and run["settle"] < 1e3 * B.SECONDS
    assert run["overshoot"] < 1e-6 and run["unanswered"] == 0
    assert run["acceleration"] <= 1.0 + 1e-9


def test_a_step_that_fails_brakes_the_arm_within_its_limits_and_is_counted() -> None:
    model, q0 = load_robot("panda", task="pose"), home_configuration("panda")
    qdd = B.LIMITS["2 on every joint"](q0.size)

    def failing(q, prev, target):  # type: ignore[no-untyped-def]
        return None, False

    goal = B.targets(model, q0)["orientation held"][0]
    run = B.run(failing, model, q0, goal, qdd)
    assert run["unanswered"] == int(round(B.SECONDS / B.DT))
    assert run["settle"] is None and run["acceleration"] == 0.0
    # moving, then failing from step 20: the arm brakes at its limits, it is not held
    speed = np.linspace(0.1, 0.4, q0.size) * B.DT  # a step per period [rad]
    steps = []

    def fails_later(q, prev, target):  # type: ignore[no-untyped-def]
        steps.append(q - prev)
        return (q + speed, True) if len(steps) < 20 else (None, False)

    B.run(fails_later, model, q0, goal, qdd)
    change = np.diff(np.asarray(steps[19:]), axis=0)  # from the first failed step on
    assert np.all(np.abs(change) <= qdd * B.DT**2 * (1 + 1e-9))  # no stop at once
    assert np.allclose(steps[-1], 0.0)  # and it comes to rest


def test_a_row_reads_every_move_and_the_section_lists_every_row() -> None:
    runs = [
        {"settle": 500.0, "overshoot": 0.0, "unanswered": 0, "acceleration": 1.0},
        {"settle": None, "overshoot": 2.5, "unanswered": 12, "acceleration": 0.5},
    ]
    row = B._row("panda", "2 on every joint", "turning", "lpik (default)", runs)
    assert row == ["panda", "2 on every joint", "turning", "lpik (default)", "1 of 2", "500",
                   "2.5", "12", "1"]  # fmt: skip
    assert B._row("ur5e", "x", "z", "y", runs[1:])[5] == "never"
    text = B.section([row], "python benchmarks/braking.py")
    assert text.startswith(B.HEADING)
    assert (
        "| panda | 2 on every joint | turning | lpik (default) | 1 of 2 | 500 | 2.5 | 12 | 1 |"
        in text
    )


@pytest.mark.parametrize("robot", ["panda", "ur5e", "iiwa14"])
def test_the_moves_are_the_held_translations_and_turns_to_nearby_configurations(robot: str) -> None:
    model, q0 = load_robot(robot, task="pose"), home_configuration(robot)
    goals = B.targets(model, q0)
    home = model.pose(q0)
    assert len(goals["orientation held"]) == len(B.MOVES) and len(goals["turning"]) == B.TURNS
    for move, target in zip(B.MOVES, goals["orientation held"]):
        np.testing.assert_allclose(target[:3, 3] - home[:3, 3], move, atol=1e-15)
        np.testing.assert_array_equal(target[:3, :3], home[:3, :3])
    turns = [np.linalg.norm(model.difference(home, target)[3:]) for target in goals["turning"]]
    assert min(turns) > 0.05  # every one turns the tool
    again = B.targets(model, q0)["turning"]  # seeded: the same moves every run
    np.testing.assert_array_equal(np.asarray(again), np.asarray(goals["turning"]))
