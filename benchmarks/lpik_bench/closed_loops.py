"""Closed loops over the three bundled arms and ten controller settings, every step checked.

The soak (:mod:`lpik_bench.soak`) runs one arm with one setting for a million
steps. This runs each bundled arm (Panda, UR5e, iiwa14: a pose task but in one
setting, dt = 1 ms, the URDFs' end-stops and velocity limits) under each of
:data:`SETTINGS` for fewer steps: a setting a user picks may reach code the
default never does (the progress mode's second stage, a kernel loaded only
after a fault, a command left unclamped as the peers' benchmarks give it). The
target is the soak's random walk, kept within :data:`RADIUS` of the tool's
home position (often out of reach), and now and then one ``q_prev`` sample is
off by about 0.05 rad per joint: a speed of up to some 50 rad/s that no drive
can make (a bad velocity sample). Each step is checked by
:func:`lpik_bench.soak.check_step` (no acceleration, end-stop or velocity
limit broken, never further out while recovering, no NaN, ``p`` in [0, 1];
among the shelf's obstacles, which the Panda alone runs, no step from outside
the safety distance ending inside it), and its time is taken: a step above 1
ms misses a 1 kHz period (a kernel loaded from numba's cache inside the loop
once cost 11 ms after the first bad sample).

One setting builds ``q_prev`` from a velocity reading, ``q0 - qd dt`` (as many
drives report ``qd``), exact but for about one reading in :data:`VELOCITY_FAULT_EVERY`,
where one joint's is beyond its velocity limit (:func:`bad_reading`). Its steps are
checked against the arm's own last motion, not the reading, so that the acceleration
limits are held on every step, the bad readings' included; each bad reading's step
is ``recovering``. The other settings' bad samples are checked against the sample.

One setting closes the loop on measured joints (:func:`run_measured`): each
state is the last command plus encoder noise, the reading before it is
``q_prev``, and each step is held to that loop's contract
(:func:`lpik_bench.soak.check_measured_step`: no command further past an
end-stop than its reading, the velocity limits, and each step but a recovery
within twice the acceleration band of the step answered before it).

Run it from the repository root (``--write`` puts the table into
``docs/reliability.md``, between its markers)::

    PYTHONPATH=benchmarks python -m lpik_bench.closed_loops --steps 40000 \\
        --write docs/reliability.md
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from lpik_bench.soak import (
    DT,
    SoakReport,
    Walk,
    check_measured_step,
    check_step,
    tally,
    write_block,
)

#: The arms, by their names in lpik's registry.
ROBOTS = ("panda", "ur5e", "iiwa14")
#: The controller settings: a label and ``Lp2Controller``'s keyword arguments.
SETTINGS: dict[str, dict[str, Any]] = {
    "default, qdd_max=10": {"qdd_max": 10.0},
    "unclamped, qdd_max=10": {"qdd_max": 10.0, "v_max": 1e6, "w_max": 1e6},
    'mode="progress", qdd_max=5': {"qdd_max": 5.0, "mode": "progress"},
    "unclamped, no acceleration limits": {"v_max": 1e6, "w_max": 1e6},
    "lambda_bound=None, qdd_max=50": {"qdd_max": 50.0, "lambda_bound": None},
    "on_stall=None (strict), qdd_max=10": {"qdd_max": 10.0, "on_stall": None},
    "saturate=False, qdd_max=10": {"qdd_max": 10.0, "saturate": False},
    "position task, qdd_max=10": {"qdd_max": 10.0, "task": "position"},
    "the shelf scene, qdd_max=10": {"qdd_max": 10.0, "scene": "panda-shelf"},
    "the shelf scene, unclamped, qdd_max=10": {
        "qdd_max": 10.0,
        "v_max": 1e6,
        "w_max": 1e6,
        "scene": "panda-shelf",
    },
    "the shelf scene, field and rows, qdd_max=10": {
        "qdd_max": 10.0,
        "scene": "panda-shelf",
        "mechanism": "both",
    },
    "measured joints (noise 1e-4 rad), qdd_max=10": {"qdd_max": 10.0, "noise": 1e-4},
    "velocity readings, qdd_max=10": {"qdd_max": 10.0, "velocity_readings": True},
}
#: The settings whose ``q_prev`` is built from a velocity reading, not passed as it is.
VELOCITY_SETTINGS = {name for name, kw in SETTINGS.items() if kw.get("velocity_readings")}
#: The settings with a scene run on the arm the scene is laid out for only.
SCENE_ARM = "panda"
#: A step from at or above the safety distance may end below it by this much [m]: the
#: rows hold the distance to first order, and the walk's steps are small.
SECOND_ORDER = 1e-4
#: A step's closest pair may come nearer than its damper row allows by this much [m]: the
#: row holds the distance to first order (a capsule's witness point moves along it).
DAMPER_SECOND_ORDER = 1e-5
#: The walk stays within this distance of the tool's home position [m].
RADIUS = 0.8
#: On average one bad ``q_prev`` sample in this many steps.
BAD_SAMPLE_EVERY = 5000
#: Standard deviation of a bad sample's offset per joint [rad].
BAD_SAMPLE_SIZE = 0.05
#: On average one bad velocity reading in this many steps (:func:`bad_reading`).
VELOCITY_FAULT_EVERY = 500
#: A step slower than this misses a 1 kHz period [s].
PERIOD = 1e-3
#: Markers of the generated block in docs/reliability.md.
BEGIN, END = "<!-- loops:begin -->", "<!-- loops:end -->"


def bad_reading(rng: Any, model: Any, q0: Any, q_prev: Any) -> Any:
    """``q_prev`` as a loop builds it from a velocity reading, ``q0 - qd dt``, where one
    joint's reading is a bad sample: beyond its velocity limit by 0.01 to 50 rad/s."""
    j = int(rng.integers(q0.size))
    speed = (model.qd_max[j] + rng.uniform(0.01, 50.0)) * rng.choice([-1.0, 1.0])
    out = q_prev.copy()
    out[j] = q0[j] - speed * DT
    return out


def _setup(robot: str, setting: str) -> tuple[Any, Any, Any, str, dict[str, Any]]:
    """The task model, compiled controller, scene (or None), task kind and keyword arguments
    of ``robot`` under ``SETTINGS[setting]``."""
    from lpik.collision import collision_avoidance, load_scene
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import load_robot

    options = dict(SETTINGS[setting])
    options.pop("noise", None)
    options.pop("velocity_readings", None)  # how the loop builds q_prev (run)
    task = options.pop("task", "pose")  # the walk is a pose; a position task follows its point
    model = load_robot(robot, task=task)
    scene = None if "scene" not in options else load_scene(options.pop("scene"))
    mechanism = options.pop("mechanism", "rows")  # the potential field too: the compiled field
    if scene is not None and mechanism != "rows":
        scene = collision_avoidance(model, scene, None, mechanism=mechanism)
    controller = Lp2Controller(model, dt=DT, compile="now", scene=scene, **options)
    return model, controller, scene, task, options


def _times(times: Any) -> list[float]:
    """Median, p99, p99.9, max [s] and how many steps missed :data:`PERIOD`."""
    return [float(np.median(times)), float(np.percentile(times, 99)),
            float(np.percentile(times, 99.9)), float(times.max()),
            float((times > PERIOD).sum())]  # fmt: skip


def run(robot: str, setting: str, steps: int, seed: int = 0) -> SoakReport:
    """``robot``'s compiled controller under ``SETTINGS[setting]`` for ``steps`` steps
    (a setting with ``noise``: :func:`run_measured`)."""
    from lpik.robots.registry import home_configuration, load_robot

    if "noise" in SETTINGS[setting]:
        return run_measured(robot, setting, steps, seed)
    model, controller, scene, task, options = _setup(robot, setting)
    rng = np.random.default_rng(seed)
    q = home_configuration(robot)
    q_prev = q.copy()
    start = load_robot(robot).pose(q)
    walk = Walk(start, rng, center=start[:3, 3], radius=RADIUS)
    report = SoakReport(path=f"{robot}, {setting}")
    times = np.empty(steps)
    run_length = 0
    readings = setting in VELOCITY_SETTINGS
    for k in range(steps):
        target = walk.next() if task == "pose" else walk.next()[:3, 3].copy()
        given = q_prev
        if rng.random() < 1.0 / (VELOCITY_FAULT_EVERY if readings else BAD_SAMPLE_EVERY):
            given = (bad_reading(rng, model, q, q_prev) if readings
                     else q_prev + rng.normal(0.0, BAD_SAMPLE_SIZE, q.size))  # fmt: skip
            report.glitches += 1
        t0 = time.perf_counter()
        result = controller.step(q, target, given)
        times[k] = time.perf_counter() - t0
        run_length = tally(report, result, run_length)
        # a velocity reading's loop: checked against the arm's own last motion, every step
        check_step(report, model, q, q_prev if readings else given, result.q, result.p,
                   result.status, options.get("qdd_max"))  # fmt: skip
        if scene is not None:
            below, past = against_the_scene(controller.avoidance, q, result.q, DT)
            report.below_safety += below
            report.past_damper += past
        q_prev, q = q, np.array(result.q, dtype=np.float64)
    report.steps = steps
    report.step_times = _times(times)
    return report


def run_measured(robot: str, setting: str, steps: int, seed: int = 0) -> SoakReport:
    """The loop closed on measured joints: each state is the last command plus encoder noise.

    The drives are taken to follow each command exactly, and the controller is given
    the reading of that position (``noise`` rad of Gaussian noise per joint) as ``q0``
    and the reading before as ``q_prev``, as a loop on a real arm's encoders is. Each
    step is held to the contract of such a loop (:func:`lpik_bench.soak.check_measured_step`).
    """
    from lpik.robots.registry import home_configuration, load_robot

    model, controller, _, _, options = _setup(robot, setting)
    noise = float(SETTINGS[setting]["noise"])
    rng = np.random.default_rng(seed)
    q = home_configuration(robot)
    start = load_robot(robot).pose(q)
    walk = Walk(start, rng, center=start[:3, 3], radius=RADIUS)
    report = SoakReport(path=f"{robot}, {setting}")
    times = np.empty(steps)
    reading_before, answered, run_length = q.copy(), None, 0
    for k in range(steps):
        target = walk.next()
        reading = q + rng.normal(0.0, noise, q.size)
        t0 = time.perf_counter()
        result = controller.step(reading, target, reading_before)
        times[k] = time.perf_counter() - t0
        run_length = tally(report, result, run_length)
        check_measured_step(report, model, reading, answered, result.q, result.p,
                            result.status, options["qdd_max"])  # fmt: skip
        q, reading_before = np.array(result.q, dtype=np.float64), reading
        answered = q - reading
    report.steps = steps
    report.step_times = _times(times)
    return report


def against_the_scene(avoidance: Any, q0: Any, q: Any, dt: float) -> tuple[bool, bool]:
    """Whether the step from ``q0`` to ``q`` took the closest pair from the safety distance
    ``d_s`` or more to below it (by more than :data:`SECOND_ORDER`), and whether a pair
    within the influence distance ``d_i`` and outside ``d_s`` came nearer than its damper row
    allows, ``d < (1 - r) d0 + r d_s`` (by more than :data:`DAMPER_SECOND_ORDER`)."""
    from lpik.collision.avoidance import damper_share

    scene = avoidance.scene
    safety, influence = scene.safety_distance, scene.influence_distance
    share = damper_share(avoidance.approach_speed, dt, safety, influence)
    before = np.array([p.distance for p in avoidance.proximities.at(q0)])
    after = np.array([p.distance for p in avoidance.proximities.at(q)])
    if not before.size:
        return False, False
    watched = (before >= safety) & (before < influence)
    allowed = (1.0 - share) * before + share * safety - DAMPER_SECOND_ORDER
    return (bool(before.min() >= safety and after.min() < safety - SECOND_ORDER),
            bool((watched & (after < allowed)).any()))  # fmt: skip


def render(reports: list[SoakReport], command: str) -> str:
    """The Markdown block for docs/reliability.md."""
    rows = [
        "| arm, setting | steps | broken: acceleration / end-stop / velocity / further out / "
        "NaN / p / below d_s | nearer than the damper allows | bad samples | "
        "off_direction / infeasible / recovering steps | "
        "longest p = 0 run | step time median / p99 / p99.9 / max [us] | steps over 1 ms |",
        "|" + "---|" * 9,
    ]
    for r in reports:
        med, p99, p999, worst = (1e6 * t for t in r.step_times[:4])
        s = r.statuses
        rows.append(
            f"| {r.path} | {r.steps:,} | {r.acceleration_violations} / {r.end_stop_violations} / "
            f"{r.velocity_violations} / {r.further_out} / {r.non_finite} / {r.p_outside_unit} / "
            f"{r.below_safety} | {r.past_damper if 'scene' in r.path else '-'} | "
            f"{r.glitches} | {s.get('off_direction', 0):,} / {s.get('infeasible', 0):,} / "
            f"{s.get('recovering', 0):,} | {r.longest_p_zero_run:,} | "
            f"{med:.1f} / {p99:.1f} / {p999:.1f} / {worst:.0f} | {int(r.step_times[4])} |"
        )
    load = "/".join(f"{x:.1f}" for x in os.getloadavg())
    machine = (f"{platform.machine()}, {os.cpu_count()} cores, Python "
               f"{platform.python_version()}, load average {load} at the end")  # fmt: skip
    return "\n".join([BEGIN, "", f"Produced by `{command}` ({machine}).", "", *rows, "", END])


def main(argv: list[str] | None = None) -> int:
    """Command line: every arm under every setting; print (or write) the table."""
    parser = argparse.ArgumentParser(prog="python -m lpik_bench.closed_loops",
                                     description=__doc__.splitlines()[0])  # fmt: skip
    parser.add_argument("--steps", type=int, default=40_000, help="steps per arm and setting")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--write", type=Path, help="the Markdown file with the markers")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error(f"--steps: must be at least 1, got {args.steps}")
    reports = []
    for robot in ROBOTS:
        for setting in SETTINGS:
            if "scene" in SETTINGS[setting] and robot != SCENE_ARM:
                continue
            reports.append(run(robot, setting, args.steps, args.seed))
            print(reports[-1].path, "broken:", reports[-1].broken(), flush=True)
    command = "PYTHONPATH=benchmarks python -m lpik_bench.closed_loops " + " ".join(
        sys.argv[1:] if argv is None else argv)  # fmt: skip
    block = render(reports, command.strip())
    print(block)
    if args.write is not None:
        write_block(args.write, block, BEGIN, END)
    return 1 if any(r.broken() for r in reports) else 0


if __name__ == "__main__":
    sys.exit(main())
