"""Structured binding: one :class:`~lpik.labels.Binding` from every path, held to the answer.

Each path's binding is held to another path's (numpy ratio test, HiGHS, the
compiled controller, a batch, the closed loop and its CSV, ``lpik solve``'s
JSON), and its fields to the step itself: the bound it names is the one the
step stops at.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import pickle

import numpy as np
import pytest

from cli_documents import GOOD
from lpik.cli.main import main
from lpik.labels import KINDS, SINGULARITY, Binding, bound_label, multiplier_label, row_label
from lpik.limits import AccelerationLimits, EndStops, build_problem, standard_limits
from lpik.methods.lp2 import lp2
from lpik.methods.lp2s import lp2s
from lpik.paper.scenarios import get_scenario
from lpik.problem import Problem
from lpik.result import OPTIMAL, RECOVERING
from lpik.robots.planar import planar_arm
from lpik.robots.registry import load_robot


def _arm():  # type: ignore[no-untyped-def]
    qd_max = np.array([0.5, 0.8, 1.0, 1.2])
    return planar_arm([1.0, 0.8, 0.6, 0.4], q_min=np.full(4, -2.0), q_max=np.full(4, 2.0),
                      qd_max=qd_max)  # fmt: skip


def test_a_binding_is_its_label_and_says_what_it_names() -> None:
    b = bound_label("panda_joint2", "upper", "acceleration limit", 1)
    assert b == "panda_joint2 upper acceleration limit" and isinstance(b, str)
    assert (b.kind, b.index, b.name, b.side, b.recovering) == (
        "acceleration", 1, "panda_joint2", "upper", False)  # fmt: skip
    assert json.dumps({"binding": b}) == '{"binding": "panda_joint2 upper acceleration limit"}'
    assert pickle.loads(pickle.dumps(b)).as_dict() == b.as_dict()
    assert b.outside().recovering and b.outside() == b
    with pytest.raises(AttributeError, match="immutable"):
        b.kind = "velocity"  # type: ignore[misc]
    m = multiplier_label(0, "lower")
    assert (m, m.kind, m.index, m.side) == ("multiplier 1 lower bound", "multiplier", 0, "lower")
    r = row_label(2, "table")
    assert (r, r.kind, r.index, r.name) == ("table", "row", 2, "table")
    assert row_label(0, "table", "collision").kind == "collision"
    assert SINGULARITY.kind == "singularity" and set(KINDS) >= {b.kind, m.kind, r.kind}


def test_every_kind_is_named_alike_by_the_numpy_layers_and_the_compiled_step() -> None:
    """Random states against every kind of limit: the compiled step's Binding equals the numpy
    ratio test's field by field, and the bound it names is where the step stops."""
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller

    arm = _arm()
    controller = Lp2Controller(
        arm, dt=0.05, v_max=2.0, qdd_max=np.array([4.0, 6.0, 8.0, 10.0]), lambda_bound=0.05,
        G=np.array([[1.0, 1.0, 0.0, 0.0]]), h=np.array([1.5]), row_labels=("elbow row",),
        on_stall=None,  # the method's step, against the LP's
    )  # fmt: skip
    rng = np.random.default_rng(11)
    seen: set[str] = set()
    for _ in range(600):
        q0 = rng.uniform(-2.0, 2.0, 4)
        q0[1] = min(q0[1], 1.5 - q0[0])
        prev = q0 - rng.uniform(-1.0, 1.0, 4) * arm.qd_max * 0.05 * rng.integers(0, 2)
        target = arm.pose(q0) + np.append(rng.normal(0.0, 0.2, 2), 0.0)
        fast = controller.step(q0, target, prev)
        problem = controller.problem(q0, target, prev)
        ref = (lp2s if controller.method == "lp2s" else lp2)(problem, path="ratio-test")
        if ref.binding is None:
            assert fast.binding is None
            continue
        assert isinstance(fast.binding, Binding) and isinstance(ref.binding, Binding)
        assert fast.binding.as_dict() == ref.binding.as_dict()
        b = ref.binding
        seen.add(b.kind)
        if ref.status != OPTIMAL or b.recovering:
            continue
        lower, upper = problem.step_bounds()[:2]
        if b.kind in ("end-stop", "velocity", "acceleration"):
            assert b.name == arm.joint_names[b.index]
            bound = upper[b.index] if b.side == "upper" else lower[b.index]
            assert abs(ref.dq[b.index] - bound) <= 1e-9
        elif b.kind == "multiplier":
            bound = problem.lam_max[b.index] if b.side == "upper" else problem.lam_min[b.index]
            assert abs(ref.lam[b.index] - bound) <= 1e-9
        elif b.kind == "row":
            assert b.name == "elbow row"
            assert abs(problem.G[b.index] @ ref.q - problem.h[b.index]) <= 1e-9
    assert {"end-stop", "velocity", "acceleration", "multiplier", "row"} <= seen, seen


def test_the_highs_path_and_a_batch_name_the_same_binding() -> None:
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller

    arm = _arm()
    controller = Lp2Controller(arm, dt=0.05, v_max=2.0, lambda_bound=0.05, on_stall=None)
    rng = np.random.default_rng(3)
    q0 = rng.uniform(-1.5, 1.5, (40, 4))
    targets = np.array([arm.pose(q) + np.append(rng.normal(0, 0.2, 2), 0) for q in q0])
    batch = controller.step_batch(q0, targets)
    agree = 0
    for b in range(len(q0)):
        one = controller.step(q0[b], targets[b])
        assert batch.binding_of(b) == one.binding
        if one.binding is not None:
            assert batch.binding_of(b).as_dict() == one.binding.as_dict()
            highs = lp2(controller.problem(q0[b], targets[b]), path="highs")
            if highs.binding is not None and abs(highs.p - one.p) < 1e-9:
                agree += highs.binding.as_dict() == one.binding.as_dict()
    assert agree > 0


def test_a_limit_that_holds_p_weakly_near_a_singularity_is_named_on_both_paths() -> None:
    # A stretched 2-link arm (smallest singular value 1.9e-3) with multiplier 1 held
    # in [0, 0]: that bound stops p at 0, but relaxing it by 1e-6 raises p by only
    # 1e-10, within HiGHS's rounding. The HiGHS path once called this a singularity.
    problem = Problem(
        J=np.array([[-1.93530688e-03, -1.93530688e-03], [9.36353397e-07, -1.99999906e00]]),
        dw=np.array([0.04, 0.0]), q0=np.array([0.0, 3.140625]),
        q_min=np.full(2, -3.2), q_max=np.array([0.0, 3.140625]),
        dq_min=np.full(2, -0.125), dq_max=np.full(2, 0.125),
        lam_min=np.zeros(2), lam_max=np.array([0.0, 1.0]),
    )  # fmt: skip
    answers = [lp2(problem, path=path) for path in ("ratio-test", "highs")]
    assert [res.p for res in answers] == [0.0, 0.0]
    assert [str(res.binding) for res in answers] == ["multiplier 1 lower bound"] * 2
    # and it does hold p: relaxing it alone lets the step move along the command
    relaxed = lp2(problem.replace(lam_min=np.array([-1e-3, 0.0])), path="highs")
    assert relaxed.p > 1e-8


def test_recovering_and_singularity_are_named_as_values() -> None:
    arm = planar_arm([1.0, 1.0], q_min=[-1.0, -1.0], q_max=[1.0, 1.0], qd_max=1.0)
    limits = standard_limits(arm)
    q0 = np.array([1.2, 0.0])  # joint 1 past its upper end-stop
    problem = build_problem(arm.jacobian(q0), [0.001, 0.0], q0, limits, dt=0.01)
    res = lp2(problem)
    assert res.status == RECOVERING and res.binding.recovering
    assert (res.binding.kind, res.binding.index, res.binding.side) == ("end-stop", 0, "upper")
    stretched = np.zeros(2)  # the arm straight along x: it cannot move along x
    problem = build_problem(arm.jacobian(stretched), [0.01, 0.0], stretched, limits, dt=0.01)
    res = lp2(problem)
    assert res.p < 1 and res.binding == "singularity" and res.binding.kind == "singularity"


def test_build_problem_names_joints_as_the_model_does() -> None:
    """The names come with standard_limits(model): the numpy path spells a limit as the
    controller and simulate do, without joint_names passed by hand."""
    panda = load_robot("panda", task="position")
    q0 = np.clip(np.zeros(panda.n_joints), panda.q_min, panda.q_max)
    limits = [*standard_limits(panda), AccelerationLimits(1.0)]
    problem = build_problem(panda.jacobian(q0), [0.05, 0.0, 0.0], q0, limits, dt=0.01)
    res = lp2(problem)
    assert res.binding is not None and res.binding.name in panda.joint_names
    assert res.binding.startswith("panda_joint") and res.binding.kind == "acceleration"
    plain = build_problem(np.eye(2), [1.0, 0.0], [0.0, 0.0], [EndStops(-1, 1)], dt=0.01)
    assert plain.joint_names == ("joint 1", "joint 2")
    assert Problem(J=np.eye(1), dw=[1.0], q0=[0.0], G=[[1.0]], h=[0.5],
                   row_labels=["wall"]).row_labels[0].kind == "row"  # fmt: skip


def test_no_binding_is_none_in_the_log_and_an_empty_field_in_the_csv(tmp_path) -> None:  # type: ignore[no-untyped-def]
    log = get_scenario("pull-in").run("lp2", steps=400)
    assert any(b is None for b in log.binding) and any(b is not None for b in log.binding)
    assert all(b is None or isinstance(b, Binding) for b in log.binding)
    assert all((b is None) == (p == 1.0) for b, p in zip(log.binding, log.p))
    out = log.to_csv(tmp_path / "run.csv")
    with out.open(encoding="utf-8") as handle:
        column = [row["binding"] for row in csv.DictReader(handle)]
    assert column == [b or "" for b in log.binding]


def test_the_json_answer_keeps_the_string_label(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "p.json"
    path.write_text(json.dumps(GOOD), encoding="utf-8")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["solve", str(path)]) == 0
    data = json.loads(out.getvalue())
    problem = Problem(**{k: v for k, v in GOOD.items() if k != "method"})
    assert data["binding"] == lp2(problem).binding
