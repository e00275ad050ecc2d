"""The soak: a long random walk of targets with acceleration limits, every step checked.

A Panda (pose task, dt = 1 ms, the URDF's end-stops and velocity limits,
``qdd_max`` on every joint) follows a target that wanders in small steps, jumps
now and then (also out of reach) and turns; now and then the measured state
jumps past an end-stop (an encoder glitch, a manual jog). Each step's answer is
checked here, independently of lpik's own check:

- acceleration: ``|dq - last| <= qdd_max dt^2`` on every step, whatever the state;
- end-stops and velocity limits: on every step from a state within its limits;
  a step from outside (status ``recovering``) never moves a joint further out
  unless it brakes at its acceleration limit;
- no NaN or inf in ``q`` or ``p``; ``p`` in [0, 1];
- memory: the resident set size after the first 1,000 steps and at each quarter of the run.

Three paths run the walk: the compiled controller (``Lp2Controller``), the numpy
engine (:class:`lpik.control.stepper.Stepper`: the same stages, what a controller
runs without numba or while it compiles) and the bare numpy layers
(``build_problem`` and the paper's LP2, no stage around them).

Run it from the repository root (``--write`` puts the results into
``docs/reliability.md``, between its soak markers)::

    python -m lpik_bench.soak --steps 1000000 --engine-steps 100000 --numpy-steps 100000 \
        --write docs/reliability.md
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lpik.command import ClampedTarget
from lpik.limits import AccelerationLimits, build_problem, standard_limits
from lpik.methods.lp2 import lp2
from lpik.result import RECOVERING
from lpik.robots.registry import home_configuration, load_robot
from lpik.robots.rotations import exp_so3
from lpik.types import FloatArray

#: Control period [s] and acceleration limit [rad/s^2] of the soak.
DT, QDD_MAX = 1e-3, 10.0
#: Tolerances of the soak's own checks (absolute, in rad per step or rad).
STEP_TOL, STOP_TOL = 1e-12, 1e-9
#: The Panda's shoulder (joint 2) in its base frame [m]; targets wander around it.
SHOULDER = np.array([0.0, 0.0, 0.333])
#: Steps after which the soak's start RSS is taken (the kernels are loaded by then).
WARM_UP = 1000
#: Markers of the generated block in docs/reliability.md.
BEGIN, END = "<!-- soak:begin -->", "<!-- soak:end -->"


def rss_mib() -> float:
    """The process's resident set size now [MiB] (its peak where /proc is missing)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


@dataclass
class SoakReport:
    """What a soak counted; every count of a broken contract should be 0."""

    path: str
    steps: int = 0
    acceleration_violations: int = 0
    worst_acceleration_ratio: float = 0.0
    end_stop_violations: int = 0
    velocity_violations: int = 0
    further_out: int = 0
    non_finite: int = 0
    p_outside_unit: int = 0
    #: Among obstacles (:mod:`lpik_bench.closed_loops`): steps from at or above the
    #: safety distance to below it (beyond the rows' second-order rounding).
    below_safety: int = 0
    #: Among obstacles: steps from outside the safety distance whose closest pair came
    #: nearer than the damper's row allows, beyond the rows' second-order rounding. Under
    #: acceleration limits a pair brakes ahead of ``d_i`` for its row
    #: (:func:`lpik.collision.avoidance.braking_row`); a row still yields to them where they
    #: cannot slow the pair in time (:func:`lpik.collision.recovery.stop_within_rows`).
    past_damper: int = 0
    glitches: int = 0
    statuses: dict[str, int] = field(default_factory=dict)
    p_zero_steps: int = 0
    longest_p_zero_run: int = 0
    step_times: list[float] = field(default_factory=list)
    rss_trace_mib: list[float] = field(default_factory=list)
    wall_s: float = 0.0

    def broken(self) -> int:
        """How many checks failed (0 for a sound run)."""
        return (self.acceleration_violations + self.end_stop_violations
                + self.velocity_violations + self.further_out + self.non_finite
                + self.p_outside_unit + self.below_safety)  # fmt: skip


class Walk:
    """The random target: small steps, occasional jumps (some out of reach), turns.

    It stays within ``radius`` of ``center`` (the Panda's shoulder and 0.9 m, a
    little beyond its reach, by default).
    """

    def __init__(
        self, start: FloatArray, rng: np.random.Generator, center: FloatArray = SHOULDER,
        radius: float = 0.9,
    ) -> None:  # fmt: skip
        self.pose = start.copy()
        self.rng = rng
        self.center, self.radius = np.asarray(center, dtype=np.float64), float(radius)

    def next(self) -> FloatArray:
        """The target for the next step."""
        rng, pose = self.rng, self.pose
        pose[:3, 3] += rng.normal(0.0, 2e-4, 3)
        if rng.random() < 2e-3:  # a jump of about 20 cm
            pose[:3, 3] += rng.normal(0.0, 0.2, 3)
        reach = pose[:3, 3] - self.center  # keep it within the radius (the Panda's reach ~0.85)
        scale = min(1.0, self.radius / max(1e-9, float(np.linalg.norm(reach))))
        pose[:3, 3] = self.center + reach * scale
        turn = rng.normal(0.0, 3e-4, 3) if rng.random() > 1e-3 else rng.normal(0.0, 0.5, 3)
        pose[:3, :3] = exp_so3(turn) @ pose[:3, :3]
        u, _, vt = np.linalg.svd(pose[:3, :3])  # keep it a rotation over a million turns
        pose[:3, :3] = u @ vt
        return pose


def past_stops(model, q):  # type: ignore[no-untyped-def]
    """How far each joint of ``q`` is past its end-stops [rad] (0 within them)."""
    return np.maximum(q - model.q_max, 0) + np.maximum(model.q_min - q, 0)


def tally(report: SoakReport, result, run_length: int) -> int:  # type: ignore[no-untyped-def]
    """Count the step's status and ``p = 0``; returns the run of ``p = 0`` steps it ends or
    lengthens."""
    report.statuses[result.status] = report.statuses.get(result.status, 0) + 1
    run_length = run_length + 1 if result.p == 0.0 else 0
    report.p_zero_steps += result.p == 0.0
    report.longest_p_zero_run = max(report.longest_p_zero_run, run_length)
    return run_length


def check_step(  # type: ignore[no-untyped-def]
    report: SoakReport, model, q0, q_prev, q, p, status, qdd_max: float | None = QDD_MAX
) -> None:
    """Count what the step from ``q0`` to ``q`` breaks (the checks of the module docstring).

    ``qdd_max`` None: no acceleration limits. Where ``q_prev`` implies a speed above
    the velocity limits (a bad sample: no motion the drives can make), the
    acceleration against it is not checked; the rest is.
    """
    dq, last = q - q0, q0 - q_prev
    if not (np.isfinite(q).all() and np.isfinite(p)):
        report.non_finite += 1
        return
    report.p_outside_unit += not (0.0 <= p <= 1.0)
    decel = np.inf if qdd_max is None else qdd_max * DT * DT
    if not (np.abs(last) > model.qd_max * DT * (1.0 + 1e-9)).any():
        excess = np.abs(dq - last) / decel
        report.acceleration_violations += bool((np.abs(dq - last) > decel + STEP_TOL).any())
        report.worst_acceleration_ratio = max(report.worst_acceleration_ratio, float(excess.max()))
    past_before, past_after = past_stops(model, q0), past_stops(model, q)
    if status == RECOVERING:
        braking = np.abs(dq - last) >= decel - STEP_TOL
        report.further_out += bool(((past_after > past_before + STOP_TOL) & ~braking).any())
    else:
        report.end_stop_violations += bool((past_after > STOP_TOL).any())
        report.velocity_violations += bool((np.abs(dq) > model.qd_max * DT + STEP_TOL).any())


def check_measured_step(  # type: ignore[no-untyped-def]
    report: SoakReport, model, reading, answered, q, p, status, qdd_max: float
) -> None:
    """Count what a step of a loop closed on measured joints breaks.

    The contract of such a loop (docs/concepts.md): no command further past an
    end-stop than its ``reading``; every step within the velocity limits; each
    step that is not a recovery within twice the acceleration limits' share of a
    period of the step ``answered`` before it (None on the first step: nothing
    to check against); no NaN; ``p`` in [0, 1].
    """
    if not (np.isfinite(q).all() and np.isfinite(p)):
        report.non_finite += 1
        return
    report.p_outside_unit += not (0.0 <= p <= 1.0)
    step = q - reading
    report.end_stop_violations += bool(
        (past_stops(model, q) > past_stops(model, reading) + STOP_TOL).any()
    )
    report.velocity_violations += bool((np.abs(step) > model.qd_max * DT + STEP_TOL).any())
    if answered is None or status == RECOVERING:
        return
    band = 2.0 * qdd_max * DT * DT
    excess = np.abs(step - answered) / band
    report.acceleration_violations += bool((np.abs(step - answered) > band + STEP_TOL).any())
    report.worst_acceleration_ratio = max(report.worst_acceleration_ratio, float(excess.max()))


def soak(
    steps: int, *, path: str = "compiled", seed: int = 0, glitch_every: int = 50_000
) -> SoakReport:
    """Run the soak for ``steps`` control steps on one path: ``"compiled"``,
    ``"numpy engine"`` or ``"numpy"`` (the bare layers).

    ``rss_trace_mib`` is taken after the first :data:`WARM_UP` steps (once the kernels
    are compiled or loaded), then at each quarter of the run and at its end.
    """
    model = load_robot("panda")
    rng = np.random.default_rng(seed)
    q = home_configuration("panda")
    q_prev = q.copy()
    walk = Walk(model.pose(q), rng)
    report = SoakReport(path=path)
    if path == "compiled":
        from lpik.control.controller import Lp2Controller

        controller = Lp2Controller(model, dt=DT, qdd_max=QDD_MAX)

        def step(q0, target, prev):  # type: ignore[no-untyped-def]
            return controller.step(q0, target, prev)
    elif path == "numpy engine":
        from lpik.control.stepper import Stepper

        stepper = Stepper(model, dt=DT, qdd_max=QDD_MAX)

        def step(q0, target, prev):  # type: ignore[no-untyped-def]
            return stepper.step(q0, target, prev)
    else:
        limits = [*standard_limits(model), AccelerationLimits(np.full(model.n_joints, QDD_MAX))]

        def step(q0, target, prev):  # type: ignore[no-untyped-def]
            dw = ClampedTarget(target)(model, q0, DT)
            problem = build_problem(model.jacobian(q0), dw, q0, limits, dt=DT, q_prev=prev,
                                    joint_names=model.joint_names)  # fmt: skip
            return lp2(problem)

    times = np.full(steps, np.nan)  # written now, so its pages count in the start RSS
    run = 0
    start = time.perf_counter()
    for k in range(steps):
        if k == min(WARM_UP, steps - 1) or (k and k % max(1, steps // 4) == 0):
            report.rss_trace_mib.append(rss_mib())
        if glitch_every and k and k % glitch_every == 0:  # a joint measured past its end-stop
            joint = int(rng.integers(model.n_joints))
            side = model.q_max if rng.random() < 0.5 else model.q_min
            sign = 1.0 if side is model.q_max else -1.0
            q = q.copy()
            q[joint] = side[joint] + sign * rng.uniform(0.0, 0.1)
            q_prev = q.copy()
            report.glitches += 1
        target = walk.next()
        t0 = time.perf_counter()
        result = step(q, target, q_prev)
        times[k] = time.perf_counter() - t0
        run = tally(report, result, run)
        check_step(report, model, q, q_prev, result.q, result.p, result.status)
        q_prev, q = q, np.array(result.q, dtype=np.float64)
    report.wall_s = time.perf_counter() - start
    report.steps = steps
    report.step_times = [float(np.median(times)), float(np.percentile(times, 99)),
                         float(times.max())]  # fmt: skip
    report.rss_trace_mib.append(rss_mib())
    return report


def render(reports: list[SoakReport], command: str) -> str:
    """The Markdown block for docs/reliability.md."""
    rows = [
        "| path | steps | acceleration violations (worst, x limit) | end-stop / velocity "
        "violations | further out while recovering | NaN | p outside [0, 1] | glitches | "
        "recovering steps | infeasible (safe stop) steps | p = 0 steps (longest run) | "
        "step time median / p99 / max [us] | RSS after 1,000 steps, at each quarter [MiB] |",
        "|" + "---|" * 13,
    ]
    for r in reports:
        med, p99, worst = (1e6 * t for t in r.step_times)
        rows.append(
            f"| {r.path} | {r.steps:,} | {r.acceleration_violations} "
            f"({r.worst_acceleration_ratio:.6f}) | {r.end_stop_violations} / "
            f"{r.velocity_violations} | {r.further_out} | {r.non_finite} | {r.p_outside_unit} | "
            f"{r.glitches} | {r.statuses.get('recovering', 0):,} | "
            f"{r.statuses.get('infeasible', 0):,} | {r.p_zero_steps:,} "
            f"({r.longest_p_zero_run:,}) | {med:.1f} / {p99:.1f} / {worst:.0f} | "
            f"{' / '.join(f'{v:.0f}' for v in r.rss_trace_mib)} |"
        )
    machine = f"{platform.machine()}, Python {platform.python_version()}, {platform.system()}"
    return "\n".join([BEGIN, "", f"Produced by `{command}` ({machine}).", "", *rows, "", END])


def write_block(doc: Path, block: str, begin: str = BEGIN, end: str = END) -> None:
    """Replace the block between the markers ``begin`` and ``end`` (the soak's) of ``doc``."""
    text = doc.read_text(encoding="utf-8")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    doc.write_text(head + block + tail, encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    """Command line: run the soak on its paths and print (or write) the results."""
    parser = argparse.ArgumentParser(prog="python -m lpik_bench.soak", description=__doc__)
    parser.add_argument("--steps", type=int, default=1_000_000, help="compiled steps")
    parser.add_argument(
        "--engine-steps", type=int, default=100_000, help="numpy engine steps (the Stepper)"
    )
    parser.add_argument("--numpy-steps", type=int, default=100_000, help="numpy-layer steps")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--write", type=Path, help="the Markdown file with the soak markers")
    args = parser.parse_args(argv)
    reports = [soak(args.steps, path="compiled", seed=args.seed)]
    if args.engine_steps:
        reports.append(soak(args.engine_steps, path="numpy engine", seed=args.seed))
    if args.numpy_steps:
        reports.append(soak(args.numpy_steps, path="numpy", seed=args.seed))
    command = "python -m lpik_bench.soak " + " ".join(sys.argv[1:] if argv is None else argv)
    block = render(reports, command.strip())
    print(block)
    if args.write is not None:
        write_block(args.write, block)
    return 1 if any(r.broken() for r in reports) else 0


if __name__ == "__main__":
    sys.exit(main())
