"""docs/quality.md from a run of the motion-quality suite: every number and verdict generated.

One table per scenario (libraries as rows), lpik's ``p`` and binding limits,
the per-direction recoveries of the out-of-reach scenario, a line naming the
best library on each metric and the goal table: per metric, whether each lpik
variant is within :data:`MARGIN` of the best peer (strictly better on jitter,
a tie within :data:`TIE` counting as met, no violation at all); in the
acceleration-limited scenarios, the table of each variant with acceleration
limits against the peers with the same limits (:data:`AGAINST_LIMITED`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX
from lpik_bench.quality_metrics import (
    FROZEN_DQ,
    HIGH_HZ,
    KINDS,
    RECOVERY_WINDOW,
    SETTLE_TOL,
    TRACK_TOL,
    Metrics,
    ScenarioResult,
    SuiteResult,
)
from lpik_bench.quality_reach import REACH_TOL, SAMPLE_EVERY
from lpik_bench.soak import STEP_TOL, STOP_TOL
from lpik_bench.workload import QDD_MAX

#: The variant the goal names ("lpik's default controller"), a key of
#: :data:`lpik_bench.quality.VARIANTS`.
DEFAULT_VARIANT = "lp2s"
#: "At least as good as the best peer within 10 %".
MARGIN = 0.10
#: Tracking errors at or below this [mm, mrad] are rounding, not motion: equal for the goal.
ERROR_RESOLUTION = 1e-9
#: "Strictly better" (jitter) is met by a tie too: a value within this share of the best.
TIE = 0.01
#: The metrics on which, in an acceleration-limited scenario, a variant with acceleration
#: limits is judged against the peers with the same limits alone (like against like:
#: the same command and limits); every other metric against every peer.
AGAINST_LIMITED = ("pos_rms", "pos_max", "ori_rms", "ori_max", "settle_ms", "overshoot",
                   "braking")  # fmt: skip
UNITS = {"end-stop": "rad", "velocity": "rad/s", "acceleration": "rad/s^2"}
RULE_LABELS = {"strict": f" (better; a tie within {TIE:.0%} counts)", "zero": " (must be 0)"}


@dataclass(frozen=True)
class Metric:
    """A metric of the goal: attribute of Metrics, label, which way is better, the rule.

    ``rule``: ``"within"`` (no worse than the best peer by more than MARGIN),
    ``"strict"`` (better than the best peer, or within :data:`TIE` of it: a tie),
    ``"zero"`` (none at all).
    ``resolution``: values at or below it count as it (:data:`ERROR_RESOLUTION`).
    """

    key: str
    label: str
    higher: bool = False
    rule: str = "within"
    resolution: float = 0.0

    def value(self, m: Metrics) -> float:
        """The metric's value in ``m`` (counts stay ints)."""
        return getattr(m, self.key)


METRICS = (
    Metric("pos_rms", "position error RMS [mm]", resolution=ERROR_RESOLUTION),
    Metric("pos_max", "position error max [mm]", resolution=ERROR_RESOLUTION),
    Metric("ori_rms", "orientation error RMS [mrad]", resolution=ERROR_RESOLUTION),
    Metric("ori_max", "orientation error max [mrad]", resolution=ERROR_RESOLUTION),
    Metric("jitter", "jitter [rad/s]", rule="strict"),
    Metric("high", f"velocity energy > {HIGH_HZ:g} Hz [%]"),
    Metric("violation_steps", "limit violations [steps]", rule="zero"),
    Metric("frozen", "frozen steps"),
    Metric("recovered", "recovered directions", higher=True),
    Metric("settle_ms", f"settle time to {SETTLE_TOL[0] * 1e3:g} mm [ms]"),
    Metric("overshoot", "overshoot [mm]", resolution=ERROR_RESOLUTION),
    Metric("braking", "braking steps"),
    Metric("step_median", "step time median [us]"),
    Metric("step_p99", "step time p99 [us]"),
    Metric("step_max", "step time max [us]"),
)


def fmt(x: float | None) -> str:
    """A number with three significant digits or so, plainly."""
    if x is None:
        return "–"
    if x == math.inf:
        return "never"
    if isinstance(x, int):
        return f"{x:,}"
    a = abs(x)
    if a == 0:
        return "0"
    if a >= 100:
        return f"{x:,.0f}"
    if a >= 10:
        return f"{x:.1f}"
    if a >= 1:
        return f"{x:.2f}"
    return f"{x:.2g}"


def metrics_of(result: ScenarioResult) -> tuple[Metric, ...]:
    """The metrics that apply to a scenario.

    Recoveries only where legs end in a hold; settle time, overshoot and braking
    steps only where the legs are point-to-point moves.
    """
    has_recovery = any(leg.settle_from is not None for leg in result.scenario.legs)
    held = any(leg.held for leg in result.scenario.legs)
    return tuple(
        m
        for m in METRICS
        if (m.key != "recovered" or has_recovery)
        and (m.key not in ("settle_ms", "overshoot", "braking") or held)
    )


def meets(metric: Metric, value: float, best: float) -> bool:
    """Whether ``value`` meets the goal against the best peer's ``best``."""
    value, best = max(value, metric.resolution), max(best, metric.resolution)
    if metric.rule == "zero":
        return value == 0
    if metric.rule == "strict":  # better, or equal within TIE
        return value >= (1 - TIE) * best if metric.higher else value <= (1 + TIE) * best
    if metric.higher:
        return value >= (1 - MARGIN) * best
    return value <= (1 + MARGIN) * best


def best_of(metric: Metric, rows: dict[str, Metrics]) -> tuple[list[str], float] | None:
    """The rows with the best value of ``metric`` and that value (None without rows)."""
    if not rows:
        return None
    values = {name: metric.value(m) for name, m in rows.items()}
    pick: Callable[..., float] = max if metric.higher else min
    best = pick(values.values())
    return [name for name, v in values.items() if v == best], best


def violations_cell(m: Metrics) -> str:
    """``0``, or each kind's count and worst excess."""
    parts = [
        f"{kind} {m.violations[kind][0]} (worst +{m.violations[kind][1]:.2g} {UNITS[kind]})"
        for kind in KINDS
        if m.violations.get(kind, (0, 0))[0]
    ]
    return "; ".join(parts) or "0"


def scenario_table(result: ScenarioResult) -> list[str]:
    """The main table: one row per library."""
    recovery = any(leg.settle_from is not None for leg in result.scenario.legs)
    head = (
        [
            "library",
            "position RMS / max [mm]",
            "orientation RMS / max [mrad]",
            "jitter [rad/s]",
            f"> {HIGH_HZ:g} Hz [%]",
            "max \\|qdd\\| [rad/s^2]",
            "violations",
            "frozen",
            "failed",
        ]
        + (["recovered"] if recovery else [])
        + ["step median / p99 / max [us]"]
    )
    lines = ["| " + " | ".join(head) + " |", "|---" + "|---:" * (len(head) - 1) + "|"]
    legs = len(result.scenario.legs)
    for name, m in result.rows.items():
        cells = (
            [
                f"**{name}**" if name in result.lpik else name,
                f"{fmt(m.pos_rms)} / {fmt(m.pos_max)}",
                f"{fmt(m.ori_rms)} / {fmt(m.ori_max)}",
                fmt(m.jitter),
                fmt(m.high),
                fmt(m.acc_max),
                violations_cell(m),
                str(m.frozen),
                str(m.failed),
            ]
            + ([f"{m.recovered}/{legs}"] if recovery else [])
            + [" / ".join(fmt(t) for t in m.step_us)]
        )
        lines.append("| " + " | ".join(cells) + " |")
    failures = [
        f"{name}: {m.failed:,} (the first: {m.first_failure})"
        for name, m in result.rows.items()
        if m.failed
    ]
    if failures:
        lines += ["", "Failed steps (held as `dq = 0`; with acceleration limits, the braking "
                  "step): " + "; ".join(failures) + "."]  # fmt: skip
    return lines


def lpik_table(result: ScenarioResult) -> list[str]:
    """lpik's variants: mean p, share of p = 0, statuses, the binding limits seen most."""
    lines = [
        "| lpik variant | mean p | p = 0 [%] | frozen, no exact direction | statuses "
        "| binding limits (top 3, steps) |",
        "|---|---:|---:|---:|---|---|",
    ]
    for name in result.rows:
        if name not in result.lpik:
            continue
        m = result.rows[name]
        statuses = ", ".join(f"{s} {c:,}" for s, c in m.statuses.items())
        bindings = "; ".join(f"{b} ({c:,})" for b, c in m.bindings) or "none"
        none = "-" if m.frozen_without_direction is None else f"{m.frozen_without_direction:,}"
        lines.append(f"| {name} | {m.p_mean:.3f} | {fmt(m.p_zero)} | {none} of {m.frozen:,} "
                     f"| {statuses} | {bindings} |")  # fmt: skip
    return lines


def recovery_table(result: ScenarioResult) -> list[str]:
    """Per direction: recovered (after how long) and the jitter while out of reach."""
    legs = [leg.label for leg in result.scenario.legs if leg.settle_from is not None]
    lines = ["| library | " + " | ".join(legs) + " |", "|---" + "|---" * len(legs) + "|"]
    for name, m in result.rows.items():
        cells = []
        for r in m.recoveries:
            if r.recovered:
                cells.append(f"yes, {r.after_ms:.0f} ms; chatter {fmt(r.chatter)}")
            else:
                cells.append(f"**no** ({fmt(r.final_mm)} mm off); chatter {fmt(r.chatter)}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def best_line(result: ScenarioResult) -> str:
    """Who is best on each metric, over every row."""
    parts = []
    for metric in metrics_of(result):
        found = best_of(metric, result.rows)
        if found is not None:
            names, value = found
            shown = ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
            parts.append(f"{metric.label}: {shown} ({fmt(value)})")
    return "**Best per metric** (all rows): " + "; ".join(parts) + "."


def goal_rows(result: ScenarioResult) -> list[tuple[Metric, tuple[list[str], float] | None]]:
    """Each metric of the scenario with the best peer(s) and value (None without peers)."""
    peers = {n: m for n, m in result.rows.items() if n not in result.lpik}
    return [(metric, best_of(metric, peers)) for metric in metrics_of(result)]


def settling_table(result: ScenarioResult) -> list[str]:
    """Per point-to-point leg: settle time, overshoot and braking steps of each library."""
    legs = [leg.label for leg in result.scenario.legs if leg.held]
    lines = ["| library | " + " | ".join(legs) + " |", "|---" + "|---" * len(legs) + "|"]
    for name, m in result.rows.items():
        cells = [
            f"{'never' if s.settle_ms is None else f'{s.settle_ms:.0f} ms'}; "
            f"{fmt(s.overshoot)} mm; {s.braking:,}"
            for s in m.settlings
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def like_rows(result: ScenarioResult) -> list[tuple[Metric, tuple[list[str], float] | None]]:
    """Each metric with the reference a variant with acceleration limits is judged against.

    The peers with the same acceleration limits on :data:`AGAINST_LIMITED`, every
    peer on the others (None without such peers).
    """
    peers = {n: m for n, m in result.rows.items() if n not in result.lpik}
    limited = {n: m for n, m in peers.items() if n in result.limited}
    if not limited:
        return []
    return [(metric, best_of(metric, limited if metric.key in AGAINST_LIMITED else peers))
            for metric in metrics_of(result)]  # fmt: skip


def like_table(result: ScenarioResult) -> list[str]:
    """lpik's variants with acceleration limits against the peers with the same limits."""
    variants = [n for n in result.rows if n in result.lpik and n in result.limited]
    lines = [
        "| metric | judged against | " + " | ".join(variants) + " |",
        "|---|---" + "|---" * len(variants) + "|",
    ]
    for metric, best in like_rows(result):
        if best is None:
            continue
        names, value = best
        cells = [
            f"{fmt(metric.value(result.rows[v]))} "
            f"{'met' if meets(metric, metric.value(result.rows[v]), value) else '**missed**'}"
            for v in variants
        ]
        label = metric.label + RULE_LABELS.get(metric.rule, "")
        lines.append(f"| {label} | {', '.join(names[:2])} {fmt(value)} | " + " | ".join(cells)
                     + " |")  # fmt: skip
    return lines


def goal_table(result: ScenarioResult) -> list[str]:
    """Per metric: the best peer, each lpik variant's value and whether it meets the goal."""
    variants = [n for n in result.rows if n in result.lpik]
    lines = [
        "| metric | best peer | " + " | ".join(variants) + " | met by |",
        "|---|---" + "|---" * len(variants) + "|---|",
    ]
    for metric, best in goal_rows(result):
        if best is None:
            continue
        names, value = best
        cells, met = [], []
        for v in variants:
            x = metric.value(result.rows[v])
            ok = meets(metric, x, value)
            met += [v] if ok else []
            cells.append(f"{fmt(x)} {'✓' if ok else '✗'}")
        rule = RULE_LABELS.get(metric.rule, "")
        lines.append(
            f"| {metric.label}{rule} | {', '.join(names[:2])} {fmt(value)} | "
            + " | ".join(cells)
            + f" | {', '.join(met) or '**none**'} |"
        )
    return lines


def like_summary(suite: SuiteResult) -> list[str]:
    """Per acceleration-limited scenario and variant with those limits: met, judged, missed."""
    lines = []
    for result in suite.scenarios:
        judged = [(m, b) for m, b in like_rows(result) if b is not None]
        if not judged:
            continue
        for v in [n for n in result.rows if n in result.lpik and n in result.limited]:
            x = result.rows[v]
            missed = [f"{m.label} {fmt(m.value(x))} vs {fmt(b[1])} ({b[0][0]})"
                      for m, b in judged if not meets(m, m.value(x), b[1])]  # fmt: skip
            lines.append(f"- {result.scenario.title}, {v}: {len(judged) - len(missed)}/"
                         f"{len(judged)} met" + ("; missed: " + "; ".join(missed) if missed
                                                 else "") + ".")  # fmt: skip
    return lines


def goal_summary(suite: SuiteResult) -> list[str]:
    """Per scenario and variant: goals met of goals judged."""
    variants = [n for n in suite.scenarios[0].rows if n in suite.scenarios[0].lpik]
    lines = ["| scenario | " + " | ".join(variants) + " |", "|---" + "|---:" * len(variants) + "|"]
    full = {v: 0 for v in variants}
    for result in suite.scenarios:
        judged = [(m, b) for m, b in goal_rows(result) if b is not None]
        cells = []
        for v in variants:
            met = sum(meets(m, m.value(result.rows[v]), b[1]) for m, b in judged)
            full[v] += met == len(judged) and bool(judged)
            cells.append(f"{met}/{len(judged)}")
        lines.append(f"| {result.scenario.title} | " + " | ".join(cells) + " |")
    default = DEFAULT_VARIANT if DEFAULT_VARIANT in variants else None
    if default is not None:
        lines += ["", f"Where {default} misses the goal (its value against the best peer's):", ""]
        for result in suite.scenarios:
            judged = [(m, b) for m, b in goal_rows(result) if b is not None]
            missed = [
                f"{m.label} {fmt(m.value(result.rows[default]))} vs {fmt(b[1])} ({b[0][0]})"
                for m, b in judged
                if not meets(m, m.value(result.rows[default]), b[1])
            ]
            said = "; ".join(missed) or ("nothing" if judged else "no peer ran: not judged")
            lines.append(f"- {result.scenario.title}: {said}.")
    totals = ", ".join(f"{v} {full[v]}/{len(suite.scenarios)}" for v in variants)
    return [*lines, "", f"Scenarios where the goal is met on every metric: {totals}."]


def render(suite: SuiteResult, command: str) -> str:
    """The whole of docs/quality.md."""
    env = suite.environment
    versions = ", ".join(f"{k} {v}" for k, v in env["versions"].items())
    out = [
        "# Motion quality",
        "",
        "<!-- Generated by benchmarks/lpik_bench/quality_report.py; do not edit by hand. "
        f"Regenerate with: {command} -->",
        "",
        f"Produced by `{command}` on {env['date']}, in {suite.wall_s:.0f} s: {env['cpu']}, "
        f"{env['cores']} cores, {env['platform']}, Python {env['python']} ({versions}; lpik "
        f"source {env['source']}); "
        f"load average {env['load'][0]} before, {env['load'][1]} after."
        + (f" Every leg cut to {env['max_steps']} steps." if env["max_steps"] else ""),
        "",
        *intro(suite),
        "",
    ]
    out += ["## The goal", "", goal_text(), "", *goal_summary(suite), ""]
    like = like_summary(suite)
    if like:
        out += [LIKE_TEXT, "", *like, "", *acceleration_findings(suite), ""]
    for result in suite.scenarios:
        s = result.scenario
        reach = sum(int(leg.reachable.sum()) for leg in s.legs)
        out += [
            f"## {s.title}",
            "",
            s.what,
            f"{s.steps:,} steps ({len(s.legs)} run{'s' if len(s.legs) > 1 else ''} per "
            f"library), the target reachable on {reach:,}.",
            "",
            *scenario_table(result),
            "",
        ]
        if any(leg.settle_from is not None for leg in s.legs):
            out += [
                "Recovery per direction (chatter: jitter while the target is out of reach "
                "[rad/s]):",
                "",
                *recovery_table(result),
                "",
            ]
        if any(leg.held for leg in s.legs):
            out += ["Per move: settle time; overshoot; braking steps:", "",
                    *settling_table(result), ""]  # fmt: skip
        out += [
            *lpik_table(result),
            "",
            best_line(result),
            "",
            "Goal:",
            "",
            *goal_table(result),
            "",
        ]
        if like_rows(result):
            out += [LIKE_TEXT, "", *like_table(result), ""]
    return "\n".join(out)


#: The point-to-point metrics, as the report's list of metrics says them.
SETTLE_TEXT = (
    f"- **Settle time** (scenario 7, point to point): when the error comes within "
    f"{SETTLE_TOL[0] * 1e3:g} mm and {SETTLE_TOL[1] * 1e3:g} mrad for good (the longest "
    "over the moves; never: a move that has not settled by the end of its run). "
    "**Overshoot**: the largest growth of the position error after its running minimum "
    "[mm]. **Braking steps**: steps the library did not answer (lpik: the safe step, a "
    "status that does not move as the method intends; a peer: a failed step)."
)

#: How the variants with acceleration limits are judged in the acceleration-limited scenarios.
LIKE_TEXT = (
    "**Acceleration limits, like against like.** In the acceleration-limited scenarios "
    "each lpik variant with the acceleration limit is judged against the peer given the "
    "same limits (drake +acc: DoDifferentialInverseKinematics with the same joint "
    "acceleration limits and the joint velocities of the last step) on tracking, settle "
    "time, overshoot and braking steps, and against every peer on jitter, the share above "
    f"{HIGH_HZ:g} Hz, violations, frozen steps and step times; a metric is met when the "
    f"variant is no worse than that reference by more than {MARGIN:.0%} (jitter: better, "
    f"or within {TIE:.0%}; errors at or below {ERROR_RESOLUTION:g} mm or mrad are equal):"
)

#: Why a metric of the like-against-like table can be missed: the reason behind each,
#: written from the runs of this suite; only those of the metrics missed are printed.
MISSED_BECAUSE = {
    "jitter": "jitter is the total variation of the joint velocities, and a move from rest "
    "to rest costs at least twice the sum of the joints' top speeds: a library that moves "
    "less, or not at all, scores lower, so the best jitter of scenario 7 belongs to a peer "
    "that does not reach every target (see the settle times and failed steps), not to a "
    "smoother move",
    "overshoot": "lpik brakes its command in time to stop on the target at 80 % of the "
    "acceleration limits, with the stopping distance estimated along the least joint motion "
    "(lpik.command.braking_scale); on the large moves with rotation the joints' actual "
    "motion departs from that estimate and the arm overshoots by millimetres before it settles",
    "settle_ms": "lpik keeps the commanded direction and brakes with a margin (80 % of the "
    "limits), so it takes longer than a move at the limits would",
    "pos_rms": "the tracking error is measured against the commanded target, which jumps: no "
    "library can follow a jump under the acceleration limits, and one that speeds up earlier "
    "and brakes later (or not in time) scores lower on the way",
    "step_max": "the slowest step is noise of this shared machine",
}
for _key in ("pos_max", "ori_rms", "ori_max"):
    MISSED_BECAUSE[_key] = MISSED_BECAUSE["pos_rms"]


def acceleration_findings(suite: SuiteResult) -> list[str]:
    """Why each metric missed in the like-against-like tables is missed, and what is left."""
    missed: dict[str, list[str]] = {}
    for result in suite.scenarios:
        for metric, best in like_rows(result):
            for v in [n for n in result.rows if n in result.lpik and n in result.limited]:
                x = metric.value(result.rows[v])
                if best is None or meets(metric, x, best[1]):
                    continue
                limited = {n: m for n, m in result.rows.items() if n in result.limited}
                same = best_of(metric, {n: m for n, m in limited.items() if n not in result.lpik})
                versus = "" if same is None else (
                    f"; against {same[0][0]}: {fmt(x)} vs {fmt(same[1])}, "
                    f"{'met' if meets(metric, x, same[1]) else 'missed'}")  # fmt: skip
                where = f"scenario {result.scenario.title.split('.')[0]}, {v}{versus}"
                missed.setdefault(metric.key, []).append(where)
    lines = []
    for key, where in missed.items():
        label = next(m.label for m in METRICS if m.key == key)
        why = MISSED_BECAUSE.get(key, "not analysed yet")
        lines.append(f"- {label} ({'; '.join(where)}): {why}.")
    return [
        "Why what is missed is missed:" if lines else "Nothing is missed.",
        "",
        *lines,
        "",
        "Not done yet: the tracking targets of the acceleration-limited scenarios are the "
        "commanded ones (jumps, and a circle started at full speed), not a trajectory that "
        "the acceleration limits allow; the point-to-point moves are judged on settle time "
        "and overshoot instead, with the least time of a joint move at the limits for scale.",
    ]


def goal_text() -> str:
    """The goal and how each metric is judged."""
    return (
        f"The goal: lpik's default controller ({DEFAULT_VARIANT}) is at least as good as "
        f"the best peer on every metric of every scenario within {MARGIN:.0%}, strictly "
        f"better on jitter (a tie within {TIE:.0%} counts), with zero violations. Each "
        "metric is judged against the best peer on that metric (lower is better except "
        "recovered directions); tracking errors "
        f"at or below {ERROR_RESOLUTION:g} mm or mrad (1e-12 m or rad, the rounding of the "
        "kinematics in double precision) count as equal. Every lpik variant is judged, so "
        "the gap of each is visible. Counts of goals met:"
    )


def intro(suite: SuiteResult) -> list[str]:
    """What is measured and how, with the contenders and the skipped ones."""
    dt_ms = suite.environment["dt"] * 1e3
    lines = [
        f"Closed-loop runs on the Panda (arm only, 6-D pose task, dt = {dt_ms:g} ms, the URDF's "
        "end-stops and velocity limits). Every library starts each run at rest from the same "
        "configuration, is given its current joint coordinates and the commanded target pose "
        "of the step, and integrates its own answer (`q_next = q + dq`); every library gets "
        "the same target trajectory. A step that raises or returns no finite answer counts as "
        "*failed* and is taken as `dq = 0`, or, for a library with acceleration limits, as "
        "the braking step (each joint slows down at the acceleration limit, as lpik's safe "
        "step does) (Drake's adapter returns no step unless Drake reports kSolutionFound, "
        "although with kStuck Drake does return joint velocities; drake +acc takes them, since "
        "under acceleration limits every step towards a far target has a small alpha). "
        f"lpik's controller clamps each step's command to `v_max` = {DEFAULT_V_MAX:g} m/s and "
        f"`w_max` = {DEFAULT_W_MAX:g} rad/s (its command law and defaults), except the +acc "
        "variants, whose clamp is off (like against like with drake +acc); the peers are given "
        "the whole error each step (V = error / dt), so where the target runs away they may "
        "move faster than lpik, up to their velocity limits.",
        "",
        "- **Tracking error**: the pose after each step against the target commanded for that "
        "step (position [mm], orientation [mrad]), RMS and max over the steps whose target is "
        "reachable: a bounded least-squares solve within the end-stops, seeded from the "
        f"previous sample (every {SAMPLE_EVERY} steps), ends within {REACH_TOL[0] * 1e3:g} mm "
        f"and {REACH_TOL[1] * 1e3:g} mrad, or the target is the pose of a known configuration "
        "within the limits.",
        "- **Jitter**: total variation of the joint velocities, sum over steps and joints of "
        "|qdot(k+1) - qdot(k)| [rad/s], from rest. **> 5 Hz**: share of the joint-velocity "
        f"energy above {HIGH_HZ:g} Hz (FFT of each joint's velocity per run, after removing the "
        "line through its first and last sample so that the run's ends leak nothing upwards; "
        "summed over joints and runs).",
        f"- **Violations**: steps past an end-stop (by more than {STOP_TOL:g} rad), above a "
        f"velocity limit or, for the +acc rows and in the acceleration-limited scenarios (6, 7) "
        "for every library, above "
        f"the acceleration limit {QDD_MAX:g} rad/s^2 (by more than {STEP_TOL:g} rad per step), "
        "with the worst excess. **max |qdd|**: the largest joint acceleration, from rest.",
        f"- **Frozen**: steps with a reachable target, an error above {TRACK_TOL[0] * 1e3:g} mm "
        f"or {TRACK_TOL[1] * 1e3:g} mrad before the step and no joint moving more than "
        f"{FROZEN_DQ:g} rad. **Recovered** (scenario 2): within those tolerances over the "
        f"last {RECOVERY_WINDOW} steps of the final hold.",
        SETTLE_TEXT,
        "- **lpik**: `p` (mean, share of steps with p = 0), statuses and the binding limits "
        "seen most; of the frozen steps, those with no exact direction at all: LP1's `p` (the "
        "largest fraction of the command that any step within the limits follows exactly) is "
        "0 there, so no step that keeps the commanded direction can move, and only leaving it "
        "(the opt-in `on_stall` progress step) makes progress. **Step time**: the library's "
        "step call alone, median / p99 / max [us]. "
        "The machine is a shared 2-core virtual machine on which other work ran at the same "
        "time: step times are noisy (the max most of all) and only their order of magnitude "
        "is a finding here; docs/benchmarks.md has careful timings.",
        "",
        "| row | setup |",
        "|---|---|",
    ]
    lines += [f"| {name} | {note} |" for name, note in suite.notes.items()]
    if suite.skipped:
        lines += ["", "Not run: " + "; ".join(suite.skipped) + "."]
    return lines
