"""The benchmark's records as a text table (``lpik bench``) and as markdown (docs/benchmarks.md)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

Rec = dict[str, Any]


def _of(records: Sequence[Rec], kind: str) -> list[Rec]:
    return [r for r in records if r.get("kind") == kind]


def speedup(ratio: float | None) -> str:
    """``ratio`` (median / fastest peer median) as ``"12.3x faster"`` or ``"1.5x slower"``."""
    if ratio is None or ratio != ratio or ratio <= 0:
        return ""
    if ratio <= 1.0:
        return f"{1.0 / ratio:.1f}x faster"
    return f"{ratio:.1f}x slower"


def _us(value: float | None) -> str:
    if value is None:
        return ""
    if value >= 1e5:
        return f"{value / 1e6:.2f} s"
    return f"{value:.2f}" if value < 100 else f"{value:.0f}"


def timing_rows(records: Sequence[Rec]) -> list[list[str]]:
    """Cells of the timing table: library, method, what, median, p99, p99.9, max, vs fastest
    peer, cold median and max, n."""
    return [
        [
            r["library"],
            r["method"],
            r["what"],
            _us(r["median_us"]),
            _us(r["p99_us"]),
            _us(r.get("p999_us")),
            _us(r.get("max_us")),
            speedup(r.get("ratio_to_fastest_peer")),
            _us(r.get("cold_median_us")),
            _us(r.get("cold_max_us")),
            str(r.get("samples", "")),
        ]
        for r in _of(records, "timing")
    ]


def timing_notes(records: Sequence[Rec]) -> list[str]:
    """``library / method / what: note`` for every timing record with a note."""
    return [
        f"{r['library']} / {r['method']} / {r['what']}: {r['note']}"
        for r in _of(records, "timing")
        if r.get("note")
    ]


def first_call_rows(records: Sequence[Rec]) -> list[list[str]]:
    """Cells of the first-call table: library, method, what, seconds, phases."""
    rows = []
    for r in _of(records, "first call"):
        phases = ", ".join(
            f"{k.removesuffix('_s')} {v:.3f} s" for k, v in r.items() if k.endswith("_s")
        )
        rows.append([r["library"], r["method"], r["what"], f"{r['median_us'] / 1e6:.3f}", phases])
    return rows


def _e(value: float | None) -> str:
    """A number in ``%.2e``; ``inf`` for a non-finite one (stored as ``null`` in JSON)."""
    return "inf" if value is None else f"{value:.2e}"


def agreement_rows(records: Sequence[Rec]) -> list[list[str]]:
    """Cells of the agreement table: library, method, passed, cases, max error, tolerance, what."""
    return [
        [
            r["library"],
            r["method"],
            "pass" if r["passed"] else "FAIL",
            str(r["cases"]),
            _e(r["max_error"]),
            _e(r["tolerance"]),
            r["compared"] + (f" ({r['note']})" if r.get("note") else ""),
        ]
        for r in _of(records, "agreement")
    ]


TIMING_HEAD = [
    "library",
    "method",
    "what",
    "median [us]",
    "p99 [us]",
    "p99.9 [us]",
    "max [us]",
    "vs fastest peer",
    "cold median [us]",
    "cold max [us]",
    "n",
]
FIRST_HEAD = ["library", "method", "what", "total [s]", "phases"]
AGREE_HEAD = ["library", "method", "check", "steps", "max error", "tolerance", "compared"]


def _text(head: list[str], rows: list[list[str]], width: int | None = None) -> str:
    cols = [max(len(str(x)) for x in col) for col in zip(head, *rows)] if rows else []
    if width is not None:
        cols[-1] = min(cols[-1], width)
    lines = ["  ".join(h.ljust(c) for h, c in zip(head, cols)).rstrip()]
    for row in rows:
        lines.append("  ".join(str(x).ljust(c) for x, c in zip(row, cols)).rstrip())
    return "\n".join(lines)


def environment_line(records: Sequence[Rec]) -> str:
    """One line about the machine and the load."""
    env = next(iter(_of(records, "environment")), None)
    if env is None:
        return ""
    load = env["loadavg_before"], env["loadavg_after"]
    return (
        f"{env['cpu']}, {env['cores']} cores, Python {env['python']}, "
        f"{env['numba_threads']} numba threads; load average before {load[0]}, after {load[1]}"
    )


def text_report(records: Sequence[Rec]) -> str:
    """The human-readable output of ``lpik bench``."""
    env = next(iter(_of(records, "environment")), {})
    parts = [environment_line(records), env.get("workload", ""), ""]
    parts += [_text(TIMING_HEAD, timing_rows(records)), ""]
    parts += ["Targets:", _text(TARGET_HEAD, targets(records)), ""]
    parts += ["First call (fresh process):", _text(FIRST_HEAD, first_call_rows(records)), ""]
    parts += ["Agreement checks:", _text(AGREE_HEAD, agreement_rows(records)), ""]
    for r in _of(records, "skipped"):
        parts.append(f"skipped: {r['library']} {r['what']}: {r['note']}")
    return "\n".join(parts).rstrip() + "\n"


def _md_table(head: list[str], rows: list[list[str]]) -> str:
    def esc(x: str) -> str:
        return str(x).replace("|", "\\|")

    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(esc(x) for x in row) + " |" for row in rows]
    return "\n".join(lines)


def markdown_tables(records: Sequence[Rec]) -> dict[str, str]:
    """The timing, first-call and agreement tables as markdown, by name."""
    return {
        "timing": _md_table(TIMING_HEAD, timing_rows(records)),
        "first_call": _md_table(FIRST_HEAD, first_call_rows(records)),
        "agreement": _md_table(AGREE_HEAD, agreement_rows(records)),
        "targets": _md_table(TARGET_HEAD, targets(records)),
    }


#: The speed targets: fused step with acceleration limits, batch throughput.
TARGET_MEDIAN_US = 10.0
TARGET_P99_US = 30.0
TARGET_RATIO = 0.1
TARGET_BATCH_PER_S = 1e6
#: Worst-case target of the fused step, regular and at singular configurations.
TARGET_P999_US = 50.0
#: The ``what`` of the singular cases contains this (:mod:`lpik_bench.singular`).
SINGULAR = "singular configurations"
#: Peers whose step solves a QP with the limits as constraints (the Robotics Toolbox clips).
QP_PEERS = ("drake", "pink", "mink")


def _find(records: Sequence[Rec], method: str, what: str, prefix: bool = False) -> Rec | None:
    """The first lpik timing record of ``method`` whose ``what`` is (or starts with) ``what``."""
    for r in _of(records, "timing"):
        if r["library"] != "lpik" or r["method"] != method:
            continue
        if r["what"] == what or (prefix and r["what"].startswith(what)):
            return r
    return None


def targets(records: Sequence[Rec]) -> list[list[str]]:
    """The speed targets against this run: target, measured, met (``yes``/``no``/``n/a``)."""
    return [
        *_fused_step_targets(records),
        *worst_case_targets(records),
        *_batch_targets(records),
        *_reference_targets(records),
        *_highs_reuse_targets(records),
    ]


def _row(target: str, measured: str, met: bool | None) -> list[str]:
    """One row of the targets table; ``met`` None: nothing to meet (``n/a``)."""
    return [target, measured, "n/a" if met is None else ("yes" if met else "no")]


def _fused_step_targets(records: Sequence[Rec]) -> list[list[str]]:
    """The fused step +acc: median, p99, against the peers, step_into and the planar arm."""
    acc = _find(records, "lp2 fused (compiled)", "full step +acc")
    if acc is None:
        return []
    med, p99 = acc["median_us"], acc["p99_us"]
    return [
        _row(
            f"fused step +acc: median <= {TARGET_MEDIAN_US:g} us",
            f"{med:.2f} us",
            med <= TARGET_MEDIAN_US,
        ),
        _row(
            f"fused step +acc: p99 <= {TARGET_P99_US:g} us", f"{p99:.2f} us", p99 <= TARGET_P99_US
        ),
        _fastest_peer_row(records, acc),
        *_fused_step_comparisons(records, med),
    ]


def _fastest_peer_row(records: Sequence[Rec], acc: Rec) -> list[str]:
    """The fused step +acc against the fastest peer's full step."""
    ratio = acc.get("ratio_to_fastest_peer")
    fastest = min(  # the peers' full steps (not the machine reference)
        (r for r in _of(records, "timing") if r["library"] != "lpik" and r["what"] == "full step"),
        key=lambda r: r["median_us"],
        default=None,
    )
    name = "" if fastest is None else f" ({fastest['library']} {fastest['method']})"
    return _row(
        f"fused step +acc: >= {1 / TARGET_RATIO:g}x faster than the fastest peer{name}",
        speedup(ratio) or "no peer ran",
        None if ratio is None else ratio <= TARGET_RATIO,
    )


def _fused_step_comparisons(records: Sequence[Rec], med: float) -> list[list[str]]:
    """The fused step +acc (median ``med``) against QP peers, step_into and the planar arm."""
    rows = []
    qp = [
        r for r in _of(records, "timing") if r["library"] in QP_PEERS and r["what"] == "full step"
    ]
    if qp:
        best = min(qp, key=lambda r: r["median_us"])
        rows.append(
            _row(
                f"fused step +acc vs the fastest QP-based peer ({best['library']} "
                f"{best['method']}, {best['median_us']:.0f} us)",
                speedup(med / best["median_us"]),
                med / best["median_us"] <= TARGET_RATIO,
            )
        )
    into = _find(records, "lp2 fused step_into (compiled)", "full step +acc")
    if into is not None:
        rows.append(
            _row(
                "fused step_into +acc (q into a preallocated array, no Result): median, p99",
                f"{into['median_us']:.2f} us, {into['p99_us']:.2f} us",
                None,
            )
        )
    planar = _find(records, "lp2 fused (compiled)", "full step, planar", prefix=True)
    if planar is not None:
        rows.append(
            _row(
                "planar 4-link step faster than the Panda step +acc",
                f"{planar['median_us']:.2f} us vs {med:.2f} us",
                planar["median_us"] < med,
            )
        )
    return rows


def _batch_targets(records: Sequence[Rec]) -> list[list[str]]:
    """Batched LP2 against its target, and the batched full steps."""
    rows = []
    batch = _find(records, "lp2_batch (compiled)", "batch of", prefix=True)
    if batch is not None:
        rate = batch.get("steps_per_s") or 0.0
        rows.append(
            _row(
                f"batched LP2 ({batch.get('robot', '?')}, 6-D task): "
                f">= {TARGET_BATCH_PER_S:,.0f} steps/s",
                f"{rate:,.0f} steps/s ({batch['what']})",
                rate >= TARGET_BATCH_PER_S,
            )
        )
    full_batch = _find(records, "lp2 fused step_batch (compiled)", "batch of", prefix=True)
    if full_batch is not None:
        rows.append(
            _row(
                "batched full steps +acc (FK, J, limits, LP2 per row; Lp2Controller.step_batch)",
                f"{full_batch.get('steps_per_s') or 0.0:,.0f} steps/s ({full_batch['what']})",
                None,
            )
        )
    return rows


def _reference_targets(records: Sequence[Rec]) -> list[list[str]]:
    """The machine's speed in this run: the reference case."""
    reference = next((r for r in _of(records, "timing") if r["what"] == "machine reference"), None)
    if reference is None:
        return []
    return [
        _row(
            "machine speed: a 13x13 numpy solve in this run (about 8 us when the machine is idle)",
            f"{reference['median_us']:.2f} us",
            None,
        )
    ]


def _highs_reuse_targets(records: Sequence[Rec]) -> list[list[str]]:
    """Each LP method with one HiGHS model reused across steps against a new one every step."""
    rows = []
    for method in ("lp1", "l1", "lp2 highs"):
        new = _find(records, method, "solve")
        reused = _find(records, method, "solve, HiGHS reused")
        if new is not None and reused is not None:
            gain = new["median_us"] / reused["median_us"]
            rows.append(
                _row(
                    f"{method}: HiGHS model reused across steps vs built anew",
                    f"{reused['median_us']:.0f} us vs {new['median_us']:.0f} us ({gain:.2f}x)",
                    None,
                )
            )
    return rows


TARGET_HEAD = ["target", "measured", "met"]


def worst_case_targets(records: Sequence[Rec]) -> list[list[str]]:
    """p99.9 of the fused steps (regular and singular) and the singular steps' HiGHS fallbacks."""
    rows = []
    for r in _of(records, "timing"):
        regular = r["what"] in ("full step", "full step +acc")
        if r["library"] != "lpik" or r["method"] != "lp2 fused (compiled)":
            continue
        if not regular and SINGULAR not in r["what"]:
            continue
        p999 = r.get("p999_us")
        if p999 is None:
            continue
        rows.append(
            [
                f"fused {r['what'].removeprefix('full ')}: p99.9 <= {TARGET_P999_US:g} us",
                f"{p999:.2f} us (max {_us(r.get('max_us'))} us, n {r.get('samples', '?')})",
                "yes" if p999 <= TARGET_P999_US else "no",
            ]
        )
        if r.get("loop_p999_us") is not None:
            rows.append(
                [
                    f"fused {r['what'].removeprefix('full ')}, back to back (gc off, no other work "
                    f"between steps): p99.9 <= {TARGET_P999_US:g} us",
                    f"{r['loop_p999_us']:.2f} us (median {r['loop_median_us']:.2f}, p99 "
                    f"{r['loop_p99_us']:.2f}, max {_us(r['loop_max_us'])} us, n {r['loop_steps']})",
                    "yes" if r["loop_p999_us"] <= TARGET_P999_US else "no",
                ]
            )
        if "fused_highs" in r:
            paths, steps = r.get("paths", {}), max(r.get("path_steps", 0), 1)
            rows.append(
                [
                    f"fused {r['what'].removeprefix('full ')}: no step falls back to HiGHS",
                    f"{r['fused_highs']} of {r.get('path_steps')} steps (numpy LP2's paths: "
                    f"singular {100 * paths.get('singular', 0) / steps:.0f}%, ratio test "
                    f"{100 * paths.get('ratio-test', 0) / steps:.0f}%)",
                    "yes" if r["fused_highs"] == 0 else "no",
                ]
            )
    return rows
