"""The motion-quality suite: closed-loop runs of lpik and the peers on the same target paths.

Each library runs each scenario (:mod:`lpik_bench.quality_scenarios`) on the
Panda (arm only, 6-D pose task, ``dt`` = 1 ms, the URDF's end-stops and
velocity limits) in closed loop: from the leg's start configuration at rest,
it is given the current joint coordinates and the commanded target and
integrates its own answer, ``q_next = q + dq``. The metrics
(:mod:`lpik_bench.quality_metrics`) and the report
(:mod:`lpik_bench.quality_report`) are computed from what each library did.

lpik's variants are :data:`VARIANTS`: keyword arguments of
:class:`~lpik.control.controller.Lp2Controller` by name (a variant whose
arguments the installed lpik does not take is skipped with a note). The peers
are the adapters of :mod:`lpik_bench.peers`; one that is not installed is
skipped with a note.

Run it from the repository root (``benchmarks/quality.py`` writes docs/quality.md)::

    python -m lpik_bench.quality --out docs/quality.md

``--robot iiwa14`` (or ``ur5e``) runs the same scenarios from that arm's home
configuration, leaving out those laid out for the Panda alone (:func:`run_suite`);
the report is printed (``--out`` to keep it) and gives no explanations of misses,
which were found on the Panda.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from lpik.robots.registry import load_robot, robot_names
from lpik.robots.tasks import PoseTask
from lpik.types import FloatArray
from lpik_bench.quality_metrics import (
    LegRun,
    ScenarioResult,
    SuiteResult,
    scenario_metrics,
)
from lpik_bench.quality_scenarios import SCENARIOS, Leg
from lpik_bench.workload import DT, QDD_MAX

#: ``v_max`` [m/s] and ``w_max`` [rad/s] of every variant: lpik's clamp off, so that each is
#: given the command the peers are given (V = error / dt; like against like).
UNCLAMPED = 1e6
_OPEN = {"v_max": UNCLAMPED, "w_max": UNCLAMPED}
#: lpik's variants: name -> keyword arguments of Lp2Controller (besides ``model`` and ``dt``).
#: ``mode="progress"`` (the progress mode) is skipped with a note where lpik lacks it.
#: The scenarios laid out for the Panda alone (``--robot`` takes any bundled arm).
PANDA_ONLY = ("obstacle",)
VARIANTS: dict[str, dict[str, Any]] = {
    "lp2s": {**_OPEN},
    "lp2s +acc": {"qdd_max": QDD_MAX, **_OPEN},
    # the paper's strict steps (no stall stage): what the default's stall stage buys and costs
    "lp2s strict": {"on_stall": None, **_OPEN},
    "lp2s +acc strict": {"on_stall": None, "qdd_max": QDD_MAX, **_OPEN},
    "lp2": {"saturate": False, **_OPEN},
    "lp2 +acc": {"saturate": False, "qdd_max": QDD_MAX, **_OPEN},
    "lp2s unbounded": {"lambda_bound": None, **_OPEN},
    "lp2 unbounded": {"saturate": False, "lambda_bound": None, **_OPEN},
    "lp2s progress": {"mode": "progress", **_OPEN},
}

#: ``step(q, q_prev, target) -> (dq, p, status, binding, ns)``: one timed step.
StepCall = Callable[[FloatArray, FloatArray, FloatArray], tuple]
#: ``direction(q, q_prev, target) -> p``: LP1's p on the step's problem, the largest
#: fraction of the command that any step within the limits follows exactly.
DirectionCall = Callable[[FloatArray, FloatArray, FloatArray], float]


@dataclass(eq=False)
class Contender:
    """One library (or lpik variant) as the suite runs it.

    Attributes:
        name: Row name in the report. library: ``"lpik"`` or the peer's library.
        step: One timed step (see :data:`StepCall`).
        acceleration_limited: Whether it claims to hold :data:`~lpik_bench.workload.QDD_MAX`.
        note: How it is set up.
        direction: lpik's: the largest ``p`` of any step within the limits (LP1), for
            the frozen steps (see :data:`DirectionCall`).
        limited_scenarios_only: Runs only in the acceleration-limited scenarios
            (a peer's step with acceleration limits, "+acc").
        mode: lpik's ``"direction"`` (keeps the commanded direction) or ``"progress"``
            (the progress mode); the peer each is judged against on tracking is
            :data:`lpik_bench.quality_report.LIKE_PEERS`.
        with_scene: ``with_scene(scene, q0)``: the same contender among the obstacles of
            ``scene`` (None: no obstacle support, n/a in a scenario with obstacles).
    """

    name: str
    library: str
    step: StepCall
    acceleration_limited: bool = False
    note: str = ""
    direction: DirectionCall | None = None
    limited_scenarios_only: bool = False
    mode: str = "direction"
    with_scene: Callable[[Any, FloatArray], Contender] | None = None

    @property
    def is_lpik(self) -> bool:
        """True for lpik's variants."""
        return self.library == "lpik"


def lpik_contenders(
    model: PoseTask, dt: float, names: tuple[str, ...] = tuple(VARIANTS)
) -> tuple[list[Contender], list[str]]:
    """lpik's variants by name, and a note for each one the installed lpik cannot build."""
    from lpik.control.controller import Lp2Controller

    out, notes = [], []
    for name in names:
        kwargs = VARIANTS[name]
        try:
            controller = Lp2Controller(model, dt=dt, **kwargs)
        except TypeError as exc:
            notes.append(f"{name}: not available in this lpik ({exc})")
            continue
        args = ", ".join(f"{k}={v!r}" for k, v in kwargs.items()) or "default arguments"
        out.append(_lpik_contender(name, controller, kwargs, f"Lp2Controller({args})"))
    return out, notes


def _lpik_contender(name: str, controller: Any, kwargs: dict[str, Any], note: str) -> Contender:
    """One lpik variant over ``controller``; its ``with_scene`` builds it among obstacles."""
    from lpik.control.controller import Lp2Controller
    from lpik.methods.lp1 import lp1

    def step(q: FloatArray, prev: FloatArray, target: FloatArray) -> tuple:
        t0 = time.perf_counter_ns()
        result = controller.step(q, target, prev)
        ns = time.perf_counter_ns() - t0
        return result.q - q, result.p, result.status, result.binding, ns

    def direction(q: FloatArray, prev: FloatArray, target: FloatArray) -> float:
        return float(lp1(controller.problem(q, target, prev)).p)

    def with_scene(scene: Any, q0: FloatArray) -> Contender:
        among = Lp2Controller(controller.model, dt=controller.dt, scene=scene, home=q0, **kwargs)
        return _lpik_contender(name, among, kwargs, note)

    mode = "progress" if kwargs.get("mode") == "progress" else "direction"
    return Contender(name, "lpik", step, "qdd_max" in kwargs, note, direction, mode=mode,
                     with_scene=with_scene)  # fmt: skip


def peer_contenders(
    names: tuple[str, ...], robot: str = "panda"
) -> tuple[list[Contender], list[str]]:
    """The peers' steps (:func:`lpik_bench.peers.load_peers`) and a note for each skipped one.

    A peer that takes acceleration limits (:data:`lpik_bench.peers.ACCELERATION_ADAPTERS`)
    is run a second time with them, as "<name> +acc", in the acceleration-limited
    scenarios only.
    """
    from lpik_bench.peers import ACCELERATION_ADAPTERS, load_peers
    from lpik_bench.workload import make_workload

    workload = make_workload(robot, trajectories=1, steps=1)
    peers = load_peers(workload, names)
    per_library: dict[str, int] = {}
    for peer in peers.steps:
        per_library[peer.library] = per_library.get(peer.library, 0) + 1
    with_limits = load_peers(workload, names, ACCELERATION_ADAPTERS)
    out = []
    for peer in peers.steps + with_limits.steps:
        name = peer.library
        if per_library.get(name, 0) > 1 and peer.qdd_max is None:
            name += " " + peer.method.split()[-1]
        name += "" if peer.qdd_max is None else " +acc"
        note = f"{peer.method} ({peer.library} {peer.version}): {peer.note}"
        limited = peer.qdd_max is not None
        among = _mink_with_scene if peer.library == "mink" and not limited else None
        out.append(Contender(name, peer.library, _peer_call(peer.step, limited), limited, note,
                             limited_scenarios_only=limited, with_scene=among))  # fmt: skip
    skipped = dict.fromkeys(f"{s.library}: {s.reason}" for s in peers.skipped + with_limits.skipped)
    return out, list(skipped)


def _mink_with_scene(scene: Any, q0: FloatArray) -> Contender:
    """mink among ``scene``'s obstacles (:func:`lpik_bench.quality_obstacle.mink_among`)."""
    from lpik_bench.quality_obstacle import mink_among

    note = "solve_ik daqp with CollisionAvoidanceLimit"
    return Contender("mink", "mink", _peer_call(mink_among(scene, q0), False), note=note)


def _peer_call(fn: Any, needs_prev: bool) -> StepCall:
    """A peer's ``step(q, target[, q_prev])`` as a timed :data:`StepCall`."""

    def step(q: FloatArray, prev: FloatArray, target: FloatArray) -> tuple:
        t0 = time.perf_counter_ns()
        try:
            dq = fn(q, target, prev) if needs_prev else fn(q, target)
        except Exception as exc:  # a peer that raises on a step: counted as a failed step
            ns = time.perf_counter_ns() - t0
            message = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
            return None, None, message[:160], None, ns
        return dq, None, None, None, time.perf_counter_ns() - t0

    return step


def braking_step(last: FloatArray, reduction: float | FloatArray) -> FloatArray:
    """The step of a failed step: no motion, or, with acceleration limits, the braking step.

    Each joint's step is ``last`` reduced towards 0 by at most ``reduction``
    (``qdd_max dt^2``, the acceleration limit, one for all joints or one per
    joint; 0 for a library without one: ``dq = 0``), as lpik's safe step
    (:func:`lpik.result.safe_step`) brakes.
    """
    if np.all(np.asarray(reduction) <= 0):
        return np.zeros_like(last)
    return last - np.clip(last, -reduction, reduction)


def run_leg(contender: Contender, leg: Leg, dt: float = DT) -> LegRun:
    """``contender`` in closed loop over ``leg`` from its start at rest."""
    n_steps, n = len(leg.targets), leg.q0.size
    q, prev = leg.q0.copy(), leg.q0.copy()
    qs = np.empty((n_steps + 1, n))
    qs[0] = q
    ns = np.empty(n_steps, dtype=np.int64)
    p = np.full(n_steps, np.nan) if contender.is_lpik else None
    status: list[str] = []
    binding: list[str | None] = []
    first_failure = None
    failed_at = np.zeros(n_steps, dtype=bool)
    for k in range(n_steps):
        dq, pk, sk, bk, ns[k] = contender.step(q, prev, leg.targets[k])
        if dq is None or not np.all(np.isfinite(dq)):
            failed_at[k] = True
            first_failure = first_failure or (sk if dq is None else "no finite step returned")
            dq = braking_step(q - prev, QDD_MAX * dt * dt if contender.acceleration_limited else 0)
        prev, q = q, q + np.asarray(dq, dtype=float)
        qs[k + 1] = q
        if p is not None:
            p[k] = pk
            status.append(sk)
            binding.append(bk)
    if p is None:
        return LegRun(qs, ns, first_failure=first_failure, failed_at=failed_at)
    return LegRun(qs, ns, p, status, binding, first_failure, failed_at)


def _runs(
    c: Contender, scenario: Any, dt: float
) -> tuple[list[LegRun] | None, DirectionCall | None]:
    """``c``'s run of each leg (among each leg's obstacles, if any) and its direction call.

    None for a scenario with obstacles where ``c`` has none (n/a).
    """
    if not any(leg.scene is not None for leg in scenario.legs):
        return [run_leg(c, leg, dt) for leg in scenario.legs], c.direction
    if c.with_scene is None:
        return None, None
    runs = [run_leg(c.with_scene(leg.scene, leg.q0), leg, dt) for leg in scenario.legs]
    return runs, None  # LP1's p among one leg's obstacles: not asked for


def run_suite(
    scenarios: tuple[str, ...] = tuple(SCENARIOS),
    *,
    peers: tuple[str, ...] = ("drake", "pink", "mink", "rtb"),
    variants: tuple[str, ...] = tuple(VARIANTS),
    max_steps: int | None = None,
    dt: float = DT,
    say: Callable[[str], None] = lambda message: None,
    robot: str = "panda",
) -> SuiteResult:
    """Run every contender on every scenario and compute the metrics.

    Args:
        scenarios: Keys of :data:`~lpik_bench.quality_scenarios.SCENARIOS`.
        peers: Peer names (:data:`lpik_bench.peers.ADAPTERS`); ``()`` for lpik alone.
        variants: lpik variants (keys of :data:`VARIANTS`).
        max_steps: Cut every leg to this many steps (None: full length).
        dt: Control period [s].
        say: Progress messages.
        robot: The bundled arm (its registry name). The suite is laid out for the
            Panda: on another arm a scenario that cannot be built there (the
            end-stop goals, the obstacle beside the Panda's link 4) is left out,
            and the report says why.
    """
    start = time.perf_counter()
    load = os.getloadavg() if hasattr(os, "getloadavg") else (0.0, 0.0, 0.0)
    model = load_robot(robot, task="pose")
    contenders, skipped = lpik_contenders(model, dt, variants)
    if peers:
        found, notes = peer_contenders(peers, robot)
        contenders += found
        skipped += notes
    for c in contenders:  # load or compile before anything is timed
        q = model.q_min * 0.5 + model.q_max * 0.5
        c.step(q, q, model.pose(q))
    results = []
    for key in scenarios:
        t0 = time.perf_counter()
        if key in PANDA_ONLY and robot != "panda":
            skipped.append(f"scenario {key}: laid out for the Panda only")
            continue
        try:
            scenario = SCENARIOS[key](model, dt, max_steps)
        except (RuntimeError, IndexError) as exc:  # goals chosen for the Panda's joints
            skipped.append(f"scenario {key}: not built for {robot} ({exc})")
            continue
        say(f"{scenario.title}: {scenario.steps} steps, built in {time.perf_counter() - t0:.1f} s")
        result = ScenarioResult(scenario)
        for c in contenders:
            if c.limited_scenarios_only and not scenario.acceleration_checked:
                continue
            t1 = time.perf_counter()
            runs, direction = _runs(c, scenario, dt)
            if runs is None:  # no obstacle support: n/a
                result.not_applicable.append(c.name)
                continue
            check = c.acceleration_limited or scenario.acceleration_checked
            result.rows[c.name] = scenario_metrics(
                model, scenario.legs, runs, dt, QDD_MAX if check else None, direction
            )
            if c.is_lpik:
                result.lpik.add(c.name)
            if c.acceleration_limited:
                result.limited.add(c.name)
            if c.mode == "progress":
                result.progress.add(c.name)
            say(f"  {c.name}: {time.perf_counter() - t1:.1f} s")
        result.wall_s = time.perf_counter() - t0
        results.append(result)
    after = os.getloadavg() if hasattr(os, "getloadavg") else (0.0, 0.0, 0.0)
    env = environment(load, after, dt, max_steps)
    env["robot"] = robot
    wall = time.perf_counter() - start
    return SuiteResult(results, {c.name: c.note for c in contenders}, skipped, env, wall)


def _cpu() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            for line in info:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _source() -> str:
    """The commit of the lpik source that ran, and whether src/ had uncommitted changes."""
    import subprocess

    root = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            cwd=root,
            text=True,
            capture_output=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", "src"],
            cwd=root,
            text=True,
            capture_output=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return f"commit {head}" + (" with uncommitted changes in src/" if dirty else "")


def environment(before: tuple, after: tuple, dt: float, max_steps: int | None) -> dict[str, Any]:
    """Machine, versions, lpik's source and load of the run."""
    versions = {}
    for package in (
        "lpik",
        "numpy",
        "numba",
        "drake",
        "pin-pink",
        "mink",
        "roboticstoolbox-python",
        "daqp",
        "quadprog",
    ):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            continue
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "cpu": _cpu(),
        "cores": os.cpu_count(),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "versions": versions,
        "source": _source(),
        "load": (round(before[0], 2), round(after[0], 2)),
        "dt": dt,
        "max_steps": max_steps,
    }


def main(argv: list[str] | None = None, command: str | None = None) -> int:
    """Command line: run the suite, print the report, write it to ``--out``."""
    from lpik_bench.quality_report import render

    parser = argparse.ArgumentParser(
        prog="python -m lpik_bench.quality",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--out", type=Path, help="write the Markdown report here")
    parser.add_argument("--scenarios", nargs="+", choices=list(SCENARIOS), default=list(SCENARIOS))
    parser.add_argument("--peers", nargs="*", default=["drake", "pink", "mink", "rtb"])
    parser.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS))
    parser.add_argument("--max-steps", type=int, help="cut every leg to this many steps")
    parser.add_argument(
        "--robot", default="panda", choices=robot_names(),
        help="the bundled arm (the suite is laid out for the Panda; see run_suite)",
    )  # fmt: skip
    parser.add_argument(
        "--lambda-bound",
        type=float,
        nargs="+",
        default=[],
        metavar="B",
        help="also run each chosen variant with |lam_i| <= B (sec. 3.2), for every B given",
    )
    args = parser.parse_args(argv)
    variants = list(args.variants)
    for bound in args.lambda_bound:  # bounded-multiplier twins of the chosen variants
        for name in args.variants:
            twin = f"{name} |lam|<={bound:g}"
            VARIANTS[twin] = {**VARIANTS[name], "lambda_bound": bound}
            variants.append(twin)
    if command is None:
        command = "python -m lpik_bench.quality " + " ".join(sys.argv[1:] if argv is None else argv)
    suite = run_suite(
        tuple(args.scenarios),
        peers=tuple(args.peers),
        variants=tuple(variants),
        max_steps=args.max_steps,
        say=lambda m: print(m, file=sys.stderr, flush=True),
        robot=args.robot,
    )
    text = render(suite, command.strip())
    print(text)
    if args.out is not None:
        args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
