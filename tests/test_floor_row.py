"""The automatic bound's floor as one row on the stall stage's progress step.

Where the arm's motion has reached the floor under acceleration limits, the
progress step keeps ``sigma_min``'s first-order change within a slow creep
(:func:`lpik.methods.autobound.floor_row`) instead of the stop ahead's braking
band, which alternated with a free step: the acceleration reversing on every
step (:mod:`lpik.methods.autobound`). The row is the derivative of ``sigma_min``;
the compiled twin and the numpy stepper take the same steps.
"""

from __future__ import annotations

import math

import numpy as np

from lpik.control.controller import Lp2Controller
from lpik.control.stepper import Stepper
from lpik.fast import layout
from lpik.fast.autobound import floor_in_state
from lpik.limits import AutomaticMultiplierBounds
from lpik.methods.autobound import floor_row
from lpik.result import OFF_DIRECTION
from lpik.robots.registry import home_configuration, load_robot
from lpik.tolerances import FLOOR_CREEP_TIME

DT, QDD = 1e-3, 10.0
#: A goal of benchmarks/random_goals.py (UR5e, seed 0, goal 25), rounded: on the way the
#: arm reaches the floor beside its shoulder singularity and slides along it.
GOAL_25 = np.array([-5.542, -1.526, -2.383, 1.726, -2.558, 2.292])


def sigma_min(model, q) -> float:
    return float(np.linalg.svd(model.jacobian(q), compute_uv=False)[-1])


def test_the_row_is_the_first_order_change_of_sigma_min_and_compiles_alike() -> None:
    model, limit = load_robot("ur5e"), AutomaticMultiplierBounds()
    rng = np.random.default_rng(3)
    q = home_configuration("ur5e")
    q[2] = 2e-3  # the elbow nearly stretched: sigma_min / sigma_max about 1e-3
    J = model.jacobian(q)
    s = np.linalg.svd(J, compute_uv=False)
    assert s[-1] < limit.activation * s[0]
    row, creep = np.empty(6), DT / FLOOR_CREEP_TIME
    rhs = floor_row(J, model.jacobian, q, limit.activation, limit.floor, limit.probe, DT, row)
    expected = max(s[-1] - limit.floor * s[0], 0.0) + creep * limit.floor * s[0]
    assert math.isclose(rhs, expected, rel_tol=1e-12)
    for _ in range(5):  # -row . d is d(sigma_min) along d, to first order
        d = rng.normal(size=6) * 1e-6
        change = sigma_min(model, q + d) - sigma_min(model, q)
        assert abs(change + row @ d) <= 1e-3 * np.abs(row).sum() * np.abs(d).max() + 1e-12
    controller = Lp2Controller(model, dt=DT, qdd_max=QDD)
    controller.step(q, model.pose(q), q)  # the state holds q's J and the bound's parameters
    compiled = np.empty(7)
    assert math.isclose(floor_in_state(controller._state, q, compiled), rhs, rel_tol=1e-9)
    np.testing.assert_allclose(compiled[:6], row, rtol=1e-6, atol=1e-9 * np.abs(row).max())
    far = home_configuration("ur5e")  # far from singular: no row
    assert floor_row(model.jacobian(far), model.jacobian, far, limit.activation, limit.floor,
                     limit.probe, DT, row) == math.inf  # fmt: skip


def test_at_the_floor_the_progress_step_slides_without_chatter_on_both_paths() -> None:
    """UR5e towards random goal 25 under acceleration limits: 3,000 steps, more than 400 of
    them progress steps at the floor. Joint accelerations reversing at more than half
    their limit both times: 29 (with the stop ahead's band instead of the row: 661, the
    two-step cycle). The numpy stepper (HiGHS) takes the compiled controller's steps."""
    model = load_robot("ur5e")
    goal = model.pose(GOAL_25)
    controller = Lp2Controller(model, dt=DT, qdd_max=QDD)
    stepper = Stepper(model, dt=DT, qdd_max=QDD)
    q = prev = home_configuration("ur5e")
    change_before, reversals, on_floor, compared = np.zeros(6), 0, 0, 0
    for k in range(3000):
        res = controller.step(q, goal, prev)
        at_floor = layout.vector(controller._state, layout.SINGULAR)[0] == 0.0
        on_floor += at_floor and res.status == OFF_DIRECTION
        if 1500 <= k < 1700:  # the first steps at the floor
            ref = stepper.step(q, goal, prev)
            assert ref.status == res.status, k
            np.testing.assert_allclose(ref.q, res.q, rtol=0, atol=1e-9)
            compared += at_floor and stepper.floor_reached is not None
        change = (res.q - q) - (q - prev)
        assert np.all(np.abs(change) <= QDD * DT * DT * (1 + 1e-9) + 1e-15)
        half = 0.5 * QDD * DT * DT
        reversals += bool(np.any((change * change_before < 0) & (np.abs(change) > half)
                                 & (np.abs(change_before) > half)))  # fmt: skip
        change_before, prev, q = change, q, res.q
    assert on_floor > 400 and compared > 50
    assert reversals <= 60
