"""Encoder noise fed back under acceleration limits: a loop closed on measured joints.

Each bundled arm (Panda, UR5e, iiwa 14) starts at rest on its home pose with
the goal 5 cm along x (the getting-started example), and again with the quality
suite's circle (a moving target, :data:`MOVES`); the arm follows each
command exactly, and each *reading* is that position plus Gaussian noise of
``sigma`` rad per joint. The loop feeds the last two readings back as ``q0`` and
``q_prev``, as a loop on a real arm's encoders does, with acceleration limits
``qdd_max`` on. Measured over ``--seconds`` per run, for each noise level and
seed: the tool's distance from the goal at the end and its largest after the
first second [mm], the median over the steps of the command stream's largest
joint acceleration [rad/s^2] (the commands sent to the drives), and lpik's
states taken at their plausible motion (:mod:`lpik.control.commanded`).
Rows: lpik's default controller; the same with that check off
(``controller.motion = None``: each state's implied motion continued as it
is); and Drake's ``DoDifferentialInverseKinematics`` with the same
acceleration limits (the quality suite's "drake +acc", where pydrake is
installed), fed the same readings. Run it from the repository root
(``benchmarks/measured_loops.py`` runs :func:`main`)::

    .venv/bin/python benchmarks/measured_loops.py [--sigma 0 1e-5 ...]

It writes the section "Encoder noise fed back" of ``docs/benchmarks.md``.
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
HEADING = "## Encoder noise fed back"
DT, QDD_MAX, GOAL_STEP = 1e-3, 10.0, 0.05
#: Noise per joint and reading [rad]: none, a 19-bit encoder's step, a 16-bit one's, a
#: 15-bit one's (2 pi / 2^b).
SIGMAS = (0.0, 1e-5, 1e-4, 2e-4)

#: One step of a contender: ``(q0, q_prev, target) -> q`` (None: the step failed).
StepFn = Callable[[np.ndarray, np.ndarray, np.ndarray], Any]


def goal_targets(model: Any, q0: np.ndarray, steps: int) -> np.ndarray:
    """The point-to-point move: the home pose moved :data:`GOAL_STEP` along x, every step."""
    target = model.pose(q0)
    target[0, 3] += GOAL_STEP
    return np.repeat(target[None], steps, axis=0)


def circle_targets(model: Any, q0: np.ndarray, steps: int) -> np.ndarray:
    """The quality suite's scenario 1 (a 10 cm circle through the home pose at 0.157 m/s,
    ramped up over 0.5 s, orientation held), its first ``steps`` targets."""
    from lpik_bench.quality_scenarios import circle

    targets = circle(model, DT, None).legs[0].targets
    return targets[: min(steps, len(targets))]


#: The moves, by the name of their table: the targets of each step.
MOVES: dict[str, Callable[[Any, np.ndarray, int], np.ndarray]] = {
    "point": goal_targets,
    "circle": circle_targets,
}


def run(step: StepFn, model: Any, targets: np.ndarray, q0: np.ndarray, sigma: float,
        seed: int) -> dict[str, float]:  # fmt: skip
    """One loop on noisy readings: the tool's errors and the command stream's acceleration.

    Where a step fails, the arm brakes from its last commanded motion within the
    acceleration limits (:func:`lpik_bench.quality.braking_step`, as the quality
    suite takes a failed step of a library that holds them); held where it is read
    to be, it would stop at once.
    """
    from lpik_bench.quality import braking_step

    rng = np.random.default_rng(seed)
    q, reading_before = q0.copy(), q0.copy()
    steps = len(targets)
    commands, error, failed = [q0.copy(), q0.copy()], np.empty(steps), 0
    for k, target in enumerate(targets):
        reading = q + rng.normal(0.0, sigma, q.size)
        answer = step(reading, reading_before, target)
        if answer is None or not np.all(np.isfinite(answer)):
            failed, answer = failed + 1, q + braking_step(q - commands[-2], QDD_MAX * DT * DT)
        reading_before, q = reading, np.asarray(answer, dtype=float)
        commands.append(q.copy())
        error[k] = np.linalg.norm(model.pose(q)[:3, 3] - target[:3, 3])
    c = np.asarray(commands)
    acceleration = np.abs(c[2:] - 2 * c[1:-1] + c[:-2]).max(axis=1) / DT**2
    late = error[int(1.0 / DT) :] if steps > int(1.0 / DT) else error
    return {"end": 1e3 * error[-1], "rms": 1e3 * float(np.sqrt(np.mean(error**2))),
            "late_max": 1e3 * late.max(), "acc": float(np.median(acceleration)),
            "failed": failed}  # fmt: skip


def contenders(robot: str) -> dict[str, Callable[[], tuple[StepFn, Any]]]:
    """Each row's factory: a fresh ``(step, controller or None)`` per run."""
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import load_robot

    model = load_robot(robot, task="pose")

    def lpik(check: bool) -> Callable[[], tuple[StepFn, Any]]:
        def make() -> tuple[StepFn, Any]:
            controller = Lp2Controller(model, dt=DT, qdd_max=QDD_MAX)
            if not check:
                controller.motion = None
            return (lambda q, prev, target: controller.step(q, target, prev).q), controller

        return make

    rows = {"lpik (default)": lpik(True), "lpik, check off": lpik(False)}
    try:
        from lpik_bench.quality import peer_contenders

        drake = next(c for c in peer_contenders(("drake",), robot)[0] if c.name == "drake +acc")
    except (ImportError, StopIteration):
        return rows

    def peer() -> tuple[StepFn, Any]:
        def step(q: np.ndarray, prev: np.ndarray, target: np.ndarray) -> Any:
            dq = drake.step(q, prev, target)[0]
            return None if dq is None else q + dq

        return step, None

    rows["drake +acc"] = peer
    return rows


def measure(robots: list[str], sigmas: list[float], seeds: int, steps: int,
            move: str = "point") -> list[list[str]]:  # fmt: skip
    """The rows of ``move``'s table: per arm, noise level and contender, the worst over the
    seeds (the point-to-point move: the error at the end; the circle: its RMS)."""
    from lpik.robots.registry import home_configuration, load_robot

    rows = []
    for robot in robots:
        model, q0 = load_robot(robot, task="pose"), home_configuration(robot)
        targets = MOVES[move](model, q0, steps)
        for sigma in sigmas:
            for name, make in contenders(robot).items():
                runs, corrected = [], 0
                for seed in range(seeds):
                    step, controller = make()
                    runs.append(run(step, model, targets, q0, sigma, seed))
                    motion = getattr(controller, "motion", None)
                    corrected += 0 if motion is None else motion.corrected
                worst = {k: max(r[k] for r in runs) for k in runs[0]}
                error = worst["end"] if move == "point" else worst["rms"]
                rows.append([robot, f"{sigma:g}", name, f"{error:.3g}",
                             f"{worst['late_max']:.3g}", f"{worst['acc']:.3g}",
                             f"{worst['failed']:,}", "–" if controller is None or
                             controller.motion is None else f"{corrected:,}"])  # fmt: skip
                print(move, rows[-1], flush=True)
    return rows


def section(tables: dict[str, list[list[str]]], seeds: int, steps: int, command: str) -> str:
    """The page's section: the setup, then per move one row per arm, noise level and
    contender."""
    return "\n".join([
        *section_head(HEADING, "benchmarks/measured_loops.py", command),
        f"- Each arm from rest on its home pose, `qdd_max={QDD_MAX:g}` rad/s^2, 1 kHz, "
        f"{steps * DT:g} s; the arm follows each command exactly, and each reading is that "
        "position plus Gaussian noise of sigma rad per joint. The last two readings are fed "
        f"back as `q0` and `q_prev`. Worst of {seeds} seeds. Two moves: the goal "
        f"{GOAL_STEP * 1e3:g} mm along x (*error*: the tool's distance from the goal [mm] "
        "at the end), and the quality suite's scenario 1, a 10 cm circle at 0.157 m/s "
        "(*error*: the RMS of the tool's distance from its target [mm]; lpik feeds the "
        "target's motion forward under acceleration limits, so after each step its tool is "
        "where the target will be a period later, 0.157 mm ahead at the circle's speed: the "
        "error of its noise-free rows); for both, the largest distance after the first "
        "second. *Command acceleration*: the median over "
        "the steps of the largest joint acceleration of the commands [rad/s^2]: the noise of "
        "the readings the commands are built on (a loop fed its own commands, as "
        "`lpik simulate` is, has none). *Corrected*: states whose implied step was taken at "
        "the nearest one the drives could have made (`lpik.control.commanded`). *Failed "
        "steps*: there the arm brakes from its last command at the acceleration limits, as "
        "the quality suite takes a failed step (held, it would stop at once).", "",
        *(line for move, rows in tables.items() for line in _table(move, rows)),
    ])  # fmt: skip


def _table(move: str, rows: list[list[str]]) -> list[str]:
    error = "error at the end" if move == "point" else "error RMS"
    title = (f"The goal {GOAL_STEP * 1e3:g} mm along x:" if move == "point"
             else "The circle (a moving target):")  # fmt: skip
    return [
        title, "",
        *table(f"| arm | noise [rad] | controller | {error} [mm] | largest after 1 s [mm] "
               "| command acceleration [rad/s^2] | failed steps | corrected states |",
               "|---|---:|---|---:|---:|---:|---:|---:|", rows),
        "", "",
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sigma", type=float, nargs="+", default=list(SIGMAS), help="rad")
    parser.add_argument("--robots", nargs="+", default=["panda", "ur5e", "iiwa14"])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--out", type=Path, default=OUT, help="the page whose section is written")
    given = sys.argv[1:] if argv is None else argv
    args = parser.parse_args(given)
    os.environ.setdefault("LPIK_COMPILE", "now")
    steps = max(1, int(round(args.seconds / DT)))
    tables = {move: measure(args.robots, args.sigma, args.seeds, steps, move) for move in MOVES}
    command = " ".join(["python benchmarks/measured_loops.py", *given])
    text = section(tables, args.seeds, steps, command)
    print(text)
    write_section(args.out, HEADING, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
