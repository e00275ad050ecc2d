"""Targets driven beyond reach and back under acceleration limits, on every 3-D arm.

For each bundled arm (Panda, UR5e, iiwa 14) the default controller
(``Lp2Controller``, 1 kHz, the command unclamped as the quality suite's peers get
it) starts at rest on its home pose; the target moves at 1 m/s ``far`` metres
along one of ten directions (the six axes and four diagonals), is held 0.3 s,
comes back at the same speed and is held 2.5 s on the home pose. An excursion
is *recovered* when the tool ends within 0.01 mm of home. Run it from the
repository root with lpik installed::

    .venv/bin/python benchmarks/excursions.py [--qdd-max 10] [--far 0.5 1.0]

It prints a Markdown table (recovered excursions per arm, and where each miss
ended); ``docs/benchmarks.md`` keeps the results and the command.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Iterator

import numpy as np

DT = 1e-3
#: The six axes and four diagonals the target is driven along.
DIRECTIONS = ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1),
              (1, 1, 0), (1, 0, 1), (-1, 1, 1), (1, -1, -1))  # fmt: skip
#: Speed [m/s], hold far out [steps], hold at home [steps]; recovered within [m].
SPEED, HOLD, SETTLE, RECOVERED = 1.0, 300, 2500, 1e-5


def targets(start: np.ndarray, direction: np.ndarray, far: float) -> Iterator[np.ndarray]:
    """The excursion's target poses, one per step."""
    ramp = int(round(far / SPEED / DT))
    share = [*np.linspace(0.0, 1.0, ramp), *[1.0] * HOLD, *np.linspace(1.0, 0.0, ramp),
             *[0.0] * SETTLE]  # fmt: skip
    for s in share:
        target = start.copy()
        target[:3, 3] += s * far * direction
        yield target


def excursion(robot: str, direction: tuple, far: float, qdd_max: float | None) -> float:
    """The tool's distance from home after the excursion [m]."""
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    model, q0 = load_robot(robot), home_configuration(robot)
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd_max, v_max=1e6, w_max=1e6)
    unit = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    home = model.pose(q0)
    q, prev = q0.copy(), q0.copy()
    for target in targets(home, unit, far):
        prev, q = q, controller.step(q, target, prev).q
    return float(np.linalg.norm(model.pose(q)[:3, 3] - home[:3, 3]))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qdd-max", type=float, default=10.0, help="rad/s^2; 0: none")
    parser.add_argument("--far", type=float, nargs="+", default=[0.5, 1.0], help="metres")
    parser.add_argument("--robots", nargs="+", default=["panda", "ur5e", "iiwa14"])
    args = parser.parse_args(argv)
    os.environ.setdefault("LPIK_COMPILE", "now")
    qdd = args.qdd_max or None
    print(f"Command: {' '.join(['python benchmarks/excursions.py', *(argv or sys.argv[1:])])}")
    print()
    print("| arm | recovered | misses (far [m], direction: tool's distance from home [mm]) |")
    print("|---|---:|---|")
    for robot in args.robots:
        misses = []
        runs = [(far, d) for far in args.far for d in DIRECTIONS]
        for far, direction in runs:
            off = excursion(robot, direction, far, qdd)
            if off > RECOVERED:
                misses.append(f"{far:g}, {direction}: {off * 1e3:.1f}")
        text = "; ".join(misses) or "none"
        print(f"| {robot} | {len(runs) - len(misses)} of {len(runs)} | {text} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
