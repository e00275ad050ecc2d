"""Limits as data, stacked into one problem by build_problem (eqs. 13-14, sec. 3.2, rows)."""

from __future__ import annotations

import numpy as np
import pytest

from lpik.limits import (
    AccelerationLimits,
    AutomaticMultiplierBounds,
    EndStops,
    LinearRows,
    MultiplierBounds,
    StepContext,
    VelocityLimits,
    build_problem,
    standard_limits,
)
from lpik.methods import lp2
from lpik.robots.planar import planar_arm

J = [[1.0, 0.5, 0.25], [0.0, 1.0, 0.5]]
Q0 = np.array([0.1, 0.2, 0.3])


def test_velocity_limits_scale_with_dt() -> None:
    piece = VelocityLimits([1.0, 2.0, 3.0]).apply(StepContext(Q0, 0.01))
    np.testing.assert_allclose(piece.dq_max, [0.01, 0.02, 0.03])
    np.testing.assert_allclose(piece.dq_min, [-0.01, -0.02, -0.03])
    assert piece.kind == "velocity limit"
    asym = VelocityLimits(qd_max=1.0, qd_min=-0.5).apply(StepContext(Q0, 0.1))
    assert (asym.dq_min, asym.dq_max) == pytest.approx((-0.05, 0.1))


def test_acceleration_limits_follow_the_previous_step() -> None:
    limit = AccelerationLimits(10.0)
    piece = limit.apply(StepContext(Q0, 0.1))
    assert (piece.qdd_min, piece.qdd_max, piece.kind) == (-10.0, 10.0, "acceleration limit")
    at_rest = build_problem(J, [0.0, 0.0], Q0, [limit], dt=0.1)
    np.testing.assert_allclose(
        [at_rest.dq_min, at_rest.dq_max], [np.full(3, -0.1), np.full(3, 0.1)]
    )
    moving = build_problem(J, [0.0, 0.0], Q0, [limit], dt=0.1, q_prev=Q0 - 0.05)
    np.testing.assert_allclose(moving.dq_min, np.full(3, -0.05))
    np.testing.assert_allclose(moving.dq_max, np.full(3, 0.15))
    assert moving.dq_max_kind == ("acceleration limit",) * 3


def test_build_problem_keeps_the_tightest_bound_and_its_kind() -> None:
    P = build_problem(
        J,
        [0.01, 0.0],
        Q0,
        [
            EndStops(q_min=-1.0, q_max=[1.0, 0.205, 1.0]),
            VelocityLimits(1.0),
            AccelerationLimits([500.0, 500.0, 0.5]),
        ],
        dt=0.01,
    )
    np.testing.assert_allclose(P.q_max, [1.0, 0.205, 1.0])
    # joint 2 can stop within its 0.005 to the end-stop (braking distance bounds the speed)
    np.testing.assert_allclose(P.dq_max, [0.01, 0.005, 0.00005])
    assert P.dq_max_kind == ("velocity limit", "end-stop", "acceleration limit")
    _, upper, _, upper_labels = P.step_bounds()
    np.testing.assert_allclose(upper, [0.01, 0.005, 0.00005])
    assert upper_labels == (
        "joint 1 upper velocity limit",
        "joint 2 upper end-stop",
        "joint 3 upper acceleration limit",
    )


def test_later_end_stops_only_tighten() -> None:
    P = build_problem(
        J, [0.0, 0.0], Q0, [EndStops(-1.0, 1.0), EndStops([-2.0, -0.5, -2.0], 2.0)], dt=0.1
    )
    np.testing.assert_array_equal(P.q_min, [-1.0, -0.5, -1.0])
    np.testing.assert_array_equal(P.q_max, [1.0, 1.0, 1.0])


def test_multiplier_bounds_and_rows_reach_the_problem() -> None:
    P = build_problem(
        J,
        [0.01, 0.0],
        Q0,
        [
            MultiplierBounds.symmetric(0.5),
            LinearRows([[1.0, 0.0, 0.0]], [0.5], labels=("wall",)),
            LinearRows([[0.0, 1.0, 1.0], [0.0, 0.0, 1.0]], [1.0, 1.0]),
        ],
        dt=0.01,
        M=[1.0, 2.0, 3.0],
    )
    np.testing.assert_array_equal(P.lam_min, [-0.5, -0.5])
    np.testing.assert_array_equal(P.lam_max, [0.5, 0.5])
    assert P.G.shape == (3, 3)
    assert P.row_labels == ("wall", "row 1", "row 2")
    np.testing.assert_array_equal(np.diag(P.M), [1.0, 2.0, 3.0])


def test_a_binding_acceleration_limit_is_named_by_lp2() -> None:
    P = build_problem(
        J,
        [0.01, 0.0],
        Q0,
        [VelocityLimits(1.0), AccelerationLimits(1.0)],
        dt=0.01,
    )
    res = lp2(P)
    assert res.p < 1.0
    assert res.binding is not None and res.binding.endswith("acceleration limit")


def test_standard_limits_of_a_model() -> None:
    arm = planar_arm([1.0, 1.0], q_min=-1.0, q_max=1.0, qd_max=2.0)
    limits = standard_limits(arm)
    P = build_problem(arm.jacobian([0.0, 0.5]), [0.0, 0.0], [0.0, 0.5], limits, dt=0.1)
    np.testing.assert_array_equal(P.q_min, [-1.0, -1.0])
    np.testing.assert_allclose(P.dq_max, [0.2, 0.2])
    unlimited = planar_arm([1.0, 1.0])
    # end-stops, and LP2's automatic multiplier bound (a default that adds no bound here)
    assert [type(lim) for lim in standard_limits(unlimited)] == [
        EndStops,
        AutomaticMultiplierBounds,
    ]
    assert len(standard_limits(arm, velocity=False, lambda_bound=None)) == 1
    assert isinstance(standard_limits(arm, lambda_bound=0.5)[-1], MultiplierBounds)


@pytest.mark.parametrize("dt", [0.0, -0.01, float("nan"), float("inf"), "0.01", True, 1e-200, 1e13])
def test_bad_dt_is_named(dt: object) -> None:
    with pytest.raises(ValueError, match="^dt:"):
        build_problem(J, [0.0, 0.0], Q0, [], dt=dt)  # type: ignore[arg-type]


@pytest.mark.parametrize("bound", [0.0, -1.0, float("nan")])
def test_symmetric_multiplier_bound_must_be_positive(bound: float) -> None:
    with pytest.raises(ValueError, match="lambda bound"):
        MultiplierBounds.symmetric(bound)


def test_nan_in_a_limit_is_named() -> None:
    with pytest.raises(ValueError, match="^qd_max:"):
        build_problem(J, [0.0, 0.0], Q0, [VelocityLimits([1.0, np.nan, 1.0])], dt=0.01)
