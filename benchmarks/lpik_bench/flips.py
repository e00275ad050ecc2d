"""Where one lpik variant changes its control law from step to step, and what that costs.

A step of the default controller is the exact step (status ``optimal``), the
progress step (``off_direction``) or the safe step (``infeasible``); where the
status changes from one step to the next the joint velocities may jump. On one
leg of a scenario of the quality suite (:mod:`lpik_bench.quality_scenarios`)
this reports how much of the leg's jitter (:func:`lpik_bench.quality_metrics.velocity_changes`)
falls on those steps, and on how many steps a joint's acceleration reverses at
more than half the suite's limit both times (the reversals of
:mod:`lpik_bench.random_goals`); ``--window`` lists the steps one by one (status,
``p``, binding limit, the joints' accelerations). From the repository root::

    PYTHONPATH=benchmarks .venv/bin/python -m lpik_bench.flips beyond-acc +y "lp2s +acc" \\
        --window 1000 1040

It writes nothing: it is for looking into a miss of ``docs/quality.md``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from lpik_bench.quality_metrics import LegRun, step_changes, velocity_changes
from lpik_bench.random_goals import REVERSAL_SHARE
from lpik_bench.workload import DT, QDD_MAX


@dataclass(frozen=True)
class LawChanges:
    """What the changes of law cost on one leg.

    Attributes:
        jitter: The leg's jitter [rad/s].
        at_changes: The part of it on steps whose status differs from the step before.
        changes: How many such steps.
        reversals: Steps on which some joint's acceleration changes sign, above
            ``REVERSAL_SHARE`` of the limit both times.
        steps: Steps of the leg.
    """

    jitter: float
    at_changes: float
    changes: int
    reversals: int
    steps: int


def law_changes(run: LegRun, dt: float = DT, qdd_max: float = QDD_MAX) -> LawChanges:
    """The jitter on the steps where ``run``'s status changes, and the acceleration reversals."""
    if run.status is None:
        raise ValueError("law_changes: the run has no statuses (an lpik variant's run has)")
    ddq = step_changes(run.q)[1]
    change = velocity_changes(ddq, dt)
    status = np.asarray(run.status)
    changed = np.zeros(status.size, dtype=bool)
    changed[1:] = status[1:] != status[:-1]
    big = np.abs(ddq) > REVERSAL_SHARE * qdd_max * dt * dt
    flipped = big[1:] & big[:-1] & (np.sign(ddq[1:]) != np.sign(ddq[:-1]))
    return LawChanges(
        jitter=float(change.sum()),
        at_changes=float(change[changed].sum()),
        changes=int(changed.sum()),
        reversals=int(flipped.any(axis=1).sum()),
        steps=int(status.size),
    )


def step_lines(run: LegRun, start: int, stop: int, dt: float = DT) -> list[str]:
    """One line per step in ``[start, stop)``: status, ``p``, binding, accelerations [rad/s^2]."""
    if run.status is None or run.p is None or run.binding is None:
        raise ValueError("step_lines: the run has no statuses (an lpik variant's run has)")
    ddq = step_changes(run.q)[1] / (dt * dt)
    lines = []
    for k in range(max(start, 0), min(stop, len(run.status))):
        accelerations = " ".join(f"{a:6.1f}" for a in ddq[k])
        lines.append(f"{k:6d} {run.status[k]:14s} p {run.p[k]:.4f} [{accelerations}] "
                     f"{run.binding[k]}")  # fmt: skip
    return lines


def main(argv: list[str] | None = None) -> int:
    from lpik.robots.registry import load_robot
    from lpik_bench.quality import VARIANTS, lpik_contenders, run_leg
    from lpik_bench.quality_scenarios import SCENARIOS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", choices=list(SCENARIOS))
    parser.add_argument("leg", help="the leg's label (a direction, a joint, a goal)")
    parser.add_argument("variant", choices=list(VARIANTS))
    parser.add_argument("--window", type=int, nargs=2, metavar=("START", "STOP"))
    args = parser.parse_args(argv)
    model = load_robot("panda", task="pose")
    scenario = SCENARIOS[args.scenario](model, DT, None)
    legs = {leg.label: leg for leg in scenario.legs}
    if args.leg not in legs:
        parser.error(f"leg: one of {', '.join(legs)}, got {args.leg!r}")
    contender = lpik_contenders(model, DT, (args.variant,))[0][0]
    run = run_leg(contender, legs[args.leg])
    c = law_changes(run)
    print(f"{args.variant}, {scenario.title}, leg {args.leg}: jitter {c.jitter:.1f} rad/s, "
          f"{c.at_changes:.1f} of it on the {c.changes:,} steps where the status changes; "
          f"reversals on {c.reversals:,} of {c.steps:,} steps")  # fmt: skip
    if args.window:
        print("\n".join(step_lines(run, *args.window)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
