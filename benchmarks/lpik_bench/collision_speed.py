"""The time of one fused Panda step with self-collision and 10 obstacles.

    python -m lpik_bench.collision_speed [--runs N] [--steps N] [--json]

The Panda reaches from its home configuration into a shelf among 10
obstacles (``benchmarks/scenes/panda-shelf-10.json``: the shelf scene of
``lpik/data/scenes/panda-shelf.json`` with a sphere, a capsule and a turned box
added; ``d_s`` 0.02 m, ``d_i`` 0.15 m), with self-collision between
non-neighbouring links: 7 moving capsules against 10 obstacles and 16
self-collision pairs, 86 rows. Each variant runs the same reach ``--runs``
times from home for ``--steps`` steps of 10 ms and times every step; the first
run only warms up. Variants:

* ``Lp2Controller.step, no obstacles``: the fused step alone, the reference;
* ``AvoidingLp2Controller.step``: distances, rows and LP2 in one compiled call
  (:mod:`lpik.fast.avoiding_step`), and its ``step_into`` (no Result);
* ``AvoidingLp2Controller.step, qdd_max=10, q_prev``: under acceleration limits,
  in a loop that passes ``q_prev``: the damper's stops ahead of ``d_i``
  (:func:`lpik.collision.avoidance.braking_row`) measure the pairs within
  ``d_i`` plus how far each capsule may need to brake;
* ``AvoidingLp2Controller.step, lambda_bound=None``: without the automatic
  multiplier bound (:mod:`lpik.methods.autobound`), which on a step with
  ``p < 1`` looks for a bound inside the compiled step and may solve LP2 again;
* ``AvoidingLp2Controller.step, coal``: ``compiled_distances=False``, the
  distances through coal in Python and the rows written in before the
  compiled step (the path before the compiled distance kernels);
* ``Lp2Controller.step, field`` (``both``: the paper's potential field
  with the rows; ``field``: the field alone, rows only inside ``d_s``): the
  pairs' repulsion summed in the same compiled call and added to the criterion
  at its share of the step's room (:func:`lpik.fast.step.field_in_state`);
  ``qdd_max=10`` in a loop that passes ``q_prev`` (the room of the acceleration
  bands around the motion);
* ``Lp2Controller.step, field (both, coal)``: the field with the rows through
  coal in Python, its share read off the numpy engine's problem for the step
  (``compiled_distances=False``, the only path for the field before it was compiled).

Every variant reaches the target; the compiled and coal paths give the same
steps (tests hold them equal to 1e-9).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path
from typing import Any

import numpy as np

from lpik.collision import collision_avoidance, load_scene
from lpik.control.avoiding_controller import AvoidingLp2Controller
from lpik.control.controller import Lp2Controller
from lpik.paper.collision_runs import SHELF_TARGET
from lpik.paper.reach import reach_setup

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "panda-shelf-10.json"


def timed(step: Any, q0: np.ndarray, target: np.ndarray, runs: int, steps: int) -> dict:
    """Per-step times [us] of ``runs`` reaches (the first a warm-up) and the last end point."""
    times, q = [], q0
    for run in range(runs + 1):
        q = q0.copy()
        if hasattr(step, "restart"):  # a loop that remembers its last state
            step.restart()
        for _ in range(steps):
            start = time.perf_counter()
            q = step(q, target)
            if run:
                times.append(time.perf_counter() - start)
    us = np.array(times) * 1e6
    return {
        "median_us": float(np.median(us)),
        "p99_us": float(np.percentile(us, 99)),
        "max_us": float(us.max()),
        "steps": int(us.size),
        "q_end": q,
    }


class LoopStep:
    """``controller.step(q, target, q_prev)`` in a loop fed its commands (q_prev: the last q)."""

    def __init__(self, controller: Lp2Controller) -> None:
        self.controller, self.prev = controller, None

    def restart(self) -> None:
        """A new reach: from rest, the controller's memory of the last step forgotten."""
        self.prev = None
        self.controller.reset()

    def __call__(self, q: np.ndarray, target: np.ndarray) -> np.ndarray:
        answer = self.controller.step(q, target, q if self.prev is None else self.prev).q
        self.prev = q
        return answer


def _stepping(controller: Lp2Controller) -> Any:
    """``controller.step(q, target).q``, at rest each step."""
    return lambda q, target: controller.step(q, target).q


def run(runs: int, steps: int) -> dict:
    """Every variant, with the machine's load before and after."""
    setup = reach_setup("panda", SHELF_TARGET)
    scene = load_scene(SCENE)
    target = np.asarray(setup.target, dtype=np.float64)
    plain = Lp2Controller(setup.model, dt=setup.dt)
    fused = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt)
    unbounded = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt,
                                      lambda_bound=None)  # fmt: skip
    coal = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt,
                                 compiled_distances=False)  # fmt: skip
    braking = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt, qdd_max=10.0)
    out = np.zeros(setup.model.n_joints)

    def field(mechanism: str, qdd_max: float | None = None, **options: Any) -> Lp2Controller:
        avoid = collision_avoidance(setup.model, scene, setup.q0, mechanism=mechanism)
        return Lp2Controller(setup.model, dt=setup.dt, qdd_max=qdd_max, scene=avoid, **options)

    def into(q: np.ndarray, target: np.ndarray) -> np.ndarray:
        fused.step_into(q, target, out=out)
        return out.copy()

    load_before = os.getloadavg()
    variants = {
        "Lp2Controller.step, no obstacles": lambda q, t: plain.step(q, t).q,
        "AvoidingLp2Controller.step": lambda q, t: fused.step(q, t).q,
        "AvoidingLp2Controller.step_into": into,
        "AvoidingLp2Controller.step, qdd_max=10, q_prev": LoopStep(braking),
        "AvoidingLp2Controller.step, lambda_bound=None": lambda q, t: unbounded.step(q, t).q,
        "AvoidingLp2Controller.step, coal": lambda q, t: coal.step(q, t).q,
        "Lp2Controller.step, field (both)": _stepping(field("both")),
        "Lp2Controller.step, field (both), qdd_max=10, q_prev": LoopStep(field("both", 10.0)),
        "Lp2Controller.step, field (field alone), qdd_max=10, q_prev": LoopStep(
            field("field", 10.0)
        ),
        "Lp2Controller.step, field (both, coal)": _stepping(
            field("both", compiled_distances=False)
        ),
        "Lp2Controller.step, field (both, coal), qdd_max=10, q_prev": LoopStep(
            field("both", 10.0, compiled_distances=False)
        ),
    }
    rows = []
    for name, step in variants.items():
        result = timed(step, setup.q0, target, runs if "coal" not in name else 1, steps)
        tool = setup.model.kinematics.fk(result.pop("q_end"))[:3, 3]
        result["tool_error_m"] = float(np.linalg.norm(tool - np.asarray(SHELF_TARGET)))
        rows.append({"variant": name, **result})
    return {
        "pairs": len(fused.pair_labels),
        "obstacles": len(scene.obstacles),
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
        "loadavg_before": [round(v, 2) for v in load_before],
        "loadavg_after": [round(v, 2) for v in os.getloadavg()],
        "rows": rows,
    }


def main(argv: list[str] | None = None) -> int:
    """Print the table (markdown) or JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    report = run(args.runs, args.steps)
    if args.json:
        print(json.dumps(report, indent=1))
        return 0
    print(f"{report['obstacles']} obstacles, {report['pairs']} pairs; load average before "
          f"{report['loadavg_before']}, after {report['loadavg_after']}\n")  # fmt: skip
    print("| variant | median [us] | p99 [us] | max [us] | steps | tool error at the end [m] |")
    print("|---|---:|---:|---:|---:|---:|")
    for r in report["rows"]:
        print(f"| {r['variant']} | {r['median_us']:.2f} | {r['p99_us']:.2f} | "
              f"{r['max_us']:.1f} | {r['steps']} | {r['tool_error_m']:.1e} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
