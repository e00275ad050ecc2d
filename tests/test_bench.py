"""lpik bench: the records' contract, graceful skipping of peers, the checks' logic.

No timing is asserted: only shapes, keys and the mathematics of the checks.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.cli.main import main  # noqa: E402
from lpik_bench import agreement as A  # noqa: E402
from lpik_bench import peers as P  # noqa: E402
from lpik_bench import runner as R  # noqa: E402
from lpik_bench import table as T  # noqa: E402
from lpik_bench.cases import Case  # noqa: E402
from lpik_bench.workload import (  # noqa: E402
    TARGET_FRACTION,
    arm_only_urdf,
    make_workload,
    step_target,
)

REQUIRED = ("library", "method", "what", "median_us", "p99_us")
KINDS = {"timing", "first call", "agreement", "skipped", "environment"}


@pytest.fixture(scope="module")
def quick_records() -> list[dict]:
    """``lpik bench --quick --json``, run once for the module (peers as installed)."""
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(["bench", "--quick", "--json"])
    assert status == 0
    return json.loads(out.getvalue())


def test_quick_json_has_the_required_keys(quick_records: list[dict]) -> None:
    assert isinstance(quick_records, list) and quick_records
    for record in quick_records:
        for key in REQUIRED:
            assert key in record, (key, record)
        assert record["kind"] in KINDS
    timings = [r for r in quick_records if r["kind"] == "timing"]
    assert timings
    for r in timings:
        assert math.isfinite(r["median_us"]) and r["median_us"] > 0
        assert r["p99_us"] >= r["median_us"]
        assert r["samples"] >= 1


def test_quick_run_covers_every_lpik_case(quick_records: list[dict]) -> None:
    from lpik.methods import ALL_METHODS

    lpik = {(r["method"], r["what"]) for r in quick_records if r["library"] == "lpik"}
    for method in ALL_METHODS:
        assert (method, "solve") in lpik
    for what in ("full step", "full step +acc", "full step, planar 4-link"):
        assert ("lp2 fused (compiled)", what) in lpik
    assert ("chain_fk_jacobian (compiled)", "FK + J") in lpik
    assert any(m == "lp2_batch (compiled)" and w.startswith("batch of") for m, w in lpik)
    assert any(m == "lp2 fused step_batch (compiled)" and w.endswith("full steps +acc")
               for m, w in lpik)  # fmt: skip
    for method in ("lp1", "l1", "lp2 highs"):
        assert (method, "solve, HiGHS reused") in lpik
    singular = [r for r in quick_records if "singular configurations" in r["what"]]
    assert {r["method"] for r in singular} == {"lp2 fused (compiled)", "lp2 (numpy layers)"}
    for r in singular:
        assert r["p999_us"] >= r["p99_us"] and r["ratio_to_fastest_peer"] is None
        if r["method"] == "lp2 fused (compiled)":
            assert r["fused_highs"] == 0 and sum(r["paths"].values()) == r["path_steps"]
    firsts = [r for r in quick_records if r["kind"] == "first call"]
    assert any(r["library"] == "lpik" and r["median_us"] > 0 for r in firsts)


def test_quick_run_lpik_agreement_passes(quick_records: list[dict]) -> None:
    checks = [r for r in quick_records if r["kind"] == "agreement" and r["library"] == "lpik"]
    assert len(checks) == 5
    assert all(r["passed"] for r in checks), checks


def test_missing_peers_are_skipped_with_the_install_command(quick_records: list[dict]) -> None:
    import importlib.util

    modules = {"drake": "pydrake", "pink": "pink", "mink": "mink", "rtb": "roboticstoolbox"}
    skipped = {r["library"]: r["note"] for r in quick_records if r["kind"] == "skipped"}
    for peer, module in modules.items():
        if importlib.util.find_spec(module) is None:
            assert peer in skipped
            assert f"pip install {P.PEER_PACKAGES[peer]}" in skipped[peer]


def test_text_report_renders(quick_records: list[dict]) -> None:
    text = T.text_report(quick_records)
    assert "median [us]" in text and "Agreement checks" in text
    tables = T.markdown_tables(quick_records)
    assert set(tables) == {"timing", "first_call", "agreement", "targets"}
    assert tables["timing"].startswith("| library |")
    failed = {"library": "x", "method": "m", "what": "agreement", "median_us": None,
              "p99_us": None, "kind": "agreement", "compared": "c", "cases": 3,
              "max_error": None, "tolerance": 1e-8, "passed": False, "note": ""}  # fmt: skip
    assert T.agreement_rows([failed])[0][2:5] == ["FAIL", "3", "inf"]


# ---------------------------------------------------------------- agreement logic


def test_relative_errors_on_synthetic_rows() -> None:
    ref = np.array([[3.0, 4.0], [0.0, 0.0], [1.0, 0.0], [1.0, 0.0]])
    other = np.array([[3.0, 4.5], [0.0, 0.0], [np.nan, 0.0], [1.0, 0.0]])
    err = A.relative_errors(ref, other)
    assert err[0] == pytest.approx(0.1)
    assert err[1] == 0.0
    assert err[2] == np.inf
    assert err[3] == 0.0
    assert A.relative_errors([[0.0, 0.0]], [[1e-3, 0.0]])[0] == np.inf


def test_check_agreement_masks_and_per_step_tolerance() -> None:
    err = np.array([1e-3, 1e-9, 5e-9, 1.0])
    mask = np.array([False, True, True, False])
    ok = A.check_agreement("x", "m", "c", err, mask, 1e-8)
    assert ok.passed and ok.cases == 2 and ok.max_error == pytest.approx(5e-9)
    bad = A.check_agreement("x", "m", "c", err, mask, np.array([1, 1e-8, 1e-9, 1]))
    assert not bad.passed and bad.worst_ratio == pytest.approx(5.0)
    empty = A.check_agreement("x", "m", "c", err, np.zeros(4, bool), 1.0)
    assert not empty.passed and empty.cases == 0
    record = empty.record().to_dict()
    assert record["max_error"] is None and record["passed"] is False
    json.dumps(record, allow_nan=False)


def test_dls_tolerance_bounds_the_damped_step() -> None:
    rng = np.random.default_rng(1)
    damping = 1e-2
    J = rng.normal(size=(200, 6, 7)) * rng.uniform(0.05, 1.0, size=(200, 1, 1))
    e = rng.normal(size=(200, 6))
    pinv = np.einsum("bij,bj->bi", np.linalg.pinv(J), e)
    JJt = J @ np.swapaxes(J, 1, 2) + damping * np.eye(6)
    dls = np.einsum("bji,bj->bi", J, np.linalg.solve(JJt, e[..., None])[..., 0])
    err = A.relative_errors(pinv, dls)
    tol = A.dls_tolerance(J, damping)
    assert (err <= tol).all()
    assert (err > 0.01 * tol).any()  # the bound is not vacuous


def test_summarize_and_ratios() -> None:
    med, p99 = R.summarize(np.arange(1, 101) * 1000, per_call=2)
    assert med == pytest.approx(25.25) and p99 == pytest.approx(49.505)
    ratios = R.ratios_to_fastest_peer({"a": 10.0, "p1": 100.0, "p2": 50.0}, ["p1", "p2"])
    assert ratios["a"] == pytest.approx(0.2) and ratios["p2"] == pytest.approx(1.0)
    assert R.ratios_to_fastest_peer({"a": 1.0}, []) == {}


def test_steady_and_cold_split_the_first_call_of_each_round() -> None:
    samples = np.full((10, 4), 2000)
    samples[:, 0] = 50_000
    stats = R.steady_and_cold(samples, per_call=2)
    assert stats["median_us"] == 1.0 and stats["p99_us"] == 1.0
    assert stats["cold_median_us"] == 25.0


def test_steady_and_cold_report_the_worst_step() -> None:
    samples = np.full((10, 4), 2000)
    samples[:, 0] = 50_000
    samples[3, 2] = 9000  # one slow steady-state step among 30
    stats = R.steady_and_cold(samples, per_call=2)
    assert stats["median_us"] == 1.0 and stats["max_us"] == 4.5
    assert stats["cold_max_us"] == 25.0


def test_steady_and_cold_report_the_p999() -> None:
    samples = np.full((10, 1001), 1000)
    samples[4, 1:21] = 90_000  # 20 slow steady-state steps in 10,000: above the p99.9
    samples[5, 3] = 200_000  # the worst
    stats = R.steady_and_cold(samples)
    assert stats["p99_us"] == 1.0 and stats["max_us"] == 200.0
    assert stats["p999_us"] == 90.0


def test_time_cases_gives_every_case_the_same_items() -> None:
    seen: dict[str, list[int]] = {"a": [], "b": []}
    cases = [
        Case("lpik", name, "solve", lambda i, name=name: seen[name].append(i)) for name in seen
    ]
    samples = R.time_cases(cases, rounds=4, max_calls=5)
    for case in cases:
        assert samples[case.label].shape == (4, 5)
    assert seen["a"] == seen["b"]
    assert seen["a"][-5:] == [15, 16, 17, 18, 19]


def test_targets_table_on_synthetic_records() -> None:
    def timing(library: str, method: str, what: str, med: float, **extra: object) -> dict:
        return {"library": library, "method": method, "what": what, "median_us": med,
                "p99_us": 2 * med, "kind": "timing", **extra}  # fmt: skip

    records = [
        timing("lpik", "lp2 fused (compiled)", "full step +acc", 8.0, ratio_to_fastest_peer=0.08),
        timing("lpik", "lp2 fused (compiled)", "full step, planar 4-link", 5.0),
        timing("lpik", "lp2_batch (compiled)", "batch of 10", 0.5, steps_per_s=2e6),
        timing("lpik", "lp1", "solve", 400.0),
        timing("lpik", "lp1", "solve, HiGHS reused", 200.0),
        timing("rtb", "DLS (jacob0)", "full step", 100.0),
        timing("numpy", "linalg.solve 13x13", "machine reference", 8.0),
    ]
    rows = {r[0]: r for r in T.targets(records)}
    met = [r[2] for r in rows.values()]
    assert met.count("yes") == 5 and met.count("n/a") == 2
    assert any(name.startswith("machine speed") for name in rows)
    # The fastest peer is the fastest other library's full step, never the yardstick.
    assert any("fastest peer (rtb DLS (jacob0))" in name for name in rows), list(rows)
    assert "2.00x" in rows["lp1: HiGHS model reused across steps vs built anew"][1]
    assert T.speedup(0.08) == "12.5x faster" and T.speedup(2.0) == "2.0x slower"


# ---------------------------------------------------------------- workload and peers


def test_arm_only_urdf_fixes_the_fingers_only() -> None:
    root = ET.fromstring(arm_only_urdf("panda"))
    kinds = {j.get("name"): j.get("type") for j in root.iter("joint")}
    assert kinds["panda_finger_joint1"] == "fixed" and kinds["panda_finger_joint2"] == "fixed"
    assert all(kinds[f"panda_joint{i}"] == "revolute" for i in range(1, 8))
    assert root.find(".//mimic") is None


def test_workload_targets_stay_inside_the_command_clamp() -> None:
    w = make_workload("panda", trajectories=2, steps=5, seed=3)
    assert w.q.shape == (10, 7) and w.targets.shape == (10, 4, 4)
    assert np.array_equal(w.q_prev[0], w.q[0]) and np.array_equal(w.q_prev[1], w.q[0])
    for q, target in zip(w.q, w.targets):
        dw = w.model.difference(w.model.pose(q), target)
        assert np.linalg.norm(dw[:3]) <= TARGET_FRACTION * w.v_max * w.dt * (1 + 1e-9)
        assert np.linalg.norm(dw[3:]) <= TARGET_FRACTION * w.w_max * w.dt * (1 + 1e-9)
        assert (q >= w.model.q_min).all() and (q <= w.model.q_max).all()
    again = make_workload("panda", trajectories=2, steps=5, seed=3)
    assert np.array_equal(again.q, w.q)


def test_step_target_is_exact_in_lpiks_difference() -> None:
    w = make_workload("panda", trajectories=1, steps=1)
    pose = w.model.pose(w.q[0])
    goal = w.model.pose(w.q[0] + 0.3)
    target = step_target(pose, goal, 1e-3, 2e-3)
    dw = w.model.difference(pose, target)
    assert np.linalg.norm(dw[:3]) == pytest.approx(1e-3)
    assert np.linalg.norm(dw[3:]) == pytest.approx(2e-3)


def test_load_peers_skips_missing_broken_and_mismatched(monkeypatch: pytest.MonkeyPatch) -> None:
    w = make_workload("panda", trajectories=1, steps=2)

    def missing(workload: object) -> list:
        raise ImportError("No module named 'nothing'")

    def broken(workload: object) -> list:
        raise RuntimeError("bad URDF")

    def good(workload: object) -> list:
        model = w.model
        step = P.PeerStep("good", "m", lambda q, t: np.zeros(7), model.pose, "0")
        wrong = P.PeerStep("good", "off", lambda q, t: np.zeros(7), lambda q: np.eye(4), "0")
        return [step, wrong]

    monkeypatch.setattr(P, "ADAPTERS", {"drake": missing, "pink": broken, "good": good})
    monkeypatch.setitem(P.PEER_PACKAGES, "good", "good")
    peers = P.load_peers(w, ("drake", "pink", "good"))
    assert [p.method for p in peers.steps] == ["m"]
    reasons = {s.library + s.reason[:14]: s.reason for s in peers.skipped}
    assert any("pip install drake" in r for r in reasons.values())
    assert any("failed to load: RuntimeError" in r for r in reasons.values())
    assert any("forward kinematics differs" in r for r in reasons.values())


def test_unknown_peer_and_bad_rounds_are_input_errors(capsys: pytest.CaptureFixture) -> None:
    assert main(["bench", "--quick", "--peers", "nope"]) == 2
    assert "lpik: error: --peers: unknown nope" in capsys.readouterr().err
    assert main(["bench", "--quick", "--rounds", "0"]) == 2
    assert "lpik: error: --rounds: must be >= 1" in capsys.readouterr().err  # the option's name


def test_regenerating_the_page_keeps_the_sections_other_tools_wrote() -> None:
    from lpik_bench.markdown import keep_sections

    old = "# B\n\n## Targets\n\nold\n\n## Collision\n\nkept\n\n## How it is measured\n\nold\n"
    new = "# B\n\n## Targets\n\nnew\n\n## How it is measured\n\nnew\n"
    page = keep_sections(old, new)
    assert (
        page == "# B\n\n## Targets\n\nnew\n\n## Collision\n\nkept\n\n## How it is measured\n\nnew\n"
    )
    assert keep_sections(new, new) == new
