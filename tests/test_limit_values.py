"""One way to set limits: the same values to build_problem, simulate, Lp2Controller and the CLI."""

from __future__ import annotations

import contextlib
import csv
import io
from dataclasses import dataclass

import numpy as np
import pytest

from lpik.cli.main import main
from lpik.command import ClampedTarget
from lpik.control.inputs import rate_limits
from lpik.control.simulate import simulate
from lpik.limits import (
    AccelerationLimits,
    EndStops,
    LinearRows,
    MultiplierBounds,
    Piece,
    StepContext,
    VelocityLimits,
    build_problem,
    standard_limits,
)
from lpik.methods import solve
from lpik.robots.planar import planar_arm

pytest.importorskip("numba")
from lpik.control.controller import Lp2Controller  # noqa: E402
from lpik.control.stepper import Stepper  # noqa: E402

ARM = planar_arm([1.0, 1.0, 1.0, 1.0], q_min=-2.5, q_max=np.deg2rad([95, 150, 150, 150]),
                 qd_max=1.0)  # fmt: skip
LIMITS = [
    EndStops(ARM.q_min, ARM.q_max, ARM.joint_names),
    VelocityLimits([1.0, 0.8, 1.2, 1.0], qd_min=[-0.9, -0.8, -1.2, -1.0]),
    AccelerationLimits(6.0),
    MultiplierBounds.symmetric(0.2),
    LinearRows([[1.0, 1.0, 0.0, 0.0]], [1.4], ("elbow row",)),
]


def test_the_same_values_give_the_same_steps_in_every_entry_point() -> None:
    """Lp2Controller(limits=...) step by step = build_problem(limits) + its method = simulate."""
    q0 = np.deg2rad([60.0, -30.0, -30.0, -30.0])
    target = np.array([0.2, 0.866, 0.0])
    dt, steps = 0.01, 400
    # the paper's LP2 and step: it stops at the end-stop, so that every kind of limit binds
    controller = Lp2Controller(ARM, dt=dt, limits=LIMITS, M=np.ones(4), f=np.zeros(4),
                               Lambda=np.zeros(4), saturate=False, second_order=False,
                               continuation=False, on_stall=None)  # fmt: skip
    log = simulate(ARM, ClampedTarget(target, v_max=0.5), q0, steps, dt=dt, limits=LIMITS,
                   weights={"M": np.ones(4), "f": np.zeros(4), "Lambda": np.zeros(4)},
                   method=controller.method, second_order=False, continuation=False,
                   on_stall=None)  # fmt: skip
    q, prev = q0.copy(), None
    kinds = set()
    for k in range(steps):
        res = controller.step(q, target, prev)
        dw = ARM.difference(ARM.pose(q), target)
        dw *= min(1.0, 0.5 * dt / np.linalg.norm(dw))
        ref = solve(build_problem(ARM.jacobian(q), dw, q, LIMITS, dt=dt, q_prev=prev),
                    controller.method)  # fmt: skip
        np.testing.assert_allclose(res.q, ref.q, atol=1e-9, rtol=0)
        np.testing.assert_allclose(log.q[k], q, atol=1e-9, rtol=0)
        assert (res.status, res.binding) == (ref.status, ref.binding) == (
            log.status[k], log.binding[k])  # fmt: skip
        kinds.add(None if res.binding is None else res.binding.kind)
        prev, q = q, res.q
    assert {"acceleration", "end-stop"} <= kinds, kinds


def test_the_keyword_forms_are_the_same_limits() -> None:
    forms = [
        Lp2Controller(ARM, dt=0.01, qdd_max=6.0, lambda_bound=0.2),
        Lp2Controller(ARM, dt=0.01, qdd_max=6.0, lambda_bound=MultiplierBounds.symmetric(0.2)),
        Lp2Controller(
            ARM,
            dt=0.01,
            limits=[*standard_limits(ARM), AccelerationLimits(6.0), MultiplierBounds(-0.2, 0.2)],
        ),  # fmt: skip
    ]
    rng = np.random.default_rng(2)
    for _ in range(100):
        q = rng.uniform(-1.5, 1.5, 4)
        prev = q - rng.uniform(-0.01, 0.01, 4)
        target = ARM.pose(q) + np.append(rng.normal(0, 0.1, 2), 0)
        first, *others = (c.step(q, target, prev) for c in forms)
        for other in others:
            np.testing.assert_array_equal(first.q, other.q)
            assert first.binding == other.binding


def test_rate_limits_read_per_second_values_and_refuse_state_dependent_limits() -> None:
    rates = rate_limits(LIMITS, 4)
    np.testing.assert_array_equal(rates[:2], [[-0.9, -0.8, -1.2, -1.0], [1.0, 0.8, 1.2, 1.0]])
    np.testing.assert_array_equal(rates[2:], [[-6.0] * 4, [6.0] * 4])

    @dataclass(frozen=True)
    class Wall:
        def apply(self, context: StepContext) -> Piece:
            return Piece(G=np.ones((1, 4)), h=np.array([1.0 + context.q0.sum()]))

    with pytest.raises(ValueError, match="Wall depends on the state: run it with simulate"):
        Lp2Controller(ARM, dt=0.01, limits=[*LIMITS, Wall()])
    with pytest.raises(ValueError, match="limits: must be a list of limits"):
        Lp2Controller(ARM, dt=0.01, limits=3.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="lambda_bound: must be a number > 0"):
        Lp2Controller(ARM, dt=0.01, lambda_bound="big")  # type: ignore[arg-type]


@pytest.mark.parametrize("flag", [True, [True, False, True, True], np.ones(4, dtype=bool)])
def test_acceleration_limits_are_numbers_not_a_switch(flag) -> None:  # type: ignore[no-untyped-def]
    """``qdd_max=True`` would be a limit of 1 rad/s^2 (False: 0), not limits switched on."""
    for make in (Lp2Controller, Stepper):
        with pytest.raises(ValueError, match="^qdd_max: must be a number or 4 numbers, got bool"):
            make(ARM, dt=0.01, qdd_max=flag)


@pytest.mark.parametrize(
    ("field", "bad", "kind"),
    [("q0", [True, 0.1, 0.2, 0.3], "booleans"), ("q0", np.zeros(4, dtype=bool), "booleans"),
     ("q_prev", [0.0, 0.1, np.bool_(False), 0.3], "booleans"),
     ("q0", np.array([0.0, 0.1, 0.2, 0.3]) + 1e-3j, "complex numbers"),
     ("target", [1.0, True], "booleans"), ("target", [1.5 + 0j, 1.0], "complex numbers")],
)  # fmt: skip
def test_joint_coordinates_and_targets_are_real_numbers(field: str, bad, kind: str) -> None:  # type: ignore[no-untyped-def]
    """numpy reads ``True`` as 1.0 and drops an imaginary part: each would move the arm."""
    state = {"q0": [0.0, 0.1, 0.2, 0.3], "target": [1.5, 1.0], "q_prev": [0.0, 0.1, 0.2, 0.3]}
    state[field] = bad
    args = (state["q0"], state["target"], state["q_prev"])
    steps = [Lp2Controller(ARM, dt=0.01, qdd_max=5.0).step, Stepper(ARM, dt=0.01, qdd_max=5.0).step]
    out = np.empty(4)
    steps.append(lambda *a: Lp2Controller(ARM, dt=0.01, qdd_max=5.0).step_into(*a, out=out))
    for step in steps:
        with pytest.raises(ValueError, match=f"^{field}: must be .*numbers, got {kind}$"):
            step(*args)
    batch = Lp2Controller(ARM, dt=0.01, qdd_max=5.0).step_batch
    rows = {"q0": "q0", "q_prev": "q_prev", "target": "targets"}[field]
    with pytest.raises(ValueError, match=f"^{rows}: must be numbers, got {kind}$"):
        batch([args[0]], [args[1]], [args[2]])


@pytest.mark.parametrize("size", [1e13, 1e200, -1e300])
def test_a_target_too_large_in_size_is_named(size: float) -> None:
    """A target 1e200 m away overflowed the command law's norm of the difference: the
    arm stood still, status ``optimal`` and ``p = 1``. Every way to give a target names it.
    """
    q = np.array([0.0, 0.1, 0.2, 0.3])
    target = [1.5, size, 0.0]
    out = np.empty(4)
    controller = Lp2Controller(ARM, dt=0.01, qdd_max=5.0)
    steps = [controller.step, Stepper(ARM, dt=0.01, qdd_max=5.0).step,
             lambda *a: controller.step_into(*a, out=out),
             lambda *a: controller.step(a[0], np.array(a[1]), a[2])]  # fmt: skip
    for step in steps:
        with pytest.raises(
            ValueError, match=r"^target: entry \S+ at index 1 is larger than 1e\+12"
        ):
            step(q, target, q)
    with pytest.raises(ValueError, match=r"^targets: entry \S+ at index \(1, 1\) is larger"):
        controller.step_batch([q, q], [[1.5, 1.0, 0.0], target], [q, q])
    with pytest.raises(ValueError, match=r"^target: entry \S+ at index 1 is larger"):
        ClampedTarget(target)
    assert controller.step(q, [1.5, 1e12, 0.0], q).status == "optimal"  # the largest size it takes
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(["simulate", "reach", "--robot", "panda", "--target", f"0.5,0,{size}"]) == 2
    assert err.getvalue().count("\n") == 1
    assert err.getvalue().startswith("lpik: error: --target: entry ")
    assert "is larger than 1e+12" in err.getvalue()


def test_a_ragged_limit_is_named() -> None:
    """The check for booleans reads the value inside the conversion's guard."""
    with pytest.raises(ValueError, match="^qdd_max: must be a number or 4 numbers"):
        Lp2Controller(ARM, dt=0.01, qdd_max=[1.0, [2.0, 3.0]])


def test_the_cli_sets_acceleration_limits_in_rad_per_s2(tmp_path) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "run.csv"
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(["simulate", "pull-in", "--qdd-max", "2", "--steps", "150",
                     "--out", str(out)])  # fmt: skip
    assert code == 0
    with out.open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    q = np.array([[float(r[f"q{i}"]) for i in range(1, 5)] for r in rows])
    acc = np.diff(q, 2, axis=0) / 0.01**2  # from the CSV itself
    assert np.abs(acc).max() <= 2.0 * (1 + 1e-6)
    assert any(r["binding"].endswith("acceleration limit") for r in rows)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(["simulate", "pull-in", "--qdd-max", "nan"]) == 2
    assert err.getvalue().count("\n") == 1 and "--qdd-max" in err.getvalue()
