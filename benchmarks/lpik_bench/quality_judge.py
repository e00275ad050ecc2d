"""How the motion-quality suite judges lpik's variants: like against like.

The decisions it follows:

1. *Ties count.* Where every library computes the same motion, a jitter within
   :data:`TIE` of the reference, or tracking errors both at or below
   :data:`ERROR_RESOLUTION` (rounding), meet the goal.
2. *Like against like.* Every library gets the same command (the peers'
   ``V = error / dt``; lpik with its clamp off, :data:`lpik_bench.quality.UNCLAMPED`).
   lpik's default keeps the commanded direction: on tracking (and what follows
   from it, :data:`AGAINST_LIKE`) it is judged against the peer that keeps it too
   (Drake scales ``V`` by its alpha); the progress mode against mink and pink
   (:data:`LIKE_PEERS`). On jitter, violations, frozen steps and the rest, every
   variant is judged against every peer.
3. *Acceleration limits.* In an acceleration-limited scenario the libraries that take
   acceleration limits run with them; lpik's variants with them (+acc) are the ones
   judged, and their like peer is the peer's run with the same limits (drake +acc).
   Such a library's run without the limits (drake) is shown but is no reference there:
   it is not configured as the scenario demands. Elsewhere the variants without
   acceleration limits are judged.

A metric is met when the variant is no worse than the best of its reference rows
by more than :data:`MARGIN` (jitter: better, or within :data:`TIE`; violations: none
at all). Where no reference row ran (Drake among obstacles) the metric is n/a.
A peer that answered none of the scenario's steps (every one failed) did not run
it: standing still is smooth and quick, so it is no reference on the metrics
judged against every peer (it stays the like peer on tracking, where standing
still scores as it should). A peer that answered some steps is a reference on
what it did.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from lpik_bench.quality_metrics import HIGH_HZ, SETTLE_TOL, Metrics, ScenarioResult

#: "At least as good as the reference within 10 %".
MARGIN = 0.10
#: Tracking errors at or below this [mm, mrad] are rounding, not motion: equal for the goal.
ERROR_RESOLUTION = 1e-9
#: "Strictly better" (jitter) is met by a tie too: a value within this share of the best.
TIE = 0.01
#: Distances [mm] closer than at the start by at most this are no closer (coal's rounding).
DISTANCE_RESOLUTION = 1e-6
#: The like peer(s) of each of lpik's modes (decision 2), by row name; in an
#: acceleration-limited scenario their "+acc" rows.
LIKE_PEERS = {"direction": ("drake",), "progress": ("mink", "pink daqp", "pink quadprog")}
#: The metrics judged against the like peer alone; every other against every peer.
AGAINST_LIKE = ("pos_rms", "pos_max", "ori_rms", "ori_max", "recovered", "settle_ms",
                "overshoot", "braking", "final_error")  # fmt: skip
RULE_LABELS = {"strict": f" (better; a tie within {TIE:.0%} counts)", "zero": " (must be 0)"}


@dataclass(frozen=True)
class Metric:
    """A judged metric: attribute of Metrics, label, which way is better, the rule.

    ``rule``: ``"within"`` (no worse than the reference by more than MARGIN),
    ``"strict"`` (better than the reference, or within :data:`TIE` of it: a tie),
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
    Metric("braking", "infeasible or braking steps"),
    Metric("out_after", "steps to get out of d_s"),
    Metric(
        "deeper", "closer to the obstacle than at the start [mm]", resolution=DISTANCE_RESOLUTION
    ),  # fmt: skip
    Metric("final_error", "tool error at the end [mm]", resolution=ERROR_RESOLUTION),
    Metric("step_median", "step time median [us]"),
    Metric("step_p99", "step time p99 [us]"),
    Metric("step_max", "step time max [us]"),
)
#: Metrics of point-to-point legs, of legs among obstacles, of legs ending in a hold.
HELD = ("settle_ms", "overshoot", "braking")
AMONG = ("out_after", "deeper", "final_error")
#: What a scenario among obstacles is judged on (its tracking is the end error).
AMONG_JUDGED = ("jitter", "violation_steps", "frozen", *AMONG)


def metrics_of(result: ScenarioResult) -> tuple[Metric, ...]:
    """The metrics that apply to a scenario.

    Recoveries only where legs end in a hold; settle time, overshoot and braking
    steps only where the legs are point-to-point moves; among obstacles, the
    clearance, the end error, jitter, violations and frozen steps.
    """
    legs = result.scenario.legs
    if any(leg.scene is not None for leg in legs):
        return tuple(m for m in METRICS if m.key in AMONG_JUDGED)
    has_recovery = any(leg.settle_from is not None for leg in legs)
    held = any(leg.held for leg in legs)
    return tuple(
        m
        for m in METRICS
        if (m.key != "recovered" or has_recovery)
        and (m.key not in HELD or held)
        and m.key not in AMONG
    )


def meets(metric: Metric, value: float, best: float) -> bool:
    """Whether ``value`` meets the goal against the reference's ``best`` ("never" never does)."""
    if value == math.inf:
        return False
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


def judged_variants(result: ScenarioResult) -> list[str]:
    """lpik's variants judged in this scenario: those with acceleration limits where the
    scenario is acceleration-limited, those without elsewhere (decision 3)."""
    limited = result.scenario.acceleration_checked
    return [n for n in result.rows if n in result.lpik and (n in result.limited) == limited]


def like_peers(result: ScenarioResult, variant: str) -> list[str]:
    """The like peers of ``variant`` that ran in this scenario (decision 2)."""
    names = LIKE_PEERS["progress" if variant in result.progress else "direction"]
    if result.scenario.acceleration_checked:
        names = tuple(f"{n} +acc" for n in names)
    return [n for n in names if n in result.rows]


def reference(
    result: ScenarioResult, variant: str, metric: Metric
) -> tuple[list[str], float] | None:
    """The best reference row(s) of ``metric`` for ``variant`` and their value (None: n/a)."""
    if metric.key in AGAINST_LIKE:
        names = like_peers(result, variant)
    else:
        names = [n for n in result.rows if n not in result.lpik and ran(result, n)]
        if result.scenario.acceleration_checked:  # decision 3: with the limits, where it takes them
            names = [n for n in names if f"{n} +acc" not in result.rows]
    return best_of(metric, {n: result.rows[n] for n in names})


def ran(result: ScenarioResult, name: str) -> bool:
    """Whether row ``name`` answered any of the scenario's steps (not every one failed)."""
    steps = sum(len(leg.targets) for leg in result.scenario.legs)
    return result.rows[name].failed < steps


@dataclass(frozen=True)
class Verdict:
    """One variant on one metric: its value, the reference (None: n/a), met or not."""

    metric: Metric
    value: float
    reference: tuple[list[str], float] | None

    @property
    def met(self) -> bool | None:
        """Met, missed, or None where no reference ran (n/a)."""
        if self.metric.rule == "zero":
            return meets(self.metric, self.value, 0.0)
        if self.reference is None:
            return None
        return meets(self.metric, self.value, self.reference[1])


def verdicts(result: ScenarioResult, variant: str) -> list[Verdict]:
    """``variant``'s verdict on every metric of the scenario."""
    row = result.rows[variant]
    return [Verdict(m, m.value(row), reference(result, variant, m)) for m in metrics_of(result)]
