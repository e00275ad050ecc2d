"""Reachable goals drawn at random: how often the default controller gets there, and why not.

For each bundled arm (Panda, UR5e, iiwa 14) a seeded draw of goal
configurations, each joint uniform within the middle 90 % of its end-stops;
the goal is the tool pose there, so every goal is reachable with every joint
within its limits. The default ``Lp2Controller`` (1 kHz, its default command
law) starts at rest on the home pose and runs ``STEPS`` steps toward the goal,
without acceleration limits and with each of ``LIMITS``. A goal is *reached*
when the tool ends within ``REACHED`` of it (position and orientation). For
every miss the page gives where it ended and why: the last step's binding limit, and
``sigma_min / sigma_max`` of the task Jacobian at the goal configuration (a goal
next to a singular configuration). Under acceleration limits it also counts
*reversals*: steps on which a joint's acceleration changes sign at more than
half its limit both times (chatter). Run it from the repository root with lpik
installed (``benchmarks/random_goals.py`` runs :func:`main`)::

    .venv/bin/python benchmarks/random_goals.py [--goals 30] [--qdd-max 10 2]

It writes the section "Reachable goals drawn at random" of ``docs/benchmarks.md``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lpik_bench.markdown import section_head, table, write_section

#: The page whose section :func:`main` writes.
OUT = Path(__file__).resolve().parents[2] / "docs" / "benchmarks.md"
HEADING = "## Reachable goals drawn at random"

DT = 1e-3
#: Steps per goal (10 s at 1 kHz).
STEPS = 10_000
#: Reached: the tool within this of the goal, position [m] and orientation [rad].
REACHED = (1e-5, 1e-4)
#: The share of each joint's range the goal configurations are drawn from (the middle).
MIDDLE = 0.9
#: A reversal: a joint's acceleration changes sign at more than this share of its limit.
REVERSAL_SHARE = 0.5
#: The acceleration limits measured [rad/s^2]: the quality suite's, and one of a heavy arm
#: (a hydraulic machine's boom, a large arm at a low setting), where a step that cannot turn
#: the motion it carries shows most.
LIMITS = (10.0, 2.0)


@dataclass
class GoalRun:
    """One goal's closed loop: where it ended and how it moved."""

    goal: int
    position_error: float
    orientation_error: float
    reached_at: int | None
    status: str
    binding: str
    goal_ratio: float
    reversals: int
    #: Each step's ``controller.step`` call [us].
    step_times: np.ndarray
    #: Steps not answered on the compiled path (``Result.path``: the numpy engine, HiGHS).
    uncompiled: int
    #: Of :attr:`reversals`, those on a step whose status differs from the step before's:
    #: a change of law (the exact step, the progress step ``off_direction``, the safe step).
    law_changes: int = 0

    @property
    def reached(self) -> bool:
        """Whether the tool ended within :data:`REACHED` of the goal."""
        return self.position_error <= REACHED[0] and self.orientation_error <= REACHED[1]


def goal_configurations(model, count: int, seed: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """``count`` goal configurations, each joint uniform in the middle of its range."""
    rng = np.random.default_rng(seed)
    low, high = np.asarray(model.q_min, float), np.asarray(model.q_max, float)
    margin = 0.5 * (1.0 - MIDDLE)
    return low + (high - low) * (margin + MIDDLE * rng.random((count, low.size)))


def errors(model, q: np.ndarray, target: np.ndarray) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """The tool's distance from ``target`` at ``q`` (the task's own pose difference):
    position [m], orientation [rad]."""
    d = model.difference(model.pose(q), target)
    return float(np.linalg.norm(d[:3])), float(np.linalg.norm(d[3:]))


def reverses(acceleration: np.ndarray, before: np.ndarray, threshold: float) -> bool:
    """Whether some joint's acceleration changed sign, above ``threshold`` both times."""
    big = (np.abs(acceleration) > threshold) & (np.abs(before) > threshold)
    return bool(np.any(big & (np.sign(acceleration) != np.sign(before))))


def run_goal(robot: str, index: int, goal: np.ndarray, qdd_max: float | None,
             steps: int = STEPS) -> GoalRun:  # fmt: skip
    """The default controller from rest on ``robot``'s home pose toward the pose at ``goal``
    for ``steps`` (at least 1) steps."""
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    model = load_robot(robot)
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd_max)
    target = model.pose(goal)
    singular = np.linalg.svd(model.jacobian(goal), compute_uv=False)
    q = home_configuration(robot).copy()
    prev = q.copy()
    acceleration = np.zeros(q.size)  # the last step's change of the joint step
    threshold = None if qdd_max is None else REVERSAL_SHARE * qdd_max * DT * DT  # per step
    reversals, reached_at, uncompiled, law_changes, status = 0, None, 0, 0, None
    step_times = np.empty(steps)
    for k in range(steps):
        start = time.perf_counter_ns()
        result = controller.step(q, target, prev)
        step_times[k] = (time.perf_counter_ns() - start) * 1e-3
        uncompiled += result.path != "compiled"
        change = (result.q - q) - (q - prev)
        if threshold is not None and reverses(change, acceleration, threshold):
            reversals += 1
            law_changes += result.status != status
        acceleration, prev, q, status = change, q, result.q, result.status
        position, orientation = errors(model, q, target)
        near = position <= REACHED[0] and orientation <= REACHED[1]
        reached_at = (k if reached_at is None else reached_at) if near else None
    return GoalRun(
        goal=index,
        position_error=position,
        orientation_error=orientation,
        reached_at=reached_at,
        status=result.status,
        binding="-" if result.binding is None else str(result.binding),
        goal_ratio=float(singular[-1] / singular[0]),
        reversals=reversals,
        step_times=step_times,
        uncompiled=uncompiled,
        law_changes=law_changes,
    )


def miss_text(run: GoalRun) -> str:
    """One miss, as the page lists it."""
    return (f"goal {run.goal}: {run.position_error * 1e3:.3g} mm, "
            f"{run.orientation_error * 1e3:.3g} mrad off, {run.binding} "
            f"(sigma ratio at the goal {run.goal_ratio:.1e})")  # fmt: skip


def summary(runs: list[GoalRun]) -> tuple[str, str, str]:
    """``(reached, time to reach median / max [s], reversals (at a change of law))``."""
    times = [r.reached_at * DT for r in runs if r.reached_at is not None and r.reached]
    reached = f"{sum(r.reached for r in runs)} of {len(runs)}"
    timing = f"{np.median(times):.2f} / {max(times):.2f}" if times else "-"
    changes = sum(r.law_changes for r in runs)
    return reached, timing, f"{sum(r.reversals for r in runs):,} ({changes:,})"


def timing(runs: list[GoalRun]) -> tuple[str, str]:
    """``(median / p99 / p99.9 / max [us], steps not compiled)`` of one arm and setting."""
    times = np.concatenate([r.step_times for r in runs])
    median, p99, p999 = np.percentile(times, [50, 99, 99.9])
    return (f"{median:.1f} / {p99:.0f} / {p999:.0f} / {times.max():,.0f}",
            f"{sum(r.uncompiled for r in runs):,} of {times.size:,}")  # fmt: skip


def setting(qdd_max: float | None) -> tuple[str, str]:
    """One setting's names: in the table's column, and in the timings and the misses."""
    if qdd_max is None:
        return "none", "without acceleration limits"
    return f"{qdd_max:g}", f"qdd_max={qdd_max:g}"


def section(rows: list[tuple[str, ...]], misses: list[str], goals: int, seed: int,
            limits: tuple[float, ...], command: str,
            timings: list[tuple[str, ...]] = ()) -> str:  # fmt: skip
    """The page's section: the setup, one row per arm and setting, then every miss.

    ``rows``: (arm, setting, reached, time to reach, reversals), the setting "none" or an
    acceleration limit of every joint [rad/s^2]; ``limits``: the limits measured.
    """
    measured = " and ".join(f"{q:g}" for q in limits)
    return "\n".join([
        *section_head(HEADING, "benchmarks/random_goals.py", command),
        f"- Each arm's default `Lp2Controller` at 1 kHz with its default command law, from rest "
        f"on the home pose, {STEPS * DT:g} s toward each of {goals} goals (seed {seed}): the "
        f"tool pose of a configuration drawn uniformly from the middle {MIDDLE:.0%} of every "
        f"joint's range, so that each goal is reachable within the end-stops; without "
        f"acceleration limits, and with `qdd_max` {measured} rad/s^2 on every joint. *Reached*: "
        f"within {REACHED[0] * 1e3:g} mm and {REACHED[1] * 1e3:g} mrad at the end. *Reversals* "
        f"(with acceleration limits): steps on which a joint's acceleration changes sign at more "
        f"than {REVERSAL_SHARE:.0%} of its limit both times; in brackets those on a step whose "
        f"status differs from the step before's, a change of law (the exact step, the progress "
        f"step `off_direction`, the safe step `infeasible`).", "",
        *table("| arm | acceleration limits [rad/s^2] | reached | time to reach, median / max "
               "[s] | reversals |", "|---|---:|---:|---:|---:|", rows),
        "", "Every step's `controller.step` call timed (`time.perf_counter_ns`, on this shared "
        "machine: the max is the noisiest), and the steps the compiled path did not answer (its "
        "`Result.path`: the numpy engine's stages, HiGHS):", "",
        "| arm | setting | step time, median / p99 / p99.9 / max [us] | steps not compiled |",
        "|---|---|---:|---:|",
        *(f"| {' | '.join(row)} |" for row in timings),
        "", "Misses (the last step's binding limit, and how near the goal configuration is to a "
        "singular one):", "",
        *(misses or ["- none"]),
        "", "",
    ])  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goals", type=int, default=30, help="goals per arm")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--qdd-max",
        type=float,
        nargs="+",
        default=list(LIMITS),
        help="acceleration limits of every joint to measure [rad/s^2]",
    )
    parser.add_argument("--robots", nargs="+", default=["panda", "ur5e", "iiwa14"])
    parser.add_argument("--out", type=Path, default=OUT, help="the page whose section is written")
    given = sys.argv[1:] if argv is None else argv
    args = parser.parse_args(given)
    os.environ.setdefault("LPIK_COMPILE", "now")
    from lpik.robots.registry import load_robot

    rows, misses, timings = [], [], []
    for robot in args.robots:
        goals = goal_configurations(load_robot(robot), args.goals, args.seed)
        for qdd in (None, *args.qdd_max):
            runs = [run_goal(robot, i, g, qdd) for i, g in enumerate(goals)]
            reached, reach_time, reversals = summary(runs)
            column, name = setting(qdd)
            rows.append((robot, column, reached, reach_time, "-" if qdd is None else reversals))
            timings.append((robot, name, *timing(runs)))
            misses += [f"- {robot}, {name}: {miss_text(r)}" for r in runs if not r.reached]
            print(rows[-1], flush=True)
    command = " ".join(["python benchmarks/random_goals.py", *given])
    text = section(rows, misses, args.goals, args.seed, tuple(args.qdd_max), command, timings)
    print(text)
    write_section(args.out, HEADING, text)
    return 0
