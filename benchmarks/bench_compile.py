"""Compile time of the compiled path: the first run on an empty numba cache, and where it goes.

Usage::

    python benchmarks/bench_compile.py [--old REV] [--top 15]

Each workload runs in a fresh process with an empty ``NUMBA_CACHE_DIR`` (cold:
everything it calls is compiled), then again on the cache that run filled
(warm: everything is loaded). The wall and CPU seconds are those of the whole
process (interpreter, imports, setup, the run). With ``--old REV`` the same
runs are made for that revision too (checked out beside this tree, as
``compare_revisions.py`` does), old and new in turn. The first workload's cold
compile is broken down by compiled function (numba's event API): the CPU
seconds of each function's own compile, without the functions it compiles on
the way. The section "Compile time" of ``docs/benchmarks.md`` is rewritten; the
page's other sections stay as they are.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

from compare_revisions import _worktree
from lpik_bench.markdown import replace_section

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "benchmarks.md"
HEADING = "## Compile time (first run, empty cache)"

GETTING_STARTED = (
    "from lpik import Lp2Controller, load_robot, home_configuration\n"
    "panda = load_robot('panda', task='pose')\n"
    "controller = Lp2Controller(panda, dt=0.001, qdd_max=10.0)\n"
    "q = home_configuration('panda')\n"
    "goal = panda.pose(q)\n"
    "goal[:3, 3] += [0.05, 0.0, 0.0]\n"
    "result = controller.step(q, goal)\n"
)

#: The workloads: (name, Python run in the tree's root with its ``src`` first on the path,
#: ``LPIK_COMPILE`` for the run or None for the default). The first is broken down by
#: compiled function. With the default (``compile="background"``) a cold run steps on the
#: numpy engine while a child process compiles; the warm run waits for that child.
WORKLOADS = (
    ("getting started: 1 kHz loop (Panda, pose task), compile='now'", GETTING_STARTED, "now"),
    ("getting started: 1 kHz loop (Panda, pose task, defaults)", GETTING_STARTED, None),
    (
        "examples/own_urdf_1khz.py (4-joint URDF, position task, 2000 steps)",
        "import runpy, sys\n"
        "sys.path.insert(0, 'examples')\n"
        "runpy.run_path('examples/own_urdf_1khz.py', run_name='__main__')\n",
        None,
    ),
    (
        "lpik compile (every kernel)",
        "from lpik.cli.compile import compile_kernels\ncompile_kernels()\n",
        None,
    ),
    (
        "lpik compile --jobs 2 (every kernel, 2 processes)",
        "from lpik.cli.compile import compile_kernels\n"
        "if __name__ == '__main__':\n"
        "    compile_kernels(jobs=2)\n",
        None,
    ),
)

#: Run after each workload: the background compile's children (lpik.control.warmup), if any.
CHILDREN = r"""
try:
    from lpik.control import warmup as _warmup
    print("CHILDREN " + json.dumps([w.process.pid for w in _warmup._RUNNING.values()]))
except ImportError:  # a revision without it
    pass
"""

#: Run in the worker before the workload: per compiled function, the CPU seconds of
#: its own compile (numba's "numba:compile" events, nested ones taken off).
RECORDER = r"""
import json, time, atexit
from numba.core import event

class _Own(event.Listener):
    def __init__(self):
        self.stack, self.own = [], {}
    def on_start(self, ev):
        self.stack.append([time.process_time(), 0.0])
    def on_end(self, ev):
        start, inner = self.stack.pop()
        total = time.process_time() - start
        if self.stack:
            self.stack[-1][1] += total
        f = ev.data["dispatcher"].py_func
        name = f"{f.__module__.split('.')[-1]}.{f.__qualname__}"
        count, seconds = self.own.get(name, (0, 0.0))
        self.own[name] = (count + 1, seconds + total - inner)

_own = _Own()
event.register("numba:compile", _own)
atexit.register(lambda: print("RECORD " + json.dumps(_own.own), flush=True))
"""


def _run(tree: Path, code: str, cache: str, record: bool, mode: str | None) -> dict:
    """One process: wall and CPU seconds, and (``record``) the compile per function.

    ``background``: the seconds from the start until the background compile's children
    have exited too (None where there were none).
    """
    env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(tree / "src")}
    env.pop("LPIK_EXAMPLE_STEPS", None)
    env.pop("LPIK_COMPILE", None)
    if mode is not None:
        env["LPIK_COMPILE"] = mode
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    source = "import json\n" + (RECORDER if record else "") + code + CHILDREN
    done = subprocess.run([sys.executable, "-c", source], capture_output=True, text=True,
                          env=env, cwd=tree, check=True)  # fmt: skip
    wall = time.perf_counter() - start
    children = [pid for line in done.stdout.splitlines() if line.startswith("CHILDREN ")
                for pid in json.loads(line[len("CHILDREN ") :])]  # fmt: skip
    while any(Path(f"/proc/{pid}").exists() for pid in children):
        time.sleep(0.2)
    background = time.perf_counter() - start if children else None
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    own = {}
    for line in done.stdout.splitlines():
        if line.startswith("RECORD "):
            own = json.loads(line[len("RECORD ") :])
    return {"wall": wall, "cpu": cpu, "own": own, "background": background}


def _measure(sides: dict[str, Path]) -> dict:
    """Every workload cold then warm, on every side in turn."""
    results: dict = {}
    for k, (name, code, mode) in enumerate(WORKLOADS):
        for side, tree in sides.items():
            with tempfile.TemporaryDirectory(prefix="lpik-numba-cache-") as cache:
                cold = _run(tree, code, cache, record=k == 0, mode=mode)
                warm = _run(tree, code, cache, record=False, mode=mode)
            results[(name, side)] = {"cold": cold, "warm": warm}
            print(f"{name} [{side}]: cold {cold['wall']:.1f} s wall, {cold['cpu']:.1f} s CPU; "
                  f"warm {warm['wall']:.1f} s", file=sys.stderr)  # fmt: skip
    return results


def _load() -> str:
    return " / ".join(f"{x:.1f}" for x in os.getloadavg())


def _section(results: dict, sides: dict[str, Path], command: str, loads: tuple[str, str],
             top: int) -> str:  # fmt: skip
    """The page's section, in Markdown."""
    revs = {s: subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=t, text=True,
                              capture_output=True, check=True).stdout.strip()
            for s, t in sides.items()}  # fmt: skip
    lines = [
        HEADING, "",
        "<!-- Generated by benchmarks/bench_compile.py; do not edit by hand. -->", "",
        f"- **Command:** `{command}`",
        f"- **Date:** {datetime.now(timezone.utc).isoformat(timespec='seconds')}",
        f"- **Machine:** {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
        f"load average (1 / 5 / 15 min) {loads[0]} before, {loads[1]} after: numba compiles on "
        "one core, so on a shared machine the wall time stretches and the CPU time is the "
        "steadier figure",
        "- **Revisions:** " + ", ".join(f"{s} `{r}`" for s, r in revs.items())
        + " (new: with the working tree's changes)",
        "- Each run is a fresh process (interpreter, imports, setup, the run); cold: an empty "
        "`NUMBA_CACHE_DIR`, warm: the cache the cold run filled. By default a controller "
        "on a cold cache steps on the numpy engine while a child process compiles its "
        "kernels (`compile=\"background\"`, lpik.control.warmup): the cold columns are the "
        "run's own process; *background done* is when that child had filled the cache, "
        "from the run's start (the warm run starts after it).",
        "",
        "| workload | revision | cold wall [s] | cold CPU [s] | background done [s] "
        "| warm wall [s] | warm CPU [s] |",
        "|---|---|---|---|---|---|---|",
    ]  # fmt: skip
    for name, *_ in WORKLOADS:
        for side in sides:
            r = results[(name, side)]
            done = r["cold"]["background"]
            lines.append(f"| {name} | {side} | {r['cold']['wall']:.1f} | {r['cold']['cpu']:.1f} "
                         f"| {'–' if done is None else f'{done:.1f}'} "
                         f"| {r['warm']['wall']:.1f} | {r['warm']['cpu']:.1f} |")  # fmt: skip
    first = WORKLOADS[0][0]
    for side in sides:
        own = results[(first, side)]["cold"]["own"]
        total = sum(s for _, s in own.values())
        count = sum(c for c, _ in own.values())
        lines += ["", f"Where the cold compile of the first workload goes ({side}): {count} "
                  f"compiles of {len(own)} functions, {total:.1f} s of CPU; each function's own "
                  "compile (typing, lowering, LLVM), without the functions it compiles on the way:",
                  "", "| function | compiles | CPU [s] | share |", "|---|---|---|---|"]  # fmt: skip
        for fname, (c, s) in sorted(own.items(), key=lambda kv: -kv[1][1])[:top]:
            lines.append(f"| `{fname}` | {c} | {s:.2f} | {100 * s / max(total, 1e-9):.0f}% |")
    return "\n".join(lines) + "\n\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", help="a revision to measure too")
    parser.add_argument("--top", type=int, default=15, help="functions listed per revision")
    args = parser.parse_args()
    sides = {"new": ROOT} if args.old is None else {"old": _worktree(args.old), "new": ROOT}
    command = "python benchmarks/bench_compile.py" + (f" --old {args.old}" if args.old else "")
    command += f" --top {args.top}" if args.top != 15 else ""
    before = _load()
    results = _measure(sides)
    section = _section(results, sides, command, (before, _load()), args.top)
    page = OUT.read_text(encoding="utf-8")
    OUT.write_text(replace_section(page, HEADING, section), encoding="utf-8")
    print(f"wrote the section {HEADING[3:]!r} of {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
