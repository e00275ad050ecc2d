"""A user's rows ``G q <= h`` under acceleration limits keep a stop ahead, as the end-stops do
(lpik.bands.row_deceleration, braked_room; lpik.limits.build_problem and the compiled step's
brake_rows): the deceleration against a brute force, closed loops that run at a row at full
command on both engines, and random planar arms."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_strategies import examples
from lpik import home_configuration, load_robot, planar_arm
from lpik.bands import ROW_BRAKING_SHARE, braked_room, braking_room, row_deceleration
from lpik.control.stepper import Stepper
from lpik.limits import AccelerationLimits, LinearRows, build_problem

DT = 0.001


@settings(max_examples=examples(100), deadline=None)
@given(seed=st.integers(0, 2**32 - 1), sign=st.sampled_from([-1.0, 1.0]))
def test_a_rows_deceleration_is_the_most_its_band_lowers_it(seed, sign) -> None:
    """row_deceleration against the band's corners: the most ``sign row . dq`` can fall below
    its value at the last step, each joint within ``last + [qdd_min, qdd_max] dt^2``."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    row = rng.normal(size=n) * rng.integers(0, 2, n)
    qdd_min, qdd_max = -rng.uniform(0.5, 20.0, n), rng.uniform(0.5, 20.0, n)
    corners = np.array(list(itertools.product(*zip(qdd_min, qdd_max)))) * DT**2
    expected = -min(sign * corners @ row)
    found = row_deceleration(row, sign, qdd_min, qdd_max, DT)
    assert found == pytest.approx(expected, abs=1e-15)
    qdd_min[0] = -np.inf  # no lower limit on joint 1: it stops at once where it lowers the row
    assert row_deceleration(row, sign, qdd_min, qdd_max, DT) == (
        np.inf if sign * row[0] > 0 else found
    )


def test_a_rows_room_is_what_the_joints_can_still_brake_from() -> None:
    assert braked_room(-0.01, 1e-5) == -0.01 and braked_room(0.0, 1e-5) == 0.0  # met or broken
    assert braked_room(0.01, 0.0) == 0.01 and braked_room(0.01, np.inf) == 0.01  # nothing brakes
    assert braked_room(0.01, 1e-5) == braking_room(0.01, ROW_BRAKING_SHARE * 1e-5) < 0.01
    # build_problem: the row's right-hand side about q0 is that room, the rows of no joint aside
    G, h = np.array([[1.0, -0.5], [0.0, 0.0]]), np.array([0.3, 1.0])
    q0 = np.array([0.2, 0.1])
    limits = [LinearRows(G, h), AccelerationLimits([10.0, 10.0])]
    problem = build_problem(np.eye(2), np.zeros(2), q0, limits, dt=DT, q_prev=q0)
    deceleration = 1.5 * 10.0 * DT**2
    np.testing.assert_allclose(problem.h - G @ q0, [braked_room(0.15, deceleration), 1.0])
    loose = build_problem(np.eye(2), np.zeros(2), q0, limits, dt=DT, q_prev=q0, brake_rows=False)
    np.testing.assert_array_equal(loose.h, h)


def run_at_the_wall(compiled: bool, steps: int = 1500):  # type: ignore[no-untyped-def]
    """The Panda's joint 1 driven at full command (the peers' V = error / dt) for 1 rad beyond a
    user's row ``q_1 <= home + 0.3``, 10 rad/s^2: the worst excess over the row, the statuses,
    how many steps the row bound, and the steps."""
    panda, q = load_robot("panda"), home_configuration("panda")
    G, h = np.eye(1, 7), np.array([q[0] + 0.3])
    goal = panda.pose(np.r_[q[0] + 1.0, q[1:]])
    options = dict(dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    if compiled:
        from lpik.control.controller import Lp2Controller

        stepper = Lp2Controller(panda, G=G, h=h, row_labels=("wall",), compile="now", **options)
    else:
        stepper = Stepper(panda, rows=(G, h, ("wall",)), **options)
    q_prev, worst, statuses, bound, taken = q.copy(), -np.inf, set(), 0, []
    for _ in range(steps):
        result = stepper.step(q, goal, q_prev)
        q_prev, q = q, np.asarray(result.q, dtype=np.float64)
        worst, statuses = max(worst, float(G[0] @ q - h[0])), statuses | {result.status}
        bound += "wall" in (result.binding or "")
        taken.append(q)
    return worst, statuses, bound, np.array(taken)


def test_a_panda_driven_at_a_users_row_brakes_for_it_on_both_engines() -> None:
    """Before the stop ahead, joint 1 ran 16 mrad past the row, 114 steps infeasible. Now the
    row brakes it in time (the arm then settles where the other joints bring the tool nearest),
    no step is a stop, and the two engines take the same steps."""
    pytest.importorskip("numba")
    worst, statuses, bound, steps = run_at_the_wall(compiled=False, steps=700)
    assert worst <= 1e-9 and statuses <= {"optimal", "off_direction"}
    assert bound > 0  # the row did hold joint 1 back
    compiled_run = run_at_the_wall(compiled=True, steps=700)
    assert compiled_run[:3] == (pytest.approx(worst, abs=1e-9), statuses, bound)
    np.testing.assert_allclose(compiled_run[3], steps, rtol=0, atol=1e-9)


@st.composite
def planar_walls(draw):  # type: ignore[no-untyped-def]
    """A planar arm at rest, a row on two of its joints with room at the start, a target."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = int(rng.integers(3, 6))
    arm = planar_arm(np.ones(n), q_min=-np.pi, q_max=np.pi, qd_max=2.0)
    q0 = rng.uniform(-1.0, 1.0, n)
    G = np.zeros((1, n))
    G[0, rng.choice(n, size=2, replace=False)] = rng.uniform(0.3, 1.0, 2) * rng.choice([-1, 1], 2)
    h = G @ q0 + rng.uniform(0.0, 0.4)
    target = np.r_[rng.uniform(-2.0, 2.0, 2), rng.uniform(-np.pi, np.pi)]
    return arm, q0, G, h, target


@settings(max_examples=examples(30), deadline=None)
@given(case=planar_walls())
def test_no_closed_loop_step_of_a_planar_arm_breaks_a_users_row(case) -> None:
    """Random planar arms from rest towards random targets at full command, 10 rad/s^2, a row
    on two joints: no step puts the arm past the row."""
    arm, q, G, h, target = case
    stepper = Stepper(arm, dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6, rows=(G, h, ("wall",)))
    q_prev = q.copy()
    for _ in range(400):
        result = stepper.step(q, target, q_prev)
        q_prev, q = q, np.asarray(result.q, dtype=np.float64)
        assert G[0] @ q - h[0] <= 1e-9, result.status


@pytest.mark.parametrize("compiled", [False, True], ids=["numpy", "compiled"])
def test_a_panda_walking_at_three_users_rows_never_passes_one(compiled) -> None:
    """The soak's random walk at full command, 10 rad/s^2, a bad q_prev sample now and then,
    three random rows on the joints a few tenths of a radian from home. Before the rows stage
    took the joints' own bands, a braking stop whose bands the stops ahead of the motion had
    pinned passed a row: by 0.97 urad within these steps, by up to 7.7 urad in 20,000 (the
    compiled engine); before the stop ahead of a row, by up to 0.27 rad."""
    from lpik_bench.closed_loops import BAD_SAMPLE_EVERY, BAD_SAMPLE_SIZE, RADIUS
    from lpik_bench.soak import Walk

    rng = np.random.default_rng(1)
    panda, q = load_robot("panda"), home_configuration("panda")
    G = rng.normal(size=(3, 7)) * rng.integers(0, 2, (3, 7))
    G /= np.linalg.norm(G, axis=1, keepdims=True)
    h = G @ q + rng.uniform(0.1, 0.5, 3)
    options = dict(dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6)
    if compiled:
        pytest.importorskip("numba")
        from lpik.control.controller import Lp2Controller

        stepper = Lp2Controller(panda, G=G, h=h, row_labels=tuple("abc"), compile="now", **options)
    else:
        stepper = Stepper(panda, rows=(G, h, tuple("abc")), **options)
    q_prev, start = q.copy(), panda.pose(q)
    walk, held = Walk(start, rng, center=start[:3, 3], radius=RADIUS), 0
    for _ in range(1500 if compiled else 1400):
        given = q_prev
        if rng.random() < 1.0 / BAD_SAMPLE_EVERY:
            given = q_prev + rng.normal(0.0, BAD_SAMPLE_SIZE, 7)
        result = stepper.step(q, walk.next(), given)
        q_prev, q = q, np.asarray(result.q, dtype=np.float64)
        assert np.max(G @ q - h) <= 1e-7, result.status  # the rows' check (FEASIBILITY_TOL)
        held += result.binding is not None and result.binding.kind == "row"
    assert held > 50
