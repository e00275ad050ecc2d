"""Per-step time of Lp2Controller over Pinocchio and MuJoCo: their kinematics, then compiled LP2.

A closed 1 kHz loop on the bundled Panda (pose task, velocity and acceleration
limits, the command a circle of 5 cm radius): each step is the backend's pose
and Jacobian (one pass) and the compiled rest of the step
(``lpik.control.backend_step``). lpik's own chain (one fused compiled call) is
timed alongside for reference. Prints median, p99 and max [us]; ``--markdown
PATH`` writes the table of docs/backend-benchmarks.md:

    python benchmarks/bench_backends.py --steps 20000 --markdown docs/backend-benchmarks.md
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time
from collections.abc import Callable

import numpy as np

os.environ.setdefault("LPIK_COMPILE", "now")  # time the compiled step from the first one

from lpik.control.controller import Lp2Controller  # noqa: E402
from lpik.robots.registry import ROBOTS, home_configuration, load_chain, urdf_path
from lpik.robots.tasks import PoseTask

TARGET_MEDIAN_US = 30.0


def backends() -> dict[str, object]:
    """The Panda's chain in every backend that is installed."""
    tip = ROBOTS["panda"].tip_link
    out: dict[str, object] = {"lpik SerialChain (fused)": load_chain("panda")}
    try:
        from lpik.robots.pinocchio_adapter import PinocchioChain

        out["Pinocchio"] = PinocchioChain.from_urdf(urdf_path("panda"), tip_link=tip)
    except ImportError:
        pass
    try:
        from lpik.robots.mujoco_adapter import MujocoChain

        out["MuJoCo"] = MujocoChain.from_urdf(urdf_path("panda"), tip_link=tip)
    except ImportError:
        pass
    return out


def loop_times(controller: Lp2Controller, steps: int) -> np.ndarray:
    """Wall time [us] of each ``step`` of a closed loop following a circle."""
    q = home_configuration("panda").copy()
    prev = q.copy()
    start_pose = controller.model.pose(q)
    clock = time.perf_counter_ns
    times = np.empty(steps)
    target = start_pose.copy()
    for k in range(steps + 500):  # the first 500 steps warm up and are not counted
        angle = 2 * np.pi * k / 4000
        target[:3, 3] = start_pose[:3, 3] + 0.05 * np.array([np.cos(angle) - 1, np.sin(angle), 0])
        begin = clock()
        result = controller.step(q, target, prev)
        end = clock()
        if k >= 500:
            times[k - 500] = (end - begin) / 1e3
        prev, q = q, result.q
    return times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--markdown", help="write the results as a markdown page here")
    args = parser.parse_args(argv)
    rows: list[tuple[str, float, float, float]] = []
    for name, chain in backends().items():
        controller = Lp2Controller(PoseTask(chain), dt=0.001, qdd_max=20.0)
        times = loop_times(controller, args.steps)
        row = (name, float(np.median(times)), float(np.percentile(times, 99)), float(times.max()))
        rows.append(row)
        print(f"{name:28s} median {row[1]:7.2f} us  p99 {row[2]:7.2f} us  max {row[3]:8.2f} us")
    if args.markdown:
        write_markdown(args.markdown, rows, args.steps)
    return 0


def write_markdown(path: str, rows: list[tuple[str, float, float, float]], steps: int) -> None:
    """The results as the page docs/backend-benchmarks.md."""
    load: Callable[[], tuple[float, float, float]] = os.getloadavg
    lines = [
        "# Lp2Controller over Pinocchio and MuJoCo",
        "",
        "<!-- Written by benchmarks/bench_backends.py; do not edit by hand. -->",
        "",
        f"- **Command:** `python benchmarks/bench_backends.py --steps {steps} --markdown {path}`",
        f"- **Date:** {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}",
        f"- **Machine:** {platform.machine()}, {os.cpu_count()} cores, "
        f"load average {load()[0]:.2f}; Python {platform.python_version()}",
        "- **Loop:** the bundled Panda, pose task, dt = 1 ms, velocity and acceleration limits "
        f"(20 rad/s^2), a 5 cm circle; {steps} timed steps after 500 warm-up steps.",
        f"- **Target:** a backend-backed step under {TARGET_MEDIAN_US:g} us median.",
        "- **Max** is the slowest single step; with the load average above the number of "
        "cores it measures the scheduler (the process waiting for a core), not the step.",
        "",
        "| kinematics | median [us] | p99 [us] | max [us] | median under target |",
        "|---|---|---|---|---|",
    ]
    for name, median, p99, worst in rows:
        met = "yes" if median < TARGET_MEDIAN_US else "no"
        lines.append(f"| {name} | {median:.2f} | {p99:.2f} | {worst:.2f} | {met} |")
    with open(path, "w", encoding="utf-8") as handle:
        handle.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    raise SystemExit(main())
