"""The markdown summary of ``lpik reproduce``: every number in it is computed from the runs."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from lpik.control.log import RunMetrics, SimulationLog
from lpik.paper.runs import BOUND_MARGIN, FIGURES, BoundChoice
from lpik.paper.scenarios import get_scenario
from lpik.tolerances import FULL_P

#: Run name -> (method, multipliers) as shown in the table.
RUN_LABELS = {
    "pull-in-lp1": ("LP1, each step solved on its own", "none"),
    "pull-in-lp1-warm-start": ("LP1, HiGHS warm-started", "none"),
    "pull-in-lp2": ("LP2", "unbounded"),
    "pull-in-lp2s": ("LP2 with saturation in the null space", "unbounded"),
    "edge-singularity-lp2-unbounded": ("LP2", "unbounded"),
    "edge-singularity-lp2-bounded": ("LP2", "bounded"),
    "edge-singularity-lp2-auto": ("LP2", "automatic bound"),
}


def _xy(values: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in values) + ")"


def _num(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.4g}"


def runs_table(logs: Mapping[str, SimulationLog], bound: float) -> list[str]:
    """One row per run: jitter, max q1, final p, final position, max |lam|, solve times."""
    lines = [
        "| run | method | multipliers | jitter [rad/s] | max q1 [deg] | final p | "
        "final end effector [m] | max abs lambda | solve time median / p99 [us] |",
        "|---|---|---|---:|---:|---:|---|---:|---|",
    ]
    for name, log in logs.items():
        m = log.metrics()
        method, lam = RUN_LABELS.get(name, (log.method, ""))
        if lam == "bounded":
            lam = f"abs(lambda_i) <= {bound:g}"
        lines.append(
            f"| {name} | {method} | {lam} | {_num(m.jitter)} | "
            f"{np.rad2deg(m.max_q[0]):.3f} | {_num(m.final_p)} | {_xy(m.final_position)} | "
            f"{_num(m.max_abs_lambda)} | {m.median_solve_time * 1e6:.0f} / "
            f"{m.p99_solve_time * 1e6:.0f} |"
        )
    return lines


def _jumps(log: SimulationLog, threshold: float = 1.0) -> int:
    """Steps where the joint velocities change by more than ``threshold`` [rad/s] in all."""
    return int((np.abs(np.diff(log.joint_velocities(), axis=0)).sum(axis=1) > threshold).sum())


def _first(mask: np.ndarray) -> int | None:
    hits = np.nonzero(mask)[0]
    return int(hits[0]) if hits.size else None


def findings(logs: Mapping[str, SimulationLog]) -> list[str]:
    """What the runs show, sentence by sentence, with the computed numbers."""
    lp1, lp2, warm = logs["pull-in-lp1"], logs["pull-in-lp2"], logs["pull-in-lp1-warm-start"]
    free, bounded = logs["edge-singularity-lp2-unbounded"], logs["edge-singularity-lp2-bounded"]
    j1, j2, jw = lp1.jitter(), lp2.jitter(), warm.jitter()
    out = [
        f"- **LP1 follows the pull-in command but jitters.** p = 1 on "
        f"{int((lp1.p >= FULL_P).sum())} of {lp1.steps} steps; the end effector moves "
        f"from {_xy(lp1.position[0])} to {_xy(lp1.position_end)} m. Solving every step's LP on "
        f"its own, the joint velocities jump by more than 1 rad/s on {_jumps(lp1)} steps: "
        f"jitter {j1:.4g} rad/s (Figs. 3, 4a).",
        f"- **LP1's jitter depends on the solver's vertex choice.** LP1 has many optimal "
        f"vertices; with HiGHS warm-started across steps each solve stays on the previous "
        f"basis, the joints run at their velocity limits and wander (q2 up to "
        f"{np.rad2deg(warm.q[:, 1].max()):.0f} deg), with {_jumps(warm)} jump(s) of more than "
        f"1 rad/s: jitter {jw:.4g} rad/s (Fig. 4a').",
        f"- **LP2 is smooth.** Jitter {j2:.4g} rad/s: {j1 / j2:.3g} times below LP1's, "
        f"{jw / j2:.3g} times below warm-started LP1's (Fig. 4b). LP2's step is unique.",
    ]
    stop = _first(np.char.find(lp2.binding.astype(str), "joint 1 upper end-stop") >= 0)
    max_q1 = float(np.rad2deg(max(lp2.q[:, 0].max(), lp2.q_end[0])))
    if stop is not None:
        out.append(
            f"- **LP2 keeps joint 1 at its end-stop.** Max q1 = {max_q1:.4f} deg. From "
            f"t = {lp2.t[stop]:.2f} s the binding limit is the joint 1 upper end-stop, p falls "
            f"to {lp2.p[-1]:.3g} and the end effector stops at {_xy(lp2.position_end)} m "
            "(Figs. 5, 6). LP2's equality rows are the unconstrained optimality conditions "
            "of the criterion, so the other three joints do not take over the blocked "
            "joint's share."
        )
    sat = logs.get("pull-in-lp2s")
    if sat is not None:
        full = int((sat.p >= FULL_P).sum())
        sat_q1 = float(np.rad2deg(max(sat.q[:, 0].max(), sat.q_end[0])))
        out.append(
            f"- **Beyond the paper: saturation in the null space keeps p = 1.** Fixing a joint "
            f"at the bound that stops it and resolving the criterion over the others (method "
            f"lp2s), p = 1 on {full} of {sat.steps} steps; joint 1 stays at or below "
            f"{sat_q1:.4f} deg and the end effector is pulled in to {_xy(sat.position_end)} m "
            f"(LP2: {_xy(lp2.position_end)} m), with jitter {sat.jitter():.4g} rad/s (LP2: "
            f"{j2:.4g}; Fig. 10)."
        )
    lam = np.nanmax(np.abs(free.lam), axis=1)
    paths = ", ".join(f"{p}: {c}" for p, c in zip(*np.unique(free.path, return_counts=True)))
    velocity = int((np.char.find(free.binding.astype(str), "velocity limit") >= 0).sum())
    out.append(
        f"- **Unbounded multipliers grow and the joints jitter.** max abs(lambda_i) grows from "
        f"{lam[0]:.3g} at t = 0 to {lam.max():.4g} at t = {free.t[int(np.argmax(lam))]:.2f} s; "
        f"from there the arm chatters through the stretched configuration: jitter "
        f"{free.jitter():.4g} rad/s, a velocity limit binds on {velocity} of {free.steps} steps "
        f"(Fig. 8). LP2 paths: {paths}."
    )
    reach = float(np.linalg.norm(bounded.position_end))
    out.append(
        f"- **Bounded multipliers give smooth motion and p -> 0.** Jitter "
        f"{bounded.jitter():.4g} rad/s ({free.jitter() / bounded.jitter():.3g} times below the "
        f"unbounded run), final p = {bounded.p[-1]:.3g}, the end effector stops at "
        f"{_xy(bounded.position_end)} m, {reach:.4f} m from the base (Figs. 7, 9)."
    )
    return out


def summary_markdown(
    logs: Mapping[str, SimulationLog],
    choice: BoundChoice,
    sweep: Mapping[float, RunMetrics],
    *,
    version: str,
) -> str:
    """The ``summary.md`` of ``lpik reproduce``."""
    b = choice.bound
    edge = get_scenario("edge-singularity")
    step = edge.paper.v_max * edge.dt
    lines = [
        "# The paper's section 4, computed by `lpik reproduce`",
        "",
        f"lpik {version}. Planar 4-link arm (links 1 m), q0 = (60, -30, -30, -30) deg, "
        "joint velocity limit 1 rad/s, dt = 0.01 s, v_max = 0.5 m/s, M = I, f = 0, "
        "Lambda = 0. Every number below is computed from the runs.",
        "",
        "## Runs",
        "",
        *runs_table(logs, b),
        "",
        "Jitter: total variation of the joint velocities, sum over steps and joints of "
        "abs(qdot(k+1) - qdot(k)). Solve time: wall time of one step's method on the machine "
        "that ran `lpik reproduce`; the p99 is sensitive to other load on that machine.",
        "",
        "## What the computation shows",
        "",
        *findings(logs),
        "",
        "## The multiplier bound",
        "",
        f"B = {b:g} is derived from the unbounded edge-singularity run. With M = I the "
        "multipliers are lambda = -(J J^T)^-1 p dw and grow like 1/sigma_min(J)^2 as the arm "
        f"stretches. While the command was followed in full (p = 1, up to t = "
        f"{choice.free_until:.2f} s) max abs(lambda_i) stayed at or below "
        f"{choice.free_max:.3g}; it peaked at {choice.peak:.3g} (t = {choice.peak_time:.2f} s), "
        f"and in the chattering last quarter of the run its median was "
        f"{choice.late_median:.3g}. B is {BOUND_MARGIN:g} x {choice.free_max:.3g}, rounded up "
        f"to one significant digit: it never restricts the free motion, and it lies "
        f"{choice.late_median / b:.3g} times below the chattering level. Read as a "
        "manipulability threshold: abs(lambda) <= B lets a full step of length "
        f"abs(dw) = v_max dt = {step:g} m through whenever sigma_min(J)^2 >= abs(dw) / B = "
        f"{step / b:.3g} m^2/rad^2; closer to the singularity p shrinks like sigma_min^2.",
        "",
        "The same run with other bounds:",
        "",
        "| bound B | jitter [rad/s] | final p | final end effector [m] | max abs lambda |",
        "|---:|---:|---:|---|---:|",
        *(
            f"| {bound:g}{' (chosen)' if bound == b else ''} | {_num(m.jitter)} | "
            f"{_num(m.final_p)} | {_xy(m.final_position)} | {_num(m.max_abs_lambda)} |"
            for bound, m in sweep.items()
        ),
        "",
        "## Figures",
        "",
        "In the output directory of `lpik reproduce`, each with the CSV logs it is drawn from.",
        "",
        "| figure | file | data |",
        "|---|---|---|",
        *(
            f"| {what} | `{name}` | {', '.join(f'`{r}.csv`' for r in runs)} |"
            for name, (what, runs) in FIGURES.items()
        ),
        "",
    ]
    return "\n".join(lines)
