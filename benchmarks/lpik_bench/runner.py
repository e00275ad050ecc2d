"""The benchmark run: interleaved timing, agreement checks, first-call costs, records.

Timing is interleaved: every round visits every case once, in a fresh seeded
random order, and times each call on its own with ``time.perf_counter_ns``.
Within a round a case makes up to ``max_calls`` calls on consecutive workload
items (fewer when its calls are slow: about ``round_budget_s`` per case and
round, at least two); round ``r`` starts at item ``r * max_calls`` for every
case, so that all libraries see the same configurations and targets, and
slow drifts of the machine (load, frequency) spread over every case alike.
The garbage collector is off while a round runs and collects between rounds.
Each case reports the median, the 99th and 99.9th percentiles and the worst
[us] (per step for batches) of its steady-state calls (the second and later
calls of each round) and, apart, of the first call of each round, which runs right after other
libraries and finds the caches cold (``cold_median_us``, ``cold_p99_us``); and
the ratio of its median to the fastest peer's median full step.

Agreement checks hold answers together where they must agree (see
:func:`lpik_bench.agreement.agreement_checks`); first-call costs are timed in fresh processes
(:mod:`lpik_bench.firstcall`).
"""

from __future__ import annotations

import datetime as _dt
import gc
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from importlib import metadata
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik_bench import cases as C
from lpik_bench.agreement import agreement_checks
from lpik_bench.firstcall import robot_argv
from lpik_bench.peers import ADAPTERS, PEER_PACKAGES, PeerSet, load_peers
from lpik_bench.records import Record
from lpik_bench.singular import singular_cases, singular_workload
from lpik_bench.workload import ArmFile, Workload, make_workload

#: Packages whose versions the environment record lists (PyPI names).
VERSIONED = (
    "lpik",
    "numpy",
    "scipy",
    "numba",
    "highspy",
    *PEER_PACKAGES.values(),
    "pin",
    "mujoco",
    "qpsolvers",
    "daqp",
    "quadprog",
)

#: Settings of a run by ``quick`` (a smoke test) and full (the published table).
#: ``calls``: most calls per case and round (200 x 39 steady ones: enough for a p99.9).
QUICK = {"trajectories": 2, "steps": 25, "rounds": 3, "batch": 256, "planar_steps": 50,
         "calls": 20, "singular_bases": 1}  # fmt: skip
FULL = {"trajectories": 8, "steps": 500, "rounds": 200, "batch": 10_000, "planar_steps": 400,
        "calls": 40, "singular_bases": 16}  # fmt: skip


# ---------------------------------------------------------------- statistics and timing


def summarize(samples_ns: ArrayLike, per_call: int = 1) -> tuple[float, float]:
    """Median and 99th percentile of per-call times [ns], per step [us]."""
    t = np.asarray(samples_ns, dtype=np.float64) / (1e3 * per_call)
    return float(np.median(t)), float(np.percentile(t, 99))


def steady_and_cold(samples_ns: ArrayLike, per_call: int = 1) -> dict[str, float]:
    """Median, p99, p99.9 and worst [us per step] of the steady state, and of the first calls
    of a round.

    Args:
        samples_ns: (rounds, calls) from :func:`time_cases`, at least 2 calls a round.
        per_call: Steps per call.

    Returns:
        ``median_us``, ``p99_us``, ``p999_us`` (the 99.9th percentile: about the
        worst of every thousand steps, so read it with ``samples``), ``max_us``
        over columns 1.. (the steady state)
        and ``cold_median_us``, ``cold_p99_us``, ``cold_max_us`` over column 0 (the
        first call of each round, after the other libraries ran).
    """
    t = np.asarray(samples_ns)
    median, p99 = summarize(t[:, 1:], per_call)
    cold_median, cold_p99 = summarize(t[:, 0], per_call)
    return {
        "median_us": median,
        "p99_us": p99,
        "p999_us": float(np.percentile(t[:, 1:], 99.9)) / (1e3 * per_call),
        "max_us": float(t[:, 1:].max()) / (1e3 * per_call),
        "cold_median_us": cold_median,
        "cold_p99_us": cold_p99,
        "cold_max_us": float(t[:, 0].max()) / (1e3 * per_call),
    }


def ratios_to_fastest_peer(medians: dict[str, float], peers: Sequence[str]) -> dict[str, float]:
    """``median / fastest peer median`` for every label; empty without peers.

    Args:
        medians: Median per label [us].
        peers: Labels of the peers' full steps.
    """
    peer_medians = [medians[p] for p in peers if p in medians]
    if not peer_medians:
        return {}
    fastest = min(peer_medians)
    return {label: value / fastest for label, value in medians.items()}


def time_cases(
    cases: Sequence[C.Case],
    rounds: int,
    *,
    max_calls: int = 20,
    round_budget_s: float = 2e-3,
    seed: int = 0,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, np.ndarray]:
    """Interleaved per-call times of every case [ns] (see the module docstring).

    Returns:
        Per case label, an array (rounds, calls per round): column 0 is each
        round's first call of the case, right after other cases ran (cold
        caches); the other columns are the steady state.
    """
    clock = time.perf_counter_ns
    calls = {}
    for case in cases:  # warm up (untimed), then size the calls per round
        for i in range(3):
            case.call(i)
        start = clock()
        for i in range(3):
            case.call(i)
        each = (clock() - start) / 3e9
        calls[case.label] = int(min(max_calls, max(2, round_budget_s // max(each, 1e-9))))
    samples: dict[str, list[int]] = {case.label: [] for case in cases}
    rng = np.random.default_rng(seed)
    enabled = gc.isenabled()
    try:
        for r in range(rounds):
            gc.collect()
            gc.disable()
            base = r * max_calls
            for k in rng.permutation(len(cases)):
                case = cases[k]
                out = samples[case.label]
                call = case.call
                for i in range(base, base + calls[case.label]):
                    start = clock()
                    call(i)
                    out.append(clock() - start)
            if enabled:
                gc.enable()
            if progress is not None:
                progress(r + 1, rounds)
    finally:
        if enabled:
            gc.enable()
    return {
        case.label: np.array(samples[case.label], dtype=np.int64).reshape(rounds, -1)
        for case in cases
    }


# ---------------------------------------------------------------- first calls


def first_call(what: str, robot: str | ArmFile, cold: bool = False, timeout: float = 600.0) -> dict:
    """Phases of :mod:`lpik_bench.firstcall` in a fresh process [s]; ``{"error": ...}`` on failure.

    Args:
        what: ``"lpik"`` or a peer's name.
        robot: A bundled arm's name, or an :class:`~lpik_bench.workload.ArmFile`.
        cold: For lpik: compile every kernel (an empty ``NUMBA_CACHE_DIR``).
        timeout: Limit of the child process [s].
    """
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as cache:
        if cold:
            env["NUMBA_CACHE_DIR"] = cache
        try:
            done = subprocess.run(
                [sys.executable, "-m", "lpik_bench.firstcall", what, *robot_argv(robot)],
                capture_output=True,
                text=True,
                env=env,
                timeout=timeout,
                check=False,
            )
        except subprocess.TimeoutExpired:
            return {"error": f"timed out after {timeout:g} s"}
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
        return {"error": tail}
    try:
        return json.loads(done.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return {"error": "unreadable output"}


def first_call_records(robot: str | ArmFile, peers: Sequence[str], cold: bool) -> list[Record]:
    """First-call records: lpik from the disk cache (and cold, when asked), and every peer."""
    runs = [("lpik", "disk cache", False)]
    if cold:
        runs.append(("lpik", "cold compile", True))
    runs += [(name, "", False) for name in peers]
    out = []
    for what, how, is_cold in runs:
        phases = first_call(what, robot, cold=is_cold)
        if "error" in phases:
            out.append(
                Record(what, "", "first call", kind="skipped", extra={"note": phases["error"]})
            )
            continue
        if what == "lpik":
            total = phases["import_s"] + phases["setup_s"] + phases["first_step_s"]
            method = "lp2 fused (compiled)"
            text = f"first call, {how} (import + setup + first step)"
            out.append(_first(what, method, text, total, phases))
            for method, phase in (
                ("lp2_batch (compiled)", "first_batch_s"),
                ("lp2 fused step_batch (compiled)", "first_step_batch_s"),
            ):
                out.append(_first(what, method, f"first call, {how}", None, phases, phase))
        else:
            total = phases["setup_s"] + phases["first_step_s"]
            text = "first call (import + model load + first step; numpy, lpik loaded)"
            out.append(_first(what, "", text, total, phases))
    return out


def _first(
    library: str, method: str, what: str, total: float | None, phases: dict, only: str = ""
) -> Record:
    """A first-call record; ``only``: the one phase it reports (its total), else all."""
    if only:
        total = phases[only]
        phases = {only: total}
    us = None if total is None else total * 1e6
    extra = {"samples": 1, **{k: round(v, 6) for k, v in phases.items()}}
    return Record(library, method, what, us, us, kind="first call", extra=extra)


# ---------------------------------------------------------------- environment and run


def _cpu_model() -> str:
    try:
        text = subprocess.run(
            ["lscpu"], capture_output=True, text=True, timeout=10, check=False
        ).stdout
        for line in text.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return platform.processor() or platform.machine()


def versions() -> dict[str, str]:
    """Installed versions of :data:`VERSIONED` (missing ones left out)."""
    out = {}
    for name in VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out


def environment(command: str, workload: Workload, settings: dict, load: tuple) -> Record:
    """The environment record: machine, versions, load averages, the command and workload."""
    import numba

    return Record(
        "lpik",
        "bench",
        "environment",
        kind="environment",
        extra={
            "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "command": command,
            "cpu": _cpu_model(),
            "cores": os.cpu_count(),
            "platform": platform.platform(),
            "python": platform.python_version(),
            "numba_threads": numba.get_num_threads(),
            "versions": versions(),
            "loadavg_before": [round(v, 2) for v in load[0]],
            "loadavg_after": [round(v, 2) for v in load[1]],
            "workload": workload.describe(),
            "settings": settings,
        },
    )


def _say(message: str, quiet: bool) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)


def run_benchmark(
    robot: str | ArmFile = "panda",
    *,
    quick: bool = False,
    rounds: int | None = None,
    peers: Sequence[str] | None = None,
    cold: bool | None = None,
    command: str = "lpik bench",
    quiet: bool = False,
) -> list[Record]:
    """Run the whole benchmark and return its records (see :mod:`lpik_bench`).

    Args:
        robot: A bundled arm's name, or an :class:`~lpik_bench.workload.ArmFile`.
        quick: A smoke test: a small workload, 3 rounds, small batch, no cold compile.
        rounds: Timing rounds (default 200, or 3 when quick).
        peers: Peer names to try (default: all of :data:`lpik_bench.peers.ADAPTERS`).
        cold: Also time a cold compile of the kernels in a fresh process
            (default: unless quick).
        command: The command line, for the environment record.
        quiet: No progress on stderr.

    Raises:
        ValueError: Unknown robot or peer, a bad URDF, or rounds < 1.
    """
    settings = _settings(quick, rounds)
    names = _peer_names(peers)
    cold = (not quick) if cold is None else cold
    load_before = os.getloadavg()
    _say(f"lpik bench: workload ({' '.join(robot_argv(robot))}) ...", quiet)
    workload = make_workload(robot, trajectories=settings["trajectories"], steps=settings["steps"])
    planar = C.planar_workload(settings["planar_steps"])
    problems = C.workload_problems(workload)
    peer_set = load_peers(workload, names)
    cases = _cases(robot, workload, planar, problems, peer_set, settings)
    _say(f"lpik bench: agreement checks ({len(peer_set.steps)} peer steps) ...", quiet)
    checks = agreement_checks(workload, problems, peer_set, C.batch_arrays(problems, len(problems)))
    _say(f"lpik bench: timing {len(cases)} cases, {settings['rounds']} rounds ...", quiet)
    samples = time_cases(cases, settings["rounds"], max_calls=settings["calls"])
    _say("lpik bench: first calls in fresh processes ...", quiet)
    loaded = sorted({p.library for p in peer_set.steps}, key=names.index)
    firsts = first_call_records(robot, loaded, cold)
    load_after = os.getloadavg()
    records = [environment(command, workload, settings, (load_before, load_after))]
    records += _timing_records(cases, samples, workload.name)
    records += firsts
    records += [a.record() for a in checks]
    records += [
        Record(s.library, "", "skipped", kind="skipped", extra={"note": s.reason})
        for s in peer_set.skipped
    ]
    return records


def _settings(quick: bool, rounds: int | None) -> dict:
    """The run's settings: :data:`QUICK` or :data:`FULL`, with ``rounds`` when given."""
    settings = dict(QUICK if quick else FULL)
    if rounds is not None:
        if rounds < 1:
            raise ValueError(f"rounds: must be >= 1, got {rounds}")
        settings["rounds"] = rounds
    return settings


def _peer_names(peers: Sequence[str] | None) -> tuple[str, ...]:
    """The peers to try (default all of :data:`ADAPTERS`); ``ValueError`` for an unknown one."""
    names = tuple(ADAPTERS) if peers is None else tuple(peers)
    unknown = [p for p in names if p not in ADAPTERS]
    if unknown:
        raise ValueError(f"peers: unknown {', '.join(unknown)}; available: {', '.join(ADAPTERS)}")
    return names


def _cases(
    robot: str | ArmFile,
    workload: Workload,
    planar: C.PlanarWorkload,
    problems: list[Any],
    peer_set: PeerSet,
    settings: dict,
) -> list[C.Case]:
    """Every timed case: lpik's steps (singular ones too, on the Panda), the peers', the rest."""
    singular = singular_workload(settings["singular_bases"]) if robot == "panda" else None
    return [
        *C.step_cases(workload, planar),
        *(singular_cases(singular) if singular is not None else []),
        *C.peer_cases(peer_set.steps, workload),
        *C.fk_cases(workload),
        *C.solve_cases(workload, problems),
        C.batch_case(problems, settings["batch"]),
        C.reference_case(),
    ]


def _timing_records(cases: Sequence[C.Case], samples: dict, robot: str) -> list[Record]:
    """One timing record per case, with its ratio to the fastest peer's median full step.

    ``robot`` is the arm's name, for the records' ``robot`` key.
    """
    medians = {}
    timing = []
    for case in cases:
        stats = steady_and_cold(samples[case.label], case.per_call)
        median, p99 = stats.pop("median_us"), stats.pop("p99_us")
        medians[case.label] = median
        extra = {
            "samples": int(samples[case.label][:, 1:].size),
            **stats,
            "robot": "planar-4" if case.what == C.PLANAR_STEP else robot,
            "steps_per_s": 1e6 / median if median > 0 else None,
            "note": case.note,
            **case.extra,
        }
        timing.append(
            (case, Record(case.library, case.method, case.what, median, p99, extra=extra))
        )
    ratios = ratios_to_fastest_peer(medians, [c.label for c in cases if c.peer])
    for case, record in timing:
        record.extra.setdefault("ratio_to_fastest_peer", ratios.get(case.label))
    return [record for _, record in timing]
