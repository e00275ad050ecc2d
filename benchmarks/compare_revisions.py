"""The compiled step of two revisions of lpik, timed interleaved on one machine.

Usage::

    python benchmarks/compare_revisions.py --old REV [--rounds 8] [--steps 3000]

The old revision is checked out (``git worktree``) beside this tree; each
round times the same workloads in a fresh process of each revision, in turn
(old, new, new, old, ...), so that drift of the machine's speed hits both
alike. A worker puts its tree's ``src`` first on ``sys.path``, builds the
controllers, steps each workload once to compile (numba's cache is per tree),
then times every step of a fixed set of random states (same seed on both
sides). The table of median, p99, p99.9 and max per revision goes to
``docs/step-speed.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "step-speed.md"

#: What each worker times: (name, robot, controller keywords, call). The same
#: behaviour on both sides: the stall stage (on by default since decision 3 of the
#: motion issue) is off, so the rows time the pipeline; its own cost is in
#: docs/benchmarks.md ("Progress step") and docs/quality.md.
WORKLOADS = (
    ("Panda step +acc", "panda", {"qdd_max": 10.0, "on_stall": None}, "step"),
    # the step through dq = 0, as before the continuation form (issue 23): the pipeline
    # like against like; an old revision without the keyword takes that step anyway
    (
        "Panda step +acc, continuation off",
        "panda",
        {"qdd_max": 10.0, "on_stall": None, "continuation": False},
        "step",
    ),
    ("Panda step", "panda", {"on_stall": None}, "step"),
    ("Panda step_into +acc", "panda", {"qdd_max": 10.0, "on_stall": None}, "step_into"),
    ("planar 4-link step", "planar", {"on_stall": None}, "step"),
)

WORKER = r"""
import inspect, json, sys, time
sys.path.insert(0, sys.argv[1] + "/src")
import numpy as np
from lpik.control.controller import Lp2Controller
from lpik.robots.planar import planar_arm
from lpik.robots.registry import load_robot

workloads, steps = json.loads(sys.argv[2]), int(sys.argv[3])
out = {}
for name, robot, options, call in workloads:
    if robot == "planar":
        model = planar_arm([1.0] * 4, q_min=[-np.pi] * 4, q_max=[np.pi] * 4, qd_max=1.0)
    else:
        model = load_robot(robot)
    known = inspect.signature(Lp2Controller).parameters  # an older revision's keywords
    c = Lp2Controller(model, dt=0.001, **{k: v for k, v in options.items() if k in known})
    rng = np.random.default_rng(7)
    n = model.n_joints
    lo, hi = np.maximum(model.q_min, -3.0), np.minimum(model.q_max, 3.0)
    Q0 = lo + (hi - lo) * (0.05 + 0.9 * rng.random((steps, n)))
    QP = Q0 - 0.001 * rng.uniform(-0.5, 0.5, (steps, n)) * np.minimum(model.qd_max, 2.0)
    targets = []
    for q in Q0:
        pose = np.array(model.pose(q), dtype=float)
        shift = rng.normal(size=3)
        shift *= 0.05 / np.linalg.norm(shift)
        if pose.shape == (4, 4):
            pose[:3, 3] += shift
        else:  # the planar arm: xy, with z = 0
            pose = np.r_[pose[:2] + shift[:2], 0.0]
        targets.append(np.ascontiguousarray(pose))
    buf = np.empty(n)
    def one(k):
        if call == "step":
            c.step(Q0[k], targets[k], QP[k])
        else:
            c.step_into(Q0[k], targets[k], QP[k], out=buf)
    for k in range(min(steps, 300)):  # compile, warm the caches
        one(k)
    times = np.empty(steps)
    for k in range(steps):
        t0 = time.perf_counter_ns()
        one(k)
        times[k] = time.perf_counter_ns() - t0
    out[name] = (times / 1000.0).tolist()
print(json.dumps(out))
"""


def _worktree(rev: str) -> Path:
    path = Path(tempfile.gettempdir()) / f"lpik-rev-{rev}"
    if not path.exists():
        subprocess.run(["git", "worktree", "add", "--detach", str(path), rev], cwd=ROOT,
                       check=True, capture_output=True)  # fmt: skip
    return path


def _run(tree: Path, steps: int) -> dict[str, list[float]]:
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "0", "LPIK_COMPILE": "now"}
    done = subprocess.run(
        [sys.executable, "-c", WORKER, str(tree), json.dumps(WORKLOADS), str(steps)],
        capture_output=True, text=True, check=True, env=env, cwd=tree,
    )  # fmt: skip
    return json.loads(done.stdout.strip().splitlines()[-1])


def _row(times: list[float]) -> str:
    t = np.asarray(times)
    q = np.percentile(t, [50, 99, 99.9])
    return f"{q[0]:.2f} | {q[1]:.2f} | {q[2]:.2f} | {t.max():.1f} | {t.size}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", required=True, help="the revision to compare against")
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--steps", type=int, default=3000)
    args = parser.parse_args()
    old = _worktree(args.old)
    new_rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                             capture_output=True, check=True).stdout.strip()  # fmt: skip
    sides = {"old": old, "new": ROOT}
    for tree in sides.values():  # compile both once (numba's cache is per tree)
        _run(tree, 50)
    times: dict[str, dict[str, list[float]]] = {s: {w[0]: [] for w in WORKLOADS} for s in sides}
    for r in range(args.rounds):
        order = ("old", "new") if r % 2 == 0 else ("new", "old")
        for side in order:
            for name, values in _run(sides[side], args.steps).items():
                times[side][name].extend(values)
        print(f"round {r + 1}/{args.rounds} done", file=sys.stderr)
    lines = [
        "# The compiled step, old against new",
        "",
        "<!-- Generated by benchmarks/compare_revisions.py; do not edit by hand. -->",
        "",
        f"- **Command:** `python benchmarks/compare_revisions.py --old {args.old} "
        f"--rounds {args.rounds} --steps {args.steps}`",
        f"- **Date:** {datetime.now(timezone.utc).isoformat(timespec='seconds')}",
        f"- **Machine:** {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
        f"{platform.platform()}; Python {platform.python_version()}",
        f"- **Revisions:** old `{args.old}`, new `{new_rev}` (with the working tree's changes)",
        "- Each round runs every workload in a fresh process of each revision, the order "
        "alternating; times are per call of `Lp2Controller.step` (or `step_into`) on random "
        "states (joint velocities up to half the limit, targets 5 cm away), after 300 calls "
        "of warm-up; the stall stage off on both sides (`on_stall=None`): the pipeline, "
        "not decision 3's stage, whose cost docs/benchmarks.md gives.",
        "",
        "| workload | revision | median [us] | p99 [us] | p99.9 [us] | max [us] | n |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, *_ in WORKLOADS:
        for side in sides:
            lines.append(f"| {name} | {side} | {_row(times[side][name])} |")
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
