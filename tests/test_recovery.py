"""States outside their limits, and stops: the rule of :mod:`lpik.bands` on every path.

A joint past its end-stop (or a speed above its limit) moves back as fast as
its limits allow and never further out; the safe step of an infeasible problem
is a controlled stop that keeps the acceleration limits; the numpy layers and
the compiled controller take the same steps.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_reference import SATURATION_ROUNDING, plausible_last
from core_strategies import examples
from lpik import ClampedTarget, bands, planar_arm, simulate
from lpik.limits import AccelerationLimits, standard_limits
from lpik.result import INFEASIBLE, OFF_DIRECTION, OPTIMAL, RECOVERING
from lpik.robots.registry import home_configuration, load_robot

DT = 0.001

# --------------------------------------------------------------------- the rule itself


def test_yield_to_takes_the_hard_edge_nearest_the_soft_band() -> None:
    assert bands.yield_to(-1.0, 1.0, -0.5, 2.0) == (-0.5, 1.0, bands.MET)
    assert bands.yield_to(0.2, 0.4, -1.0, 0.1) == (0.2, 0.2, bands.UPPER_YIELDED)
    assert bands.yield_to(-0.4, -0.2, 0.0, 1.0) == (-0.2, -0.2, bands.LOWER_YIELDED)


@settings(max_examples=examples(300), deadline=None)
@given(
    room=st.floats(0.0, 1.0),
    speed=st.floats(0.0, 1.0),
    qdd=st.floats(0.1, 100.0),
    dt=st.sampled_from([1e-3, 1e-2]),
)
def test_braking_room_always_leaves_a_stop_before_the_end_stop(room, speed, qdd, dt) -> None:
    """From any state the bound allows, full deceleration stops before the end-stop."""
    decel = qdd * dt * dt
    u = min(speed * dt, bands.braking_room(room, decel))  # a step within the bound
    travelled, left = 0.0, room
    for _ in range(100_000):
        if u <= 0.0:
            break
        assert u <= bands.braking_room(left, decel) + 1e-12  # within every later bound (SLACK_TOL)
        travelled, left = travelled + u, left - u
        u -= decel
    assert travelled <= room + 1e-12
    assert bands.braking_room(room, math.inf) == math.inf
    assert bands.braking_room(0.0, decel) == 0.0 and bands.braking_room(-0.1, decel) == 0.0


@settings(max_examples=examples(300), deadline=None)
@given(room=st.floats(0.0, 1.0), share=st.floats(0.0, 1.0), qdd=st.floats(0.1, 100.0),
       dt=st.sampled_from([1e-3, 4e-3, 1e-2]))  # fmt: skip
def test_no_step_within_the_braking_bound_leaves_a_motion_taken_as_a_fault(
    room, share, qdd, dt
) -> None:
    """A step up to the braking distance's bound (``share`` of it) leaves a ``last`` that
    :func:`lpik.bands.stoppable_step` keeps as it is on the next step: the fault is only
    for motions the arm cannot have made under its limits. One beyond by more than one
    full deceleration is clipped to that furthest motion, continuously."""
    decel = qdd * dt * dt
    step = share * bands.braking_room(room, decel)
    left = room - step
    brake_hi = bands.braking_room(left, decel)
    kept, fault = bands.stoppable_step(step, -math.inf, brake_hi, -decel, decel)
    assert fault == bands.MET  # at the bound exactly: the same step within one rounding
    assert kept == pytest.approx(step, rel=1e-12, abs=1e-18)
    beyond = brake_hi + decel + 1e-6
    assert bands.stoppable_step(beyond, -math.inf, brake_hi, -decel, decel) == (
        brake_hi + decel, bands.UPPER_YIELDED)  # fmt: skip
    # the lower side alike, mirrored
    kept, fault = bands.stoppable_step(-step, -brake_hi, math.inf, -decel, decel)
    assert fault == bands.MET and kept == pytest.approx(-step, rel=1e-12, abs=1e-18)


def test_a_joint_outside_its_end_stop_is_pinned_back_towards_it() -> None:
    # 0.05 past q_max, 0.01 back per step: pinned at -0.01; 0.005 past: pinned onto it
    assert bands.stop_band(1.05, -1.0, 1.0, -0.01, 0.01)[:2] == (-0.01, -0.01)
    lo, hi, _, _, outside = bands.stop_band(1.005, -1.0, 1.0, -0.01, 0.01)
    assert lo == hi == pytest.approx(-0.005) and outside == 1
    assert bands.stop_band(-1.5, -1.0, 1.0, -0.01, 0.01)[4] == -1
    # within the check's tolerance it counts as on the end-stop: it may stay
    assert bands.stop_band(1.0 + 1e-12, -1.0, 1.0, -0.01, 0.01)[:2] == (-0.01, 0.0)


def test_a_band_narrower_than_the_slack_is_one_point() -> None:
    """A joint braking at its acceleration limit towards its end-stop: the braking bound
    and the acceleration bound meet to rounding. Pinned there, as where they meet exactly,
    so that a rounding of the state cannot switch LP2 between two different steps."""
    room = 1.79e-3  # to q_max; the rate band's upper edge lies a rounding above its lower
    lo, hi, *_ = bands.stop_band(1.0 - room, -2.0, 1.0, 1.1664e-3, 1.1664e-3 + 1.6e-17)
    assert lo == hi == pytest.approx(1.1664e-3, abs=1e-16)
    lo, hi, *_ = bands.stop_band(1.0 - room, -2.0, 1.0, 1.1664e-3, 1.1664e-3 + 1e-9)
    assert hi - lo == pytest.approx(1e-9)  # a real band stays one
    lo, hi, *_ = bands.stop_band(0.0, -math.inf, math.inf, -math.inf, math.inf)
    assert (lo, hi) == (-math.inf, math.inf)


@settings(max_examples=examples(200), deadline=None)
@given(q0=st.floats(-4.0, 4.0), q_min=st.floats(-3.0, 0.0), span=st.floats(0.0, 6.0),
       beyond=st.sampled_from([0.0, 1e-12, 1e-7, 1e-3]))  # fmt: skip
def test_beyond_stops_is_the_stop_bands_outside(q0, q_min, span, beyond) -> None:
    """The joints whose band no stop ahead narrows are those stop_band pins as outside."""
    q_max = q_min + span
    for q in (q0, q_min - beyond, q_max + beyond):
        outside = bands.stop_band(q, q_min, q_max, -1.0, 1.0)[4] != 0
        assert bands.beyond_stops(q, q_min, q_max) == outside


# ------------------------------------------------------------- closed loops from outside


def planar():
    """The paper's 4-link arm, with velocity limits of 1 rad/s."""
    return planar_arm([1.0, 1.0, 1.0, 1.0], q_min=np.full(4, -2.5), q_max=np.full(4, 2.5),
                      qd_max=1.0)  # fmt: skip


def starts():
    """(model, start past an end-stop, target) for the planar arm and the Panda."""
    cases = []
    arm = planar()
    q_arm = np.array([0.3, 0.4, 0.5, 0.6])
    panda = load_robot("panda")
    q_panda = home_configuration("panda")
    # the UR5e's wrist 2 has its end-stops at +-2 pi, where the wrist is singular: the
    # stop before the singular configuration must not hold it outside (lpik.bands.beyond_stops)
    ur5e = load_robot("ur5e")
    for model, q, joint, pasts in ((arm, q_arm, 1, (1e-12, 1e-3, 0.05, 0.1)),
                                   (panda, q_panda, 3, (1e-12, 1e-3, 0.05, 0.1)),
                                   (ur5e, home_configuration("ur5e"), 4, (0.05,))):  # fmt: skip
        target = model.pose(q)
        for past in pasts:
            for side in (1, -1):
                start = q.copy()
                start[joint] = (model.q_max if side > 0 else model.q_min)[joint] + side * past
                name = f"{model.kinematics.name}-{side:+d}-{past:g}"
                cases.append(pytest.param(model, start, target, joint, side, id=name))
    return cases


def outside_by(model, q: np.ndarray) -> np.ndarray:
    """How far each joint is past its end-stops (0 inside)."""
    return np.maximum(q - model.q_max, 0.0) + np.maximum(model.q_min - q, 0.0)


@pytest.mark.parametrize(("model", "start", "target", "joint", "side"), starts())
@pytest.mark.parametrize("qdd_max", [None, 10.0])
def test_a_start_past_an_end_stop_recovers_on_every_path(
    model, start, target, joint, side, qdd_max
) -> None:
    from lpik.control.controller import Lp2Controller

    steps = 120 if qdd_max is None else 400
    limits = standard_limits(model)
    if qdd_max is not None:
        limits.append(AccelerationLimits(np.full(model.n_joints, qdd_max)))
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd_max)
    log = simulate(model, ClampedTarget(target), start, steps, dt=DT, limits=limits,
                   method=controller.method)  # fmt: skip
    q, prev = start.copy(), None
    # next to the UR5e's singular wrist the engines' rounding differs by up to 2e-12
    atol = 1e-9 if model.kinematics.name == "ur5e" else 1e-12
    for k in range(steps):
        res = controller.step(q, target, prev)
        np.testing.assert_allclose(res.q, log.q[k + 1] if k + 1 < steps else log.q_end,
                                   rtol=0, atol=atol)  # fmt: skip
        assert (res.status, res.binding) == (log.status[k], log.binding[k]), k
        prev, q = q, res.q
    past = np.array([outside_by(model, q)[joint] for q in [*log.q, log.q_end]])
    assert np.all(np.diff(past) <= 1e-15)  # never further out
    assert past[-1] <= 1e-7  # back within the check's tolerance
    recovering = log.status == RECOVERING
    assert log.metrics().recovery_steps == int(recovering.sum())
    if past[0] > 1e-7:
        limit = "upper" if side > 0 else "lower"
        assert recovering[0] and log.binding[0].endswith(f"{limit} end-stop")
        # recovery takes as many steps as the joint's speed limit needs, within the accel.
        qd = model.qd_max[joint] * DT
        assert log.metrics().recovery_steps <= math.ceil(past[0] / qd) + (
            0 if qdd_max is None else math.ceil(2 * math.sqrt(past[0] / (qdd_max * DT**2)))
        )  # fmt: skip
    else:
        assert not recovering.any()
    assert set(log.status) <= {RECOVERING, OPTIMAL, INFEASIBLE, OFF_DIRECTION}
    assert np.isfinite(log.q).all()


def test_a_speed_above_its_limit_is_a_fault_taken_at_the_limit_and_named() -> None:
    # 1.05 rad/s against a limit of 1 rad/s (within one step of acceleration past it, 1.1):
    # a fault of the state, not a motion to continue, taken at the limit
    from lpik.limits import build_problem

    arm = planar()
    q = np.array([0.3, 0.4, 0.5, 0.6])
    limits = [*standard_limits(arm), AccelerationLimits(np.full(4, 100.0))]

    def problem(speed: float):  # type: ignore[no-untyped-def]
        prev = q - np.array([speed * DT, 0.0, 0.0, 0.0])
        return build_problem(arm.jacobian(q), np.zeros(2), q, limits, dt=DT, q_prev=prev,
                             joint_names=arm.joint_names, continuation=True)  # fmt: skip

    near = problem(1.05)
    assert near.recovering() == ("joint 1 upper velocity limit",)
    lower, upper = near.step_bounds()[:2]
    assert upper[0] == pytest.approx(0.001)  # the band is taken around the limit
    assert lower[0] == pytest.approx(0.001 - 100.0 * DT**2)
    assert near.motion[0] == pytest.approx(0.001)  # the motion continued: at the limit
    # exactly one step of acceleration past the limit, up to a rounding (a measured loop's
    # state taken at the edge of its plausible band after a step at the limit): at the
    # limit still, not at rest (that stopped a joint at full speed in one step)
    edge = problem(1.0 + 100.0 * DT + 1e-14 / DT)
    assert edge.recovering() == ("joint 1 upper velocity limit",)
    assert edge.step_bounds()[1][0] == pytest.approx(0.001)
    # 3 rad/s: no motion the drives can have made even one step past the limit; the
    # sample tells nothing of the motion, and the band is taken around rest
    far = problem(3.0)
    assert far.recovering() == ("joint 1 upper velocity limit",)
    lower, upper = far.step_bounds()[:2]
    assert (lower[0], upper[0]) == pytest.approx((-100.0 * DT**2, 100.0 * DT**2))


def test_a_bad_q_prev_sample_never_runs_a_joint_past_its_end_stop() -> None:
    # issue 23: one q_prev off by 0.05 rad (an implied 50 rad/s) once ran a joint 122 rad past
    from lpik.control.controller import Lp2Controller

    arm = planar()
    controller = Lp2Controller(arm, dt=DT, qdd_max=10.0)
    q = np.array([1.0, 0.4, 0.5, 0.6])
    q_prev = q - np.array([0.05, 0.0, 0.0, 0.0])
    goal = arm.pose(q)
    statuses = set()
    for _ in range(3000):
        res = controller.step(q, goal, q_prev)
        statuses.add(res.status)
        q_prev, q = q, res.q
        assert (q <= arm.q_max + 1e-9).all() and (q >= arm.q_min - 1e-9).all()
    assert RECOVERING in statuses  # the first step says the state was at fault
    assert np.abs(q - q_prev).max() < 1e-9  # and the arm comes to rest


@settings(max_examples=examples(60), deadline=None)
@given(
    on_panda=st.booleans(),
    room=st.floats(0.0, 0.3),
    speed=st.floats(0.2, 60.0),
    qdd=st.sampled_from([2.0, 10.0, 100.0]),
    dt=st.sampled_from([1e-3, 4e-3]),
    upper=st.booleans(),
    again=st.booleans(),
)
def test_a_bad_sample_near_an_end_stop_never_runs_the_joint_past_it(
    on_panda, room, speed, qdd, dt, upper, again
) -> None:
    """A joint ``room`` inside its end-stop, and one ``q_prev`` sample implying ``speed``
    times its velocity limit towards the end-stop (``again``: the same sample on two
    steps): the fault's speed is unknown, so the step it starts keeps the room to stop
    (found by a fuzz of closed loops: taken at the velocity limit, such a step ran the
    joint up to 9 mrad past its end-stop, on that very step or a few steps later; and a
    speed within the limit, too fast to stop in ``room``, up to 55 mrad)."""
    from lpik.control.controller import Lp2Controller

    model = load_robot("panda") if on_panda else planar()
    joint = 3 if on_panda else 0
    q = home_configuration("panda") if on_panda else np.array([0.3, 0.4, 0.5, 0.6])
    stop = model.q_max[joint] if upper else model.q_min[joint]
    q[joint] = stop - room if upper else stop + room
    bad = q.copy()
    bad[joint] -= (1.0 if upper else -1.0) * speed * model.qd_max[joint] * dt
    controller = Lp2Controller(model, dt=dt, qdd_max=qdd)
    goal = model.pose(q)  # and a command that moves every joint
    if on_panda:
        goal[:3, 3] += 0.2 * np.array([1.0, -1.0, 0.5])
    else:
        goal[:2] += 0.3 * np.array([1.0, -1.0])
    q_prev = bad
    for k in range(400):
        res = controller.step(q, goal, q_prev)
        if k == 0 and speed > 1.0:
            assert res.status == RECOVERING
        q_prev, q = (bad if again and k == 0 else q), res.q
        assert (q <= model.q_max + 1e-9).all() and (q >= model.q_min - 1e-9).all(), k


@pytest.mark.parametrize(("name", "joint"), [("panda", 3), ("ur5e", 1), ("iiwa14", 6)])
def test_a_motion_too_fast_to_stop_before_the_end_stop_is_not_continued_into_it(
    name: str, joint: int
) -> None:
    """A joint on its end-stop, ``q_prev`` implying 0.75 rad/s towards it (within its
    velocity limit; a fuzz's bad sample), ``dt`` 4 ms, ``qdd_max`` 5: braking at the
    acceleration limit it ran 55 mrad past the end-stop. No step of the arm's own leaves
    such a motion (the braking distance bounds every step), so it is a fault of the
    state: the step keeps the joint on its end-stop, ``recovering``, naming it."""
    from lpik.control.controller import Lp2Controller

    model = load_robot(name)
    q = home_configuration(name)
    q[joint] = model.q_min[joint]
    q_prev = q.copy()
    q_prev[joint] += 0.003
    controller = Lp2Controller(model, dt=0.004, qdd_max=5.0)
    goal = model.pose(q)
    goal[:3, 3] += [0.1, -0.1, 0.05]
    for k in range(300):
        res = controller.step(q, goal, q_prev)
        if k == 0:
            assert res.status == RECOVERING
            assert res.binding == f"{model.joint_names[joint]} lower end-stop"
        q_prev, q = q, res.q
        assert q[joint] >= model.q_min[joint] - 1e-9, k


# -------------------------------------------------------------------- random states


def _tied(problem, a, b) -> bool:  # type: ignore[no-untyped-def]
    """Whether two steps that name different joint bounds both sit on both: a tie of the
    bounds that stop p (every joint on its acceleration band, for one), either named."""
    lower, upper, _, _ = problem.step_bounds()
    named = (a.binding, b.binding)
    if any(x is None or x.kind not in ("end-stop", "velocity", "acceleration") for x in named):
        return False
    for binding in named:
        bound = (lower if binding.side == "lower" else upper)[binding.index]
        for step in (a, b):
            if abs(step.dq[binding.index] - bound) > 1e-12 * max(1.0, abs(bound)):
                return False
    return True


@st.composite
def moving_states(draw: st.DrawFn):
    """A planar arm with all three kinds of limit and a state that may be outside them:
    past an end-stop by up to 0.1 rad, or moving at up to three times its speed limit."""
    from lpik.control.controller import Lp2Controller

    n = draw(st.integers(3, 5))
    unit = st.floats(-1.0, 1.0, allow_nan=False)
    arm = planar_arm([draw(st.floats(0.3, 1.2)) for _ in range(n)], q_min=np.full(n, -1.5),
                     q_max=np.full(n, 1.5), qd_max=draw(st.floats(0.3, 2.0)))  # fmt: skip
    dt = draw(st.sampled_from([1e-3, 1e-2]))
    qdd = draw(st.sampled_from([2.0, 10.0, 100.0]))
    controller = Lp2Controller(arm, dt=dt, v_max=0.5, qdd_max=qdd,
                               lambda_bound=draw(st.sampled_from([None, 1.0])))  # fmt: skip
    q0 = np.array([1.6 * draw(unit) for _ in range(n)])  # up to 0.1 past either end-stop
    speed = draw(st.sampled_from([0.0, 0.5, 1.0, 3.0]))  # in units of qd_max
    q_prev = q0 - speed * arm.qd_max * dt * np.array([draw(unit) for _ in range(n)])
    goal = arm.pose(q0) + np.append([0.3 * draw(unit), 0.3 * draw(unit)], 0.0)
    return controller, q0, goal, q_prev


@settings(max_examples=examples(300), deadline=None)
@given(state=moving_states())
def test_every_step_from_any_state_keeps_the_contract(state) -> None:
    from lpik.check import task_residual
    from lpik.methods import solve
    from lpik.methods.lp2 import lp2

    controller, q0, goal, q_prev = state
    arm, dt = controller.model, controller.dt
    qdd = controller.limits[-1].qdd_max
    problem = controller.problem(q0, goal, q_prev)
    fast = controller.step(q0, goal, q_prev)
    regular = np.linalg.svd(problem.J, compute_uv=False)[-1] > 1e-6  # far from a singularity
    # the controller's method (lp2s) and plain LP2, each compiled against numpy; a step
    # around the motion (lpik.continuation) scales the change dw - J last, whose terms
    # nearly cancel while the arm moves: the two ratio tests' rounding (1.2e-12 seen)
    pairs = [(fast, solve(problem, controller.method), SATURATION_ROUNDING),
             (lp2(problem, path="compiled"), lp2(problem), 1e-11)]  # fmt: skip
    for compiled, reference, atol in pairs:
        if compiled.status == OFF_DIRECTION:  # the stall stage's step: its own parity tests
            continue
        if compiled.path == "compiled" and reference.path == "ratio-test" and regular:
            assert compiled.status == reference.status
            if compiled.status != INFEASIBLE:  # an infeasible step's conflict may be a tie
                assert compiled.binding == reference.binding or _tied(
                    problem, compiled, reference
                ), (compiled.binding, reference.binding)
            np.testing.assert_allclose(compiled.q, reference.q, rtol=0, atol=atol)
    # a speed above the limit is a fault of the state, taken at the limit, and no faster
    # than the joint can still stop before its end-stop; so is a motion more than one
    # braking step beyond what the joint can stop from (lpik.bands.rate_band)
    last = plausible_last(q0, q_prev, arm, qdd, dt)
    tol = 1e-9
    for res in (fast, solve(problem, "lp1"), solve(problem, "l1")):
        assert np.isfinite(res.q).all() and 0.0 <= res.p <= 1.0
        assert (np.abs(res.dq - last) <= qdd * dt * dt + tol).all()  # never broken
        before, after = outside_by(arm, q0), outside_by(arm, res.q)
        if res.status == RECOVERING:
            assert res.binding in problem.recovering()
            # never further out, unless it brakes at its acceleration limit (it was moving out)
            braking = np.abs(res.dq - last) >= qdd * dt * dt - tol
            assert ((after <= before + tol) | braking).all()
        else:
            assert not problem.recovering()
            assert (after <= tol).all() and (np.abs(res.dq) <= arm.qd_max * dt + tol).all()
        if res.status == OFF_DIRECTION:  # the stall stage left the direction, within the limits
            assert res.p == 0.0
            continue
        if res.moved and not (res.status == RECOVERING and res.p == 0.0):  # a safe step may not
            # J dq = p dw, around the current motion (lpik.continuation; l1 takes LP1's p)
            assert task_residual(problem, res.dq, res.p) <= 1e-7
