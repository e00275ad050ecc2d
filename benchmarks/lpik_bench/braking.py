"""Point-to-point moves under other acceleration limits: does the arm stop on its goal?

The quality suite's point-to-point scenarios (7 and 8) give every joint the same
limit, 10 rad/s^2. A real arm's joints have limits of their own, and a heavy
machine's are low: there the joints' share of keeping the tool on its line, and
of turning a motion that drifted off it, matters most. Each bundled arm starts
at rest on its home pose and moves its tool by each of :data:`MOVES` (the
orientation held), and to the pose of each of :data:`TURNS` nearby configurations
(turning the tool as it goes: the moves on which the command law's stopping
distance, planned along the least joint motion, misses most), for :data:`SECONDS`,
under each set of :data:`LIMITS`.
Rows: lpik's default controller; the same with its command clamp off (the
peers' command, ``V = error / dt``); and Drake's
``DoDifferentialInverseKinematics`` with the same per-joint acceleration
limits (where pydrake is installed), its joint velocities from
``(q - q_prev) / dt``. Where a step fails, the arm brakes within its limits
(:func:`lpik_bench.quality.braking_step`, as the quality suite takes a failed
step of a library that holds acceleration limits): held where it is, it
would stop at once, far beyond the limits (Drake's failures come as the
arm arrives, moving: up to some 700 times the UR5e's 2 rad/s^2), and settle
early by it. Each loop is fed its own
commands. Per arm, limits and controller: the moves settled (within the quality
suite's :data:`~lpik_bench.quality_metrics.SETTLE_TOL`), the slowest settle
time, the largest overshoot (:func:`~lpik_bench.quality_metrics.settle_and_overshoot`),
the steps not answered (lpik's safe steps, Drake's failed steps) and the
largest joint acceleration of the commands against its limit. Run it from the
repository root (``benchmarks/braking.py`` runs :func:`main`)::

    .venv/bin/python benchmarks/braking.py

It writes the section "Point to point under other acceleration limits" of
``docs/benchmarks.md``.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from lpik_bench.markdown import section_head, table, write_section

#: The page whose section :func:`main` writes.
OUT = Path(__file__).resolve().parents[2] / "docs" / "benchmarks.md"
HEADING = "## Point to point under other acceleration limits"
DT, SECONDS = 1e-3, 3.0
#: The moves of the tool from the home pose [m], orientation held: each within reach of
#: every bundled arm from its home pose (each settles under lpik's default controller).
MOVES = ((0.05, 0.0, 0.0), (0.0, 0.2, -0.1), (-0.15, -0.1, 0.1), (0.0, -0.25, 0.0),
         (0.0, 0.15, 0.1), (-0.1, 0.1, -0.15), (0.1, 0.05, -0.1), (-0.15, 0.0, -0.1))  # fmt: skip
#: The turning moves: the tool poses of this many configurations near home, each joint
#: moved from home by a seeded draw within +-TURN_SPAN of its range (at most 2 rad) and
#: kept 0.05 rad inside its end-stops.
TURNS, TURN_SPAN, TURN_SEED = 8, 0.35, 7
#: The acceleration limits [rad/s^2], by name: each joint's, for an arm of n joints.
LIMITS: dict[str, Callable[[int], np.ndarray]] = {
    "10 on every joint": lambda n: np.full(n, 10.0),
    "2 on every joint": lambda n: np.full(n, 2.0),
    "1 (base) to 20 (wrist)": lambda n: np.linspace(1.0, 20.0, n),
    "20 (base) to 1 (wrist)": lambda n: np.linspace(20.0, 1.0, n),
}
#: lpik's command clamp off, as the quality suite's variants run [m/s, rad/s].
UNCLAMPED = 1e6

#: One step of a contender: ``(q0, q_prev, target) -> (q or None, answered)``.
StepFn = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[Any, bool]]


def contenders(robot: str, qdd_max: np.ndarray) -> dict[str, Callable[[], StepFn]]:
    """Each row's factory: a fresh step per move."""
    from lpik.control.controller import Lp2Controller
    from lpik.result import MOVING
    from lpik.robots.registry import load_robot

    model = load_robot(robot, task="pose")

    def lpik(**kwargs: float) -> Callable[[], StepFn]:
        def make() -> StepFn:
            controller = Lp2Controller(model, dt=DT, qdd_max=qdd_max, **kwargs)

            def step(q: np.ndarray, prev: np.ndarray, target: np.ndarray) -> tuple[Any, bool]:
                result = controller.step(q, target, prev)
                return result.q, result.status in MOVING

            return step

        return make

    rows = {"lpik (default)": lpik(), "lpik, clamp off": lpik(v_max=UNCLAMPED, w_max=UNCLAMPED)}
    drake = _drake(robot, qdd_max)
    if drake is not None:
        rows["drake +acc"] = drake
    return rows


def _drake(robot: str, qdd_max: np.ndarray) -> Callable[[], StepFn] | None:
    """Drake's step with ``qdd_max`` per joint, or None where pydrake is not installed."""
    try:
        from lpik_bench.peers import drake_peer
        from lpik_bench.workload import make_workload

        peer = drake_peer(make_workload(robot, trajectories=1, steps=1), qdd_max=qdd_max)[0]
    except ImportError:
        return None

    def make() -> StepFn:
        def step(q: np.ndarray, prev: np.ndarray, target: np.ndarray) -> tuple[Any, bool]:
            dq = peer.step(q, target, prev)
            answered = bool(np.all(np.isfinite(dq)))
            return (q + dq if answered else None), answered

        return step

    return make


def targets(model: Any, q0: np.ndarray) -> dict[str, list[np.ndarray]]:
    """The goal poses of each set of moves from ``q0``: :data:`MOVES` and :data:`TURNS`."""
    held = []
    for move in MOVES:
        target = model.pose(q0)
        target[:3, 3] += move
        held.append(target)
    rng, span = np.random.default_rng(TURN_SEED), np.minimum(model.q_max - model.q_min, 2.0)
    turns = [model.pose(np.clip(q0 + rng.uniform(-TURN_SPAN, TURN_SPAN, q0.size) * span,
                                model.q_min + 0.05, model.q_max - 0.05))
             for _ in range(TURNS)]  # fmt: skip
    return {"orientation held": held, "turning": turns}


def run(step: StepFn, model: Any, q0: np.ndarray, target: np.ndarray,
        qdd_max: np.ndarray) -> dict[str, Any]:  # fmt: skip
    """One move from rest at ``q0`` to ``target``: settle time [ms], overshoot [mm],
    unanswered steps, and the largest joint acceleration of the commands over its limit."""
    from lpik_bench.quality import braking_step
    from lpik_bench.quality_metrics import errors, settle_and_overshoot

    steps = int(round(SECONDS / DT))
    q, prev, poses, unanswered, worst = q0.copy(), q0.copy(), [], 0, 0.0
    for _ in range(steps):
        answer, answered = step(q, prev, target)
        unanswered += not answered
        if answer is None:  # the arm brakes within its limits, as the quality suite takes it
            answer = q + braking_step(q - prev, qdd_max * DT * DT)
        else:
            worst = max(worst, float(np.max(np.abs(answer - 2 * q + prev) / DT**2 / qdd_max)))
        prev, q = q, np.asarray(answer, dtype=np.float64)
        poses.append(model.pose(q))
    position, orientation = errors(model, np.asarray(poses), np.repeat(target[None], steps, 0))
    settle_ms, overshoot = settle_and_overshoot(position, orientation, DT)
    return {"settle": settle_ms, "overshoot": overshoot, "unanswered": unanswered,
            "acceleration": worst}  # fmt: skip


def measure(robots: list[str]) -> list[list[str]]:
    """The table's rows: per arm, set of limits and controller, over the moves."""
    from lpik.robots.registry import home_configuration, load_robot

    rows = []
    for robot in robots:
        model, q0 = load_robot(robot, task="pose"), home_configuration(robot)
        goals = targets(model, q0)
        for name, limits in LIMITS.items():
            qdd_max = limits(q0.size)
            for label, make in contenders(robot, qdd_max).items():
                for moves, poses in goals.items():
                    runs = [run(make(), model, q0, target, qdd_max) for target in poses]
                    rows.append(_row(robot, name, moves, label, runs))
                    print(rows[-1], flush=True)
    return rows


def _row(robot: str, limits: str, moves: str, label: str, runs: list[dict[str, Any]]) -> list[str]:
    """One row of the table from the runs of the moves."""
    settled = [r["settle"] for r in runs if r["settle"] is not None]
    slowest = f"{max(settled):,.0f}" if settled else "never"
    return [robot, limits, moves, label, f"{len(settled)} of {len(runs)}", slowest,
            f"{max(r['overshoot'] for r in runs):.3g}",
            f"{sum(r['unanswered'] for r in runs):,}",
            f"{max(r['acceleration'] for r in runs):.3g}"]  # fmt: skip


def section(rows: list[list[str]], command: str) -> str:
    """The page's section: the setup, then one row per arm, set of limits and controller."""
    moves = ", ".join("(" + ", ".join(f"{1e3 * v:g}" for v in m) + ")" for m in MOVES)
    return "\n".join([
        *section_head(HEADING, "benchmarks/braking.py", command),
        f"- Each arm from rest on its home pose, 1 kHz, {SECONDS:g} s per move; the tool "
        f"moved by each of {moves} mm, its orientation held (*orientation held*), and to the "
        f"tool poses of {TURNS} configurations near home (*turning*: each joint moved from "
        f"home by a draw within +-{TURN_SPAN:g} of its range, at most 2 rad, seed "
        f"{TURN_SEED}); each loop fed its own commands, `q_prev` passed. *Settled*: the "
        "moves whose error stays within 0.01 mm and 0.01 mrad, and the slowest settle time "
        "of those [ms]; "
        "*overshoot*: the largest growth of the position error after its running minimum "
        "[mm] (the quality suite's); *unanswered*: lpik's safe steps, Drake's failed steps "
        "(there the arm brakes at its limits, as the quality suite takes a failed step; "
        "held, it would stop at once, far beyond them); *acceleration / limit*: the "
        "largest joint acceleration of the steps answered over that joint's limit. lpik "
        "with its clamp off gets the command the peers get (`V = error / dt`).", "",
        *table("| arm | acceleration limits [rad/s^2] | moves | controller | settled "
               "| slowest [ms] | overshoot [mm] | unanswered steps | acceleration / limit |",
               "|---|---|---|---|---:|---:|---:|---:|---:|", rows),
        "", "",
    ])  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["panda", "ur5e", "iiwa14"])
    parser.add_argument("--out", type=Path, default=OUT, help="the page whose section is written")
    given = sys.argv[1:] if argv is None else argv
    args = parser.parse_args(given)
    os.environ.setdefault("LPIK_COMPILE", "now")
    rows = measure(args.robots)
    text = section(rows, " ".join(["python benchmarks/braking.py", *given]))
    print(text)
    write_section(args.out, HEADING, text)
    return 0
