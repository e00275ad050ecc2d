"""Targets driven beyond reach and back under acceleration limits, on every 3-D arm.

For each bundled arm (Panda, UR5e, iiwa 14) the default controller
(``Lp2Controller``, 1 kHz, the command unclamped as the quality suite's peers get
it) starts at rest on its home pose; the target moves at 1 m/s ``far`` metres
along one of ten directions (the six axes and four diagonals), is held 0.3 s,
comes back at the same speed and is held 2.5 s on the home pose. An excursion
is *recovered* when the tool ends within 0.01 mm of home. Run it from the
repository root with lpik installed (``benchmarks/excursions.py`` runs :func:`main`)::

    .venv/bin/python benchmarks/excursions.py [--qdd-max 10] [--far 0.3 0.5 ...]

It runs every excursion with and without acceleration limits and writes the
section "Excursions beyond reach under acceleration limits" of
``docs/benchmarks.md`` (recovered excursions per arm, where each miss ended,
the command and the machine). Which excursion misses is chaotic, so the section
also gives how often one excursion comes home from states a little off its own
(:func:`perturbed_returns`): the share a single run cannot show.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from lpik_bench.markdown import section_head, table, write_section
from lpik_bench.quality_reach import moved

#: The page whose section :func:`main` writes.
OUT = Path(__file__).resolve().parents[2] / "docs" / "benchmarks.md"

DT = 1e-3
#: The six axes and four diagonals the target is driven along.
DIRECTIONS = ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1),
              (1, 1, 0), (1, 0, 1), (-1, 1, 1), (1, -1, -1))  # fmt: skip
#: How far beyond the home pose the target goes [m]. Which excursion misses is chaotic
#: (a change of one rounding in a decision moves a miss to another direction), so the
#: measure is many of them: seven distances, 70 excursions per arm.
FAR = (0.3, 0.5, 0.7, 0.9, 1.0, 1.1, 1.3)
#: Speed [m/s], hold far out [steps], hold at home [steps]; recovered within [m].
SPEED, HOLD, SETTLE, RECOVERED = 1.0, 300, 2500, 1e-5
#: Returns from perturbed states (:func:`perturbed_returns`): the excursion (the one
#: tests/test_fading_motion.py runs on the Panda), the spreads of the perturbation of every
#: joint [rad], how many draws per spread, and the seed.
PERTURBED = {"direction": (-1, 1, 1), "far": 1.0, "spreads": (0.003, 0.01), "draws": 40,
             "seed": 1}  # fmt: skip
#: Steps the home pose is held on after a perturbed excursion's end (10 s).
LATER = 10_000


def targets(start: np.ndarray, direction: np.ndarray, far: float) -> Iterator[np.ndarray]:
    """The excursion's target poses from the pose ``start``, one per step; ``direction``: unit."""
    ramp = int(round(far / SPEED / DT))
    share = [*np.linspace(0.0, 1.0, ramp), *[1.0] * HOLD, *np.linspace(1.0, 0.0, ramp),
             *[0.0] * SETTLE]  # fmt: skip
    for s in share:
        yield moved(start, s * far * direction)


def _setup(robot: str, direction: tuple, far: float, qdd_max: float | None):  # type: ignore[no-untyped-def]
    """The arm, its home configuration and pose, its controller and the excursion's poses."""
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    model, q0 = load_robot(robot), home_configuration(robot)
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd_max, v_max=1e6, w_max=1e6)
    unit = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    home = model.pose(q0)
    return model, q0, home, controller, list(targets(home, unit, far))


def _run_on(model, controller, home, poses, q, prev) -> tuple[float, float]:  # type: ignore[no-untyped-def]
    """Step from ``(q, prev)`` through ``poses``: the tool's distance from ``home`` [m] then,
    and, where that is a miss, once the home pose is held :data:`LATER` steps more (a return
    still on its way is slow; one still off then stands in a local minimum)."""

    def from_home(q: np.ndarray) -> float:
        return float(np.linalg.norm(model.pose(q)[:3, 3] - home[:3, 3]))

    for target in poses:
        prev, q = q, controller.step(q, target, prev).q
    off = after = from_home(q)
    if off > RECOVERED:
        for _ in range(LATER):
            prev, q = q, controller.step(q, home, prev).q
        after = from_home(q)
    return off, after


def excursion(
    robot: str, direction: tuple, far: float, qdd_max: float | None
) -> tuple[float, float]:
    """The tool's distance from home after the excursion [m], and :data:`LATER` steps on."""
    model, q0, home, controller, poses = _setup(robot, direction, far, qdd_max)
    return _run_on(model, controller, home, poses, q0.copy(), q0.copy())


def perturbed_returns(
    robot: str, qdd_max: float, spread: float, draws: int, seed: int
) -> tuple[int, int]:
    """How many of ``draws`` runs of :data:`PERTURBED`'s excursion come home from perturbed states.

    The excursion runs to the end of its way out; there every joint of the state (``q0``
    and ``q_prev`` alike: the same velocity) is moved by a normal draw of standard
    deviation ``spread`` [rad] (kept within the end-stops), the controller forgets its
    memory (``reset``), and the excursion goes on to its end. Returns how many are home at
    its end, and how many :data:`LATER` steps on (:func:`_run_on`).
    """
    model, q0, home, controller, poses = _setup(
        robot, PERTURBED["direction"], PERTURBED["far"], qdd_max
    )
    out = int(round(PERTURBED["far"] / SPEED / DT))  # the end of the way out
    q, prev = q0.copy(), q0.copy()
    for target in poses[:out]:
        prev, q = q, controller.step(q, target, prev).q
    rng, at_end, later = np.random.default_rng(seed), 0, 0
    for _ in range(draws):
        moved_q = np.clip(q + rng.normal(size=q.size) * spread, model.q_min, model.q_max)
        controller.reset()
        off, after = _run_on(model, controller, home, poses[out:], moved_q, moved_q - (q - prev))
        at_end, later = at_end + (off <= RECOVERED), later + (after <= RECOVERED)
    return at_end, later


HEADING = "## Excursions beyond reach under acceleration limits"


def recovered(robot: str, far: tuple[float, ...], qdd_max: float | None) -> tuple[int, list[str]]:
    """How many of ``robot``'s excursions come back, and where each miss ended."""
    misses = []
    for distance in far:
        for direction in DIRECTIONS:
            off, after = excursion(robot, direction, distance, qdd_max)
            if off > RECOVERED:
                how = "home" if after <= RECOVERED else f"{after * 1e3:.1f} mm off"
                how += f" {LATER * DT:g} s later"
                misses.append(f"{distance:g} m along {direction}: {off * 1e3:.1f} mm off ({how})")
    return len(far) * len(DIRECTIONS) - len(misses), misses


def _listed(words: list[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def section(
    rows: list[tuple[str, ...]], far: list[float], qdd: float, command: str,
    perturbed: list[tuple[str, ...]],
) -> str:  # fmt: skip
    """The section: the setup, recovered excursions per arm, returns from perturbed states."""
    spreads = PERTURBED["spreads"]
    return "\n".join([
        *section_head(HEADING, "benchmarks/excursions.py", command),
        f"- Each arm's default `Lp2Controller` at 1 kHz, the command unclamped: the target goes "
        f"{_listed([f'{d:g}' for d in far])} m out from the home pose along ten directions "
        f"(six axes, four diagonals) at {SPEED:g} "
        f"m/s, is held {HOLD * DT:g} s, comes back and is held {SETTLE * DT:g} s; *recovered*: "
        f"the tool within {RECOVERED * 1e3:g} mm of home at the end. With acceleration limits "
        f"`qdd_max={qdd:g}` rad/s^2, and without them. Each miss is run again with the home "
        f"pose held {LATER * DT:g} s more: one still off then stands in a local minimum "
        "within the end-stops that no local step leaves, one home then came back slowly.", "",
        *table("| arm | without acceleration limits | with them | misses with them |",
               "|---|---:|---:|---|", rows),
        "",
        f"Which excursion misses is chaotic. The excursion {PERTURBED['far']:g} m along "
        f"{PERTURBED['direction']} with `qdd_max={qdd:g}`, run to the end of its way out, its "
        f"state then moved by a normal draw on every joint ({PERTURBED['draws']} draws of each "
        f"spread, seeds {PERTURBED['seed']} and on; the joint velocities kept), and run on to its "
        f"end: how many of the draws are home at its end, and {LATER * DT:g} s later (a draw "
        "home only then came back slowly; one not home then stands in a local minimum).", "",
        *table("| arm | " + " | ".join(f"spread {s:g} rad: at the end / later" for s in spreads)
               + " |", "|---|" + "---:|" * len(spreads), perturbed),
        "", "",
    ])  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qdd-max", type=float, default=10.0, help="rad/s^2")
    parser.add_argument("--far", type=float, nargs="+", default=list(FAR), help="metres")
    parser.add_argument("--robots", nargs="+", default=["panda", "ur5e", "iiwa14"])
    parser.add_argument("--out", type=Path, default=OUT, help="the page whose section is written")
    given = sys.argv[1:] if argv is None else argv
    args = parser.parse_args(given)
    os.environ.setdefault("LPIK_COMPILE", "now")
    rows, perturbed = [], []
    for robot in args.robots:
        free, _ = recovered(robot, tuple(args.far), None)
        held, misses = recovered(robot, tuple(args.far), args.qdd_max)
        runs = len(args.far) * len(DIRECTIONS)
        rows.append((robot, f"{free} of {runs}", f"{held} of {runs}", "; ".join(misses) or "none"))
        print(rows[-1], flush=True)
        draws, seed = PERTURBED["draws"], PERTURBED["seed"]
        perturbed.append((robot, *(  # a seed of its own for each spread: independent draws
            "{} / {} of {}".format(*perturbed_returns(robot, args.qdd_max, s, draws, seed + k),
                                   draws)
            for k, s in enumerate(PERTURBED["spreads"])
        )))  # fmt: skip
        print(perturbed[-1], flush=True)
    command = " ".join(["python benchmarks/excursions.py", *given])
    text = section(rows, args.far, args.qdd_max, command, perturbed)
    print(text)
    write_section(args.out, HEADING, text)
    return 0
