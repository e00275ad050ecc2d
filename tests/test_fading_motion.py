"""A motion that stops paying is braked in time under acceleration limits (issue 23, item 1).

An arm pushed towards a target beyond its reach stretches towards the edge of its
workspace, where the task Jacobian is singular; its motion reduces the task error less
and less. Without acceleration limits the progress step stops where moving on buys less
than its price. With them the joints cannot stop at once: the motion coasted past the
stretched pose into joint 4's end-stop, from where no step that reduces the error leads
back, and the arm stayed 0.3-0.4 m from the home pose it was brought back to. The fading
motion's stop (:func:`lpik.continuation.fading_steps`, :func:`lpik.bands.fading_band`)
brakes it in time, on the numpy and the compiled paths alike. Where the command is small
(the law has shrunk it near the stretched pose) the motion stops paying before the stop
can act, and the exact step sped joint 4 up towards the stretched pose at its acceleration
limit; the stop before a singular configuration (:func:`lpik.methods.autobound.singular_steps`,
in the step solved again under the automatic multiplier bound) brakes it before the bound's
floor.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from core_strategies import examples
from lpik.bands import braking_room, fading_band
from lpik.continuation import fading_steps
from lpik.control.controller import Lp2Controller
from lpik.control.stepper import Stepper
from lpik.fast import layout
from lpik.fast.autobound import singular_steps as compiled_singular_steps
from lpik.limits import build_problem
from lpik.methods.autobound import singular_memo, singular_steps
from lpik.robots.registry import home_configuration, load_robot
from lpik.tolerances import FADING_HOLD_SHARE, MOTION_WEIGHT, REST_STEP
from lpik_bench.excursions import DT, targets

QDD = 10.0


def test_the_steps_until_the_motion_stops_paying_are_the_linear_extrapolation() -> None:
    J = np.eye(2)
    dw, last = np.array([1.0, 0.0]), np.array([0.01, 0.0])
    before = np.array([0.012, 0.0])  # the same motion bought 12 mm a step ago, 10 mm now
    gain, gain_before, price = 0.01, 0.012, MOTION_WEIGHT * 0.01
    assert fading_steps(J, dw, last, before) == pytest.approx(
        (gain - price) / (gain_before - gain), rel=1e-12
    )
    assert fading_steps(J, dw, last, np.array([0.008, 0.0])) == math.inf  # it pays more
    assert fading_steps(J, dw, -last, -before) == math.inf  # it does not pay
    assert fading_steps(J, dw, np.zeros(2), np.zeros(2)) == math.inf  # at rest
    # a gain that falls by rounding only does not fall (GAIN_RTOL of the command's scale)
    assert fading_steps(J, dw, last, np.array([0.01 + 1e-17, 0.0])) == math.inf


def test_a_joint_moving_by_rounding_is_at_rest_for_the_stop_ahead() -> None:
    """A last step at most REST_STEP has no direction: the stop ahead leaves its band as it
    is, however far away the stop (``steps * last`` would put the edge at 8e-6 rad here)."""
    band = (-1e-4, 1e-4, -1.0, 1.0, 0.01)
    for last in (-2.2e-20, 2.2e-20, -REST_STEP, REST_STEP):
        assert fading_band(last, 3.6e14, *band) == (-1e-4, 1e-4, False, False)
    assert fading_band(-2 * REST_STEP, 10.0, *band)[2]  # beyond rounding it is a motion


@settings(max_examples=examples(200), deadline=None)
@given(
    last=st.floats(-3e-3, 3e-3).filter(lambda v: abs(v) > 1e-9),
    steps=st.floats(0.0, 500.0),
    width=st.floats(1e-5, 1e-3),
)
def test_a_joint_keeps_the_room_to_stop_at_the_fading_point(
    last: float, steps: float, width: float
) -> None:
    """Within its acceleration band, braking at the limit from the band's edge stops within
    ``steps * last`` (or the band's other edge, the least it can move, is taken); near the
    stop (FADING_HOLD_SHARE) the edge of a joint that cannot stop within one step is at
    most its step now."""
    decel = QDD * (DT * DT)  # as fading_band rounds it
    lo, hi = last - decel, last + decel
    lo, hi = min(lo, last - width), max(hi, last + width)
    new_lo, new_hi, lo_fades, hi_fades = fading_band(last, steps, lo, hi, -QDD, QDD, DT, steps)
    assert lo <= new_lo <= new_hi <= hi
    room = steps * abs(last)
    edge = new_hi if last > 0 else -new_lo
    least = lo if last > 0 else -hi  # the band's other edge, in the direction of motion
    travelled, speed = 0.0, edge
    while speed > 0.0:
        travelled += speed
        speed -= decel
    assert travelled <= room + 1e-15 or edge == pytest.approx(least, abs=1e-15)
    expected = braking_room(room, decel)
    if abs(last) > decel and braking_room(FADING_HOLD_SHARE * room, decel) < abs(last):
        expected = min(expected, abs(last))  # near the stop: no speeding up, unless it
        # can stop within one step
    given_edge = hi if last > 0 else -lo
    assert edge == pytest.approx(max(min(expected, given_edge), least), abs=1e-15)
    assert (hi_fades if last > 0 else lo_fades) == (edge < (hi if last > 0 else -lo))
    assert not (lo_fades if last > 0 else hi_fades)


def test_near_the_fading_stop_a_joint_does_not_speed_up_towards_it() -> None:
    """1 rad/s under 10 rad/s^2 stops within 0.05 rad: with the motion's own stop 0.06 rad
    ahead the band lets the joint coast or slow down, with it 0.2 rad ahead speed up as
    well, and so does a stop before a singular configuration 0.06 rad ahead (``hold``
    infinite: its own rule holds there); the same for a joint moving the other way."""
    last, decel = 1e-3, QDD * DT * DT
    lo, hi = last - decel, last + decel
    assert braking_room(0.06, decel) > hi  # the stop alone would let it speed up
    for sign in (1.0, -1.0):
        band = (*sorted((sign * lo, sign * hi)), -QDD, QDD, DT)
        near = fading_band(sign * last, 60.0, *band, 60.0)
        far = fading_band(sign * last, 200.0, *band, 200.0)
        singular = fading_band(sign * last, 60.0, *band)
        edge_near, edge_far, edge_singular = (b[1] if sign > 0 else -b[0]
                                              for b in (near, far, singular))  # fmt: skip
        assert edge_near == pytest.approx(last, abs=1e-18) and edge_far == pytest.approx(hi)
        assert edge_singular == pytest.approx(hi)
        assert near[3 if sign > 0 else 2] and not far[2] and not far[3]


def excursion(model, q0, axis, steps=None):  # type: ignore[no-untyped-def]
    """The benchmark's excursion (:mod:`lpik_bench.excursions`) 0.8 m along ``axis``."""
    unit = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return list(itertools.islice(targets(model.pose(q0), unit, 0.8), steps))


@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 0, 1)])
def test_pushed_beyond_reach_under_acceleration_limits_it_comes_back(axis: tuple) -> None:
    """The Panda under acceleration limits, the target driven far beyond reach and back
    (the command unclamped, as the peers get it): joint 4 stops short of its end-stop, and
    the arm is back on the home pose within every limit. Without the fading motion's stop
    both directions ended 0.3-0.4 m off, joint 4 on its upper end-stop."""
    model, q0 = load_robot("panda"), home_configuration("panda")
    controller = Lp2Controller(model, dt=DT, qdd_max=QDD, v_max=1e6, w_max=1e6)
    q, prev = q0.copy(), q0.copy()
    worst_acceleration, closest_to_stop = 0.0, math.inf
    for target in excursion(model, q0, axis):
        res = controller.step(q, target, prev)
        assert np.all(res.q >= model.q_min - 1e-9) and np.all(res.q <= model.q_max + 1e-9)
        worst_acceleration = max(worst_acceleration, np.abs(res.q - 2 * q + prev).max() / DT**2)
        closest_to_stop = min(closest_to_stop, model.q_max[3] - res.q[3])
        prev, q = q, res.q
    home = model.pose(q0)
    assert np.linalg.norm(model.pose(q)[:3, 3] - home[:3, 3]) < 1e-5
    assert worst_acceleration <= QDD * (1 + 1e-9)
    assert closest_to_stop > 0.05  # it used to rest on joint 4's end-stop


def test_the_fading_motion_s_stop_is_alike_on_both_paths() -> None:
    """Along the stretch towards the edge of the workspace under acceleration limits, the
    compiled controller and the numpy stepper take the same steps, and the stop ahead
    narrows the bands on some of them (labelled as the acceleration limit's)."""
    model, q0 = load_robot("panda"), home_configuration("panda")
    options = dict(dt=DT, qdd_max=QDD, v_max=1e6, w_max=1e6)
    controller, stepper = Lp2Controller(model, **options), Stepper(model, **options)
    q, prev = q0.copy(), q0.copy()
    narrowed = 0
    for target in excursion(model, q0, (1, 0, 0), 1300):
        res, ref = controller.step(q, target, prev), stepper.step(q, target, prev)
        np.testing.assert_allclose(res.q, ref.q, rtol=0, atol=1e-9)
        assert (res.status, res.binding) == (ref.status, ref.binding)
        if not np.array_equal(q, prev):  # the bounds with and without the stop ahead
            J = model.jacobian(q)
            dw = stepper.command(q, target, prev, J)  # the same step asked again: the same
            braked = stepper.limited(q, dw, prev, J).step_bounds()
            coasting = build_problem(
                J, dw, q, stepper.limits, dt=DT, q_prev=prev, continuation=True, **stepper.weights
            ).step_bounds()
            tighter = (braked[0] > coasting[0]) | (braked[1] < coasting[1])
            if tighter.any():
                narrowed += 1
                for i in np.flatnonzero(tighter):
                    side = 3 if braked[1][i] < coasting[1][i] else 2
                    assert braked[side][i].endswith("acceleration limit"), braked[side][i]
        prev, q = q, res.q
    assert narrowed > 10


def test_the_steps_to_the_singular_floor_are_the_linear_extrapolation() -> None:
    """``sigma_min`` 0.011 a step ago, 0.010 now (``sigma_max`` 1): 9 steps to the floor
    0.001; none far from singular, where ``sigma_min`` grows, or without the rule."""

    def steps(J, before, activation=0.05):  # type: ignore[no-untyped-def]
        return singular_steps(J, before, activation, 1e-3, singular_memo())

    J, before = np.diag([1.0, 0.010]), np.diag([1.0, 0.011])
    assert steps(J, before) == pytest.approx(9.0, rel=1e-12)
    assert steps(before, J) == math.inf  # it leaves the singularity
    assert steps(np.diag([1.0, 0.1]), np.diag([1.0, 0.2])) == math.inf
    assert steps(J, before, 0.0) == math.inf  # no automatic bound
    assert steps(np.diag([1.0, 5e-4]), np.diag([1.0, 6e-4])) == 0.0
    # a fall within rounding (SINGULAR_RTOL of sigma_max) is no fall
    assert steps(J, np.diag([1.0, 0.010 + 9e-16])) == math.inf


@settings(max_examples=examples(100), deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-6, -1), st.floats(-0.2, 0.2))
def test_the_singular_floor_is_alike_compiled(seed: int, exponent: float, change: float) -> None:
    """The fused step's twin (one-sided Jacobi SVD) gives the numpy rule's steps."""
    rng = np.random.default_rng(seed)
    U, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(7, 7)))
    values = np.sort(rng.uniform(0.2, 1.5, 6))[::-1]
    values[-1] = 10.0**exponent
    J = U @ np.diag(values) @ V[:6]
    values[-1] *= 1.0 + change
    before = U @ np.diag(values) @ V[:6]
    gap = abs(10.0**exponent * change)
    expected = singular_steps(J, before, 0.05, 1e-3, singular_memo())
    found = compiled_singular_steps(J, before, 0.05, 1e-3, singular_memo())
    # a change below the two SVDs' rounding (1e-16 of sigma_max) has no sign to agree on
    # (a CI draw: 1e-17, one engine at the floor, the other not): both call it no fall
    if gap < 1e-13:
        assert found == expected == math.inf
        return
    assume(gap > 1e-11)  # away from the rounding threshold (SINGULAR_RTOL) itself
    # the steps divide by sigma_min's change: the two SVDs' rounding (1e-16 of sigma_max)
    # over a change of 3e-11 (change 1e-9) differed by 5e-6 of the steps
    rel = 1e-6 + 1e-14 / gap
    assert found == expected or found == pytest.approx(expected, rel=rel, abs=1e-9)


@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 0, 1), (-1, 1, 1)])
def test_pushed_a_metre_beyond_reach_it_stops_before_the_stretched_pose(axis: tuple) -> None:
    """1 m beyond reach the law shrinks the command near the stretched pose, the motion
    stops paying, and the exact step sped joint 4 past the pose of greatest reach into its
    end-stop (the arm then ended 0.3-0.4 m off home); the stop before the singular
    configuration holds it short of there, and the arm comes home within every limit.
    Whether it comes home along (-1, 1, 1) is chaotic past the way out: from states a few
    mrad off this run's, 33 to 37 of 40 draws do (benchmarks/excursions.py, on the Panda);
    a change that fails here is to be weighed on those tallies, not on this run alone."""
    model, q0 = load_robot("panda"), home_configuration("panda")
    controller = Lp2Controller(model, dt=DT, qdd_max=QDD, v_max=1e6, w_max=1e6)
    unit = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    q, prev = q0.copy(), q0.copy()
    worst_acceleration, closest_to_stop = 0.0, math.inf
    for target in targets(model.pose(q0), unit, 1.0):
        res = controller.step(q, target, prev)
        assert np.all(res.q >= model.q_min - 1e-9) and np.all(res.q <= model.q_max + 1e-9)
        worst_acceleration = max(worst_acceleration, np.abs(res.q - 2 * q + prev).max() / DT**2)
        closest_to_stop = min(closest_to_stop, model.q_max[3] - res.q[3])
        prev, q = q, res.q
    assert np.linalg.norm(model.pose(q)[:3, 3] - model.pose(q0)[:3, 3]) < 1e-5
    assert worst_acceleration <= QDD * (1 + 1e-9)
    assert closest_to_stop > 0.2  # the pose of greatest reach is about 0.4 rad short of it


def test_the_singular_stop_is_alike_on_both_paths() -> None:
    """Through the steps where the stop before the singular configuration acts (the step
    solved again under the automatic bound, the stop nearer than the fading motion's), the
    compiled controller and the numpy stepper take the same steps."""
    model, q0 = load_robot("panda"), home_configuration("panda")
    options = dict(dt=DT, qdd_max=QDD, v_max=1e6, w_max=1e6)
    controller, stepper = Lp2Controller(model, **options), Stepper(model, **options)
    state = controller._state
    q, prev = q0.copy(), q0.copy()
    acted = 0
    for k, target in enumerate(targets(model.pose(q0), np.array([1.0, 0.0, 0.0]), 1.0)):
        if k >= 1400:
            break
        res = controller.step(q, target, prev)
        if k >= 1000:  # the approach to the stretched pose
            ref = stepper.step(q, target, prev)
            np.testing.assert_allclose(res.q, ref.q, rtol=0, atol=1e-9)
            assert (res.status, res.binding) == (ref.status, ref.binding)
            bounded = state[int(state[layout.BOUNDED])] > 0
            acted += bool(bounded and layout.vector(state, layout.SINGULAR)[0] < math.inf)
        prev, q = q, res.q
    assert acted > 10


def test_the_fused_step_reads_j_before_s_sigma_min_from_the_last_step() -> None:
    """The fused step keeps ``sigma_min`` of ``J`` (the ``sigma`` block) for the next
    step, whose ``J_before`` it is: the stop ahead decomposes one Jacobian instead of two.
    Each step of the approach to the stretched pose equals the step of a copy of the state
    that knows nothing (no kinematics or singular values at ``q_prev``), to the bit; a
    ``q_prev`` other than the last ``q0`` is decomposed anew."""
    model, q0 = load_robot("panda"), home_configuration("panda")
    controller = Lp2Controller(model, dt=DT, qdd_max=QDD, v_max=1e6, w_max=1e6)
    state = controller._state
    forgetful = Lp2Controller(model, dt=DT, qdd_max=QDD, v_max=1e6, w_max=1e6)
    sigma = layout.vector(state, layout.SIGMA)
    q, prev = q0.copy(), q0.copy()
    reused = 0
    for k, target in enumerate(targets(model.pose(q0), np.array([1.0, 0.0, 0.0]), 1.0)):
        if k >= 1300:
            break
        if k >= 1000:
            forgetful._state[:] = state
            layout.vector(forgetful._state, layout.SECOND_ORDER)[1] = 0.0  # prev_* not held
            layout.vector(forgetful._state, layout.SIGMA)[:] = np.nan
            known = not math.isnan(sigma[2])
            jolted = prev + 1e-7 if k % 7 == 0 else prev  # not the last q0: no memo
            ref = forgetful.step(q, target, jolted)
            res = controller.step(q, target, jolted)
            np.testing.assert_array_equal(res.q, ref.q)
            assert (res.status, res.binding) == (ref.status, ref.binding)
            reused += known and jolted is prev and state[int(state[layout.BOUNDED])] > 0
            if k % 7 == 0:
                continue  # the loop goes on from the step not taken
        else:
            res = controller.step(q, target, prev)
        prev, q = q, res.q
    assert reused > 10


def test_the_benchmark_counts_returns_from_perturbed_states() -> None:
    """benchmarks/excursions.py's perturbed returns: the state moved at the end of the way out
    (within the end-stops, the velocities kept) and the excursion run on. The UR5e comes home
    from every draw (docs/benchmarks.md has the tallies of every arm)."""
    from lpik_bench.excursions import perturbed_returns

    assert perturbed_returns("ur5e", QDD, 0.003, 3, 1) == (3, 3)
