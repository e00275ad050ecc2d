"""lpik bench's singular cases and worst-case columns: the machinery, on small workloads.

No timing is asserted: only the workload's geometry, the path counts and the records.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.robots.registry import home_configuration, load_robot  # noqa: E402
from lpik_bench import runner as R  # noqa: E402
from lpik_bench import singular as S  # noqa: E402
from lpik_bench import table as T  # noqa: E402


@pytest.fixture(scope="module")
def work() -> S.SingularWorkload:
    return S.singular_workload(bases=1, seed=1)


def test_the_stretched_angle_is_the_elbow_singularity() -> None:
    model = load_robot("panda", task="pose")
    q = home_configuration("panda")  # joint 5 at 0
    q[3] = S.stretched_angle(model, q)
    assert q[3] == pytest.approx(-0.467002424, abs=1e-7)  # tests/test_singular.py's angle
    assert S.smallest_singular_value(model, q) < 1e-8


def test_the_workload_has_every_start_kind_offset_and_target(work: S.SingularWorkload) -> None:
    per_elbow = len(S.OFFSETS) * len(S.TARGETS)
    assert len(work) == 2 * per_elbow + len(S.TARGETS)
    assert work.kinds.count("elbow") == work.kinds.count("elbow + wrist") == per_elbow
    model = work.model
    assert np.all(work.q >= model.q_min) and np.all(work.q <= model.q_max)
    elbow = np.array([k != "wrist" for k in work.kinds])
    assert np.all(work.q[elbow, 4] == 0.0)
    wrist = np.array([k != "elbow" for k in work.kinds])
    assert set(np.round(work.q[wrist, 5], 12)) <= {0.0, round(np.pi, 12)}
    # at the singularity itself (offset 0) and at every offset's distance from it
    assert work.sigma_min.min() < 1e-8
    assert work.sigma_min[elbow].max() < 1e-2
    assert "sigma_min(J)" in work.describe()
    # the previous configuration: one step back at the speed of the step about to be taken
    step = work.controller().step(work.q[0], work.targets[0]).q
    np.testing.assert_allclose(work.q_prev[0], 2.0 * work.q[0] - step, atol=1e-15)


def test_path_counts_add_up_and_no_fused_step_goes_to_highs(work: S.SingularWorkload) -> None:
    counts = S.path_counts(work.controller(), work)
    assert counts.steps == len(work) == sum(counts.numpy.values())
    assert set(counts.numpy) <= {"ratio-test", "singular", "highs"}
    assert counts.numpy.get("singular", 0) > 0  # the workload reaches the singular path
    assert counts.fused_highs == 0
    assert "singular path" in counts.text() and counts.extra()["path_steps"] == len(work)


def test_singular_cases_run_and_carry_their_paths(work: S.SingularWorkload) -> None:
    cases = S.singular_cases(work)
    whats = {(c.method, c.what) for c in cases}
    assert ("lp2 fused (compiled)", S.SINGULAR_STEP) in whats
    assert ("lp2 fused (compiled)", S.SINGULAR_STEP_ACC) in whats
    assert ("lp2 (numpy layers)", S.SINGULAR_STEP) in whats
    for case in cases:
        for i in (0, len(work) + 1):  # any index: taken modulo the workload
            case.call(i)
        assert case.extra["robot"] == "panda" and case.extra["ratio_to_fastest_peer"] is None
        if case.method == "lp2 fused (compiled)":
            assert case.extra["fused_highs"] == 0 and "paths (numpy LP2)" in case.note
            assert case.extra["loop_steps"] == 16 * len(work)  # every fused step back to back
    plain = cases[0].extra
    assert plain["after_gc_collect_us"] > 0 and plain["back_to_back_us"] > 0
    assert plain["loop_steps"] == 16 * len(work)
    assert plain["loop_median_us"] <= plain["loop_p99_us"] <= plain["loop_p999_us"]
    assert plain["loop_p999_us"] <= plain["loop_max_us"]
    samples = R.time_cases(cases[:1], rounds=2, max_calls=4)
    assert samples[cases[0].label].shape == (2, 4)


def test_worst_case_targets_on_synthetic_records() -> None:
    def timing(what: str, p999: float, **extra: object) -> dict:
        return {"library": "lpik", "method": "lp2 fused (compiled)", "what": what,
                "median_us": 5.0, "p99_us": 9.0, "p999_us": p999, "max_us": 2 * p999,
                "samples": 7800, "kind": "timing", **extra}  # fmt: skip

    paths = {"paths": {"singular": 3, "ratio-test": 1}, "fused_highs": 0, "path_steps": 4}
    records = [
        timing("full step", 12.0),
        timing("full step +acc", 60.0),
        timing(
            S.SINGULAR_STEP,
            20.0,
            **paths,
            loop_median_us=9.0,
            loop_p99_us=10.0,
            loop_p999_us=70.0,
            loop_max_us=900.0,
            loop_steps=11264,
        ),  # fmt: skip
        timing(S.SINGULAR_STEP_ACC, 30.0, **{**paths, "fused_highs": 1}),
    ]
    rows = {r[0]: r for r in T.worst_case_targets(records)}
    assert rows["fused step: p99.9 <= 50 us"][2] == "yes"
    assert rows["fused step +acc: p99.9 <= 50 us"][2] == "no"
    assert rows[f"fused step, {T.SINGULAR}: p99.9 <= 50 us"][2] == "yes"
    highs = rows[f"fused step, {T.SINGULAR}: no step falls back to HiGHS"]
    assert highs[2] == "yes" and "singular 75%" in highs[1]
    assert rows[f"fused step +acc, {T.SINGULAR}: no step falls back to HiGHS"][2] == "no"
    loop = [row for name, row in rows.items() if "back to back" in name]
    assert len(loop) == 1 and loop[0][2] == "no" and "n 11264" in loop[0][1]
    assert "p99.9 [us]" in T.TIMING_HEAD
    assert T.timing_rows(records)[0][T.TIMING_HEAD.index("p99.9 [us]")] == "12.00"
    assert S.SINGULAR_STEP.endswith(T.SINGULAR)


def test_the_default_controller_stays_compiled_on_every_singular_step() -> None:
    """lp2s (the default) at singular configurations: a later pass whose ratio-test answer
    fails its check takes the compiled singular path, as numpy's LP2 does, instead of
    handing the whole step to the numpy passes (1.3 ms; 12 of these 704 steps did)."""
    from lpik.methods.lp2s import lp2s

    work = S.singular_workload(16)
    controller = work.controller()
    assert controller.method == "lp2s"
    for k in range(len(work)):
        got = controller.step(work.q[k], work.targets[k])
        assert got.path == "compiled", k
        if k in (140, 141, 142, 143, 248):  # the steps that left the compiled path
            ref = lp2s(controller.problem(work.q[k], work.targets[k]))
            assert (got.status, got.binding) == (ref.status, ref.binding)
            # (1e-8: sigma_min(J) down to 1e-11 here, the passes' rounding grows with it)
            np.testing.assert_allclose(got.q, ref.q, atol=1e-8, rtol=0)
