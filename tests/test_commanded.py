"""A measured loop's noise: the state's implied step checked against the step commanded."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lpik import Lp2Controller, home_configuration
from lpik.continuation import (
    FAULT,
    HELD_FROM,
    HELD_STEP,
    MEMORY_ROWS,
    PLAUSIBLE,
    hold_step,
    plausible_previous,
)
from lpik.robots.registry import load_robot

PANDA = load_robot("panda", task="pose")
BAND = 1e-5  # qdd_max = 10 rad/s^2 at dt = 1 ms: qdd dt^2
SPEED = 2e-3  # qd_max = 2 rad/s at dt = 1 ms: qd dt


def _previous(q0: list[float], q_prev: list[float], held_from: list[float],
              held_step: list[float]) -> tuple[bool, np.ndarray]:  # fmt: skip
    n = len(q0)
    memory = np.array([held_from, held_step, [-BAND] * n, [BAND] * n, [np.nan] * n,
                       [-SPEED] * n, [SPEED] * n, [0.0] * n])  # fmt: skip
    clipped = plausible_previous(np.array(q0), np.array(q_prev), memory)
    return clipped, memory[PLAUSIBLE]


def test_an_implied_step_beyond_the_acceleration_band_of_the_commanded_one_is_clipped() -> None:
    """The commanded step was 1e-3 rad (joint 1) and 0 (joint 2); the state implies 1.5e-3
    and 2e-6: joint 1's is taken at 1e-3 + 1e-5, joint 2's stands (within the band)."""
    clipped, out = _previous([0.0015, 2e-6], [0.0, 0.0], [0.0, 0.0], [1e-3, 0.0])
    assert clipped
    np.testing.assert_allclose([0.0015, 2e-6] - out, [1e-3 + BAND, 2e-6], rtol=0, atol=1e-15)
    # within the band: q_prev stands
    assert not _previous([0.001005, 0.0], [0.0, 0.0], [0.0, 0.0], [1e-3, 0.0])[0]
    # another q_prev than the last step's q0 (a new loop, a jump): taken as it comes
    assert not _previous([0.0015, 0.0], [1e-9, 0.0], [0.0, 0.0], [1e-3, 0.0])[0]
    # no step answered yet (held_from NaN)
    assert not _previous([0.0015, 0.0], [0.0, 0.0], [np.nan, np.nan], [0.0, 0.0])[0]
    memory = np.zeros((MEMORY_ROWS, 2))
    hold_step(np.array([1.0, 2.0]), np.array([1.5, 1.0]), memory)
    assert memory[HELD_FROM].tolist() == [1.0, 2.0] and memory[HELD_STEP].tolist() == [0.5, -1.0]


def test_another_q_prev_where_the_arm_went_as_sent_is_taken_at_the_motion_since_q0() -> None:
    """q_prev is not the last q0 (a loop that builds it from a velocity reading) and q0 is
    where the last step sent the arm: joint 1's implied step, 50 times its velocity limit
    (a fault), and joint 2's, within its limit but 1e-3 rad off the commanded step, are
    taken as the motion since the last q0; the fault row says which joint and side."""
    q0, q_prev = [1e-3 + 2e-6, 0.0], [1e-3 + 2e-6 - 0.1, 1e-3]
    n = len(q0)
    memory = np.array([[0.0, 0.0], [1e-3, 0.0], [-BAND] * n, [BAND] * n, [np.nan] * n,
                       [-SPEED] * n, [SPEED] * n, [0.0] * n])  # fmt: skip
    assert plausible_previous(np.array(q0), np.array(q_prev), memory)
    np.testing.assert_allclose(memory[PLAUSIBLE], [0.0, 0.0], rtol=0, atol=1e-15)
    assert memory[FAULT].tolist() == [1.0, 0.0]
    # q0 further from where the step sent it than the drives could have made it: no memory
    assert not _previous([1e-3 + 2e-5, 0.0], [-0.1, 0.0], [0.0, 0.0], [1e-3, 0.0])[0]
    # a last step within the band around rest (a query repeated at the same q0 looks so)
    assert not _previous([5e-6, 0.0], [-0.1, 0.0], [0.0, 0.0], [5e-6, 0.0])[0]
    # a state that reads as at rest (a loop resumed after a pause): taken as it comes
    assert not _previous([1e-3, 0.0], [1e-3 - 2e-6, 0.0], [0.0, 0.0], [1e-3, 0.0])[0]


def _measured_loop(controller, sigma: float, seed: int, steps: int) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The Panda 5 cm along x from home, each reading the arm's commanded position plus
    Gaussian noise of ``sigma`` rad per joint, the last two readings fed back as ``q0`` and
    ``q_prev``. Returns the tool's position error after each step [m]."""
    rng = np.random.default_rng(seed)
    q = home_configuration("panda")
    target = PANDA.pose(q)
    target[0, 3] += 0.05
    reading_before = q.copy()
    error = np.empty(steps)
    for k in range(steps):
        reading = q + rng.normal(0.0, sigma, q.size)
        q = controller.step(reading, target, reading_before).q
        reading_before = reading
        error[k] = np.linalg.norm(PANDA.pose(q)[:3, 3] - target[:3, 3])
    return error


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_a_measured_loop_still_feeds_a_moving_targets_motion_forward(engine: str) -> None:
    """A target moving at 0.1 m/s along y, readings with 1e-5 rad of noise: the corrected
    steps still follow the last one, so the target's motion is fed forward and the tool
    keeps within 0.1 mm of it along the way; when the correction dropped the feed-forward,
    it lagged 1.1 mm behind."""
    from lpik.control.stepper import Stepper

    if engine == "compiled":
        controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0, compile="now")
    else:
        controller = Stepper(PANDA, dt=1e-3, qdd_max=10.0)
    rng = np.random.default_rng(7)
    q = home_configuration("panda")
    start = PANDA.pose(q)
    reading_before, lag = q.copy(), []
    for k in range(1500):  # speeding up at 0.1 m/s^2 for 1 s, then on at 0.1 m/s
        t, target = k * 1e-3, start.copy()
        target[1, 3] += 0.05 * min(t, 1.0) ** 2 + 0.1 * max(t - 1.0, 0.0)
        reading = q + rng.normal(0.0, 1e-5, q.size)
        q = controller.step(reading, target, reading_before).q
        reading_before = reading
        lag.append(target[1, 3] - PANDA.pose(q)[1, 3])
    assert controller.motion.corrected > 500
    assert abs(float(np.mean(lag[-400:]))) < 0.5e-3


@settings(max_examples=6, deadline=None)
@given(sigma=st.sampled_from([1e-5, 5e-5, 1e-4, 2e-4]), seed=st.integers(0, 2**16))
def test_encoder_noise_fed_back_under_acceleration_limits_does_not_drive_the_tool_away(
    sigma: float, seed: int
) -> None:
    """Continued as motion, noise of 1e-4 rad per reading (0.1 rad/s at 1 kHz, ten times what
    the acceleration limits let a step change) random-walked the joint velocities: the tool
    ended 196 mm from the goal and was 284 mm away at worst. Taken at the step the drives
    could have made, the tool stays on the goal at the level of the noise."""
    controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    error = _measured_loop(controller, sigma, seed, 2000)
    # 25 mm per rad of noise: 2.6 mm at 1e-4 (0.75-0.9 mm measured), 0.35 mm at 1e-5 (0.06-0.15)
    assert error[1000:].max() < 25.0 * sigma + 1e-4
    assert controller.motion.corrected > 0


def test_the_numpy_engine_checks_a_measured_loop_as_the_compiled_step_does() -> None:
    compiled = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    numpy_engine = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0).stepper
    a = _measured_loop(compiled, 1e-4, 7, 300)
    b = _measured_loop(numpy_engine, 1e-4, 7, 300)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    assert compiled.motion.corrected == numpy_engine.motion.corrected > 100


def test_a_loop_fed_its_own_commands_is_never_corrected() -> None:
    """The implied step is the commanded one (up to rounding): nothing to correct."""
    controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    error = _measured_loop(controller, 0.0, 0, 3000)
    assert controller.motion.corrected == 0 and error[-1] < 1e-8


def test_reset_forgets_the_last_answer_and_no_acceleration_limits_need_no_check() -> None:
    controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    q = home_configuration("panda")
    target = PANDA.pose(q)
    q1 = controller.step(q, target, q).q
    controller.reset()
    assert np.isnan(controller.motion.held_from).all()
    controller.step(q1 + 0.01, target, q)  # a jump of q0: not checked after reset
    assert controller.motion.corrected == 0
    assert Lp2Controller(PANDA, dt=1e-3).motion is None
    with pytest.raises(ValueError, match="q_prev"):
        controller.step(q, target, [0.0, 1.0])


@settings(max_examples=5, deadline=None)
@given(sigma=st.sampled_from([1e-5, 1e-4, 3e-4]), seed=st.integers(0, 2**16))
def test_a_noisy_measured_loop_keeps_every_limit_against_the_motion_it_takes(
    sigma: float, seed: int
) -> None:
    """Targets that jump to random configurations' poses every 0.3 s, readings with noise:
    no command further past an end-stop than its reading, every step within the velocity
    limits, and each step that is not a recovery within two periods' share of the
    acceleration limits of the step answered before it (the band around the plausible
    motion, around the commanded one). A reading the noise puts past an end-stop, or
    beyond the braking distance's bound, is recovered by the recovery rules
    (docs/reliability.md), whose steps that band does not bound."""
    rng = np.random.default_rng(seed)
    controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    lower, upper = PANDA.q_min, PANDA.q_max
    speed = PANDA.qd_max * 1e-3
    q = home_configuration("panda")
    reading_before, answered = q.copy(), np.zeros(q.size)
    for k in range(1500):
        if k % 300 == 0:
            target = PANDA.pose(lower + (upper - lower) * rng.uniform(0.1, 0.9, q.size))
        reading = q + rng.normal(0.0, sigma, q.size)
        result = controller.step(reading, target, reading_before)
        q, step = result.q, result.q - reading
        past_before = np.maximum(reading - upper, 0) + np.maximum(lower - reading, 0)
        past = np.maximum(q - upper, 0) + np.maximum(lower - q, 0)
        assert np.all(past <= past_before + 1e-9), k
        assert np.all(np.abs(step) <= speed + 1e-12), k
        # from the second step on: the first reading has no step answered to check against
        if k and result.status != "recovering":
            assert np.all(np.abs(step - answered) <= 2 * BAND + 1e-12), (k, result.status)
        reading_before, answered = reading, step


def _feed(controller, how: str, steps: int = 12) -> None:  # type: ignore[no-untyped-def]
    """The getting-started move, fed back ``how``: ``commands`` (q0 the last answer, q_prev
    the one before), ``readings`` (the last two readings, 1e-5 rad of noise), ``no q_prev``
    (the last answer alone) or ``reading and command`` (q0 a reading, q_prev the last answer)."""
    rng = np.random.default_rng(1)
    q = home_configuration("panda")
    target = PANDA.pose(q)
    target[0, 3] += 0.05
    before = q.copy()
    for _ in range(steps):
        reading = q + rng.normal(0.0, 1e-5, q.size)
        if how == "commands":
            answer = controller.step(q, target, before).q
            before = q
        elif how == "readings":
            answer = controller.step(reading, target, before).q
            before = reading
        elif how == "no q_prev":
            answer = controller.step(q, target).q
        else:
            answer = controller.step(reading, target, q).q
        q = answer


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("how", ["no q_prev", "reading and command"])
def test_a_loop_that_feeds_its_answer_back_as_the_past_is_warned(engine: str, how: str) -> None:
    """Feeding the last answer back as the configuration one period before q0 says the arm
    did not move while it was commanded to: under acceleration limits every step starts
    from rest and the tool crawls (still 40 mm off the 5 cm goal after 3 s). The first
    steps of a loop are watched, and that loop is told once."""
    from lpik.control.stepper import Stepper

    controller = (Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0) if engine == "compiled"
                  else Stepper(PANDA, dt=1e-3, qdd_max=10.0))  # fmt: skip
    with pytest.warns(RuntimeWarning, match="q_prev is the last step's answer") as seen:
        _feed(controller, how)
    assert len([w for w in seen if issubclass(w.category, RuntimeWarning)]) == 1


@pytest.mark.parametrize("how", ["commands", "readings"])
def test_a_loop_fed_as_documented_is_not_warned(how: str) -> None:
    """Commands fed back as commands, or readings as readings: no warning."""
    import warnings

    controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        _feed(controller, how)
        controller.reset()
        _feed(controller, how)


def _velocity_loop(controller, bad: float, joint: int, at: int, into: bool, steps: int = 300,
                   added: bool = False):  # type: ignore[no-untyped-def]  # fmt: skip
    """The Panda from home towards a goal 10 cm along x, y and -z, ``q_prev`` built from a
    velocity reading (``q0 - qd dt``) that is exact but at step ``at``, where joint
    ``joint``'s reads ``bad`` rad/s (``added``: ``bad`` rad/s more than the true speed).
    Steps with :meth:`step_into` where ``into``, else :meth:`step`. Returns the arm's
    configurations (the commands followed exactly) and each step's status and binding."""
    q = home_configuration("panda")
    goal = PANDA.pose(q)
    goal[:3, 3] += [0.1, 0.1, -0.1]
    path, said, before = [q.copy()], [], q.copy()
    for k in range(steps):
        q_prev = before.copy()
        if k == at:  # the reading bad, or the true speed plus bad
            q_prev[joint] = (before[joint] if added else q[joint]) - bad * 1e-3
        if into:
            out = np.empty(q.size)
            controller.step_into(q, goal, q_prev, out=out)
            said.append((controller.last_status, controller.last_binding))
        else:
            result = controller.step(q, goal, q_prev)
            out = result.q
            said.append((result.status, result.binding))
        before, q = q, out
        path.append(q.copy())
    return np.array(path), said


@settings(max_examples=8, deadline=None)
@given(joint=st.integers(0, 6), sign=st.sampled_from([-1.0, 1.0]),
       beyond=st.floats(0.05, 200.0), at=st.integers(20, 250),
       engine=st.sampled_from(["step", "step_into", "numpy"]))  # fmt: skip
def test_one_bad_velocity_sample_is_reported_and_the_arm_keeps_its_acceleration_limits(
    joint: int, sign: float, beyond: float, at: int, engine: str
) -> None:
    """A q_prev from a velocity reading, one sample of which is beyond the joint's velocity
    limit (a fault: the drives cannot move it so fast). Taken at rest or at the limit, as
    the step must take it without a memory, the joint's real speed changed in one period
    by 15 to 99 times its acceleration limit (five such runs). Taken as the motion since
    the last q0, the arm keeps every
    acceleration limit on every step, and the step says the state was faulty: status
    ``recovering``, naming that joint's velocity limit on the side of the sample."""
    from lpik.control.stepper import Stepper

    controller = (Stepper(PANDA, dt=1e-3, qdd_max=10.0) if engine == "numpy"
                  else Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0))  # fmt: skip
    bad = sign * (PANDA.qd_max[joint] + beyond)
    path, said = _velocity_loop(controller, bad, joint, at, engine == "step_into")
    acceleration = np.abs(np.diff(path, 2, axis=0)) / 1e-6
    assert acceleration.max() <= 10.0 * (1 + 1e-6)
    side = "upper" if sign > 0 else "lower"
    assert said[at] == ("recovering", f"panda_joint{joint + 1} {side} velocity limit")
    assert all(status != "recovering" for status, _ in said[:at] + said[at + 1 :])
    assert controller.motion.faults == 1


@settings(max_examples=8, deadline=None)
@given(joint=st.integers(0, 6), off=st.floats(0.02, 1.5), sign=st.sampled_from([-1.0, 1.0]),
       at=st.integers(20, 250), engine=st.sampled_from(["step", "step_into", "numpy"]))  # fmt: skip
def test_a_wrong_velocity_reading_within_the_limit_is_taken_at_the_arms_motion(
    joint: int, off: float, sign: float, at: int, engine: str
) -> None:
    """One velocity reading off by 0.02 to 1.5 rad/s, where the arm went as the last step
    sent it: continued as it is, a reading 0.5 rad/s off changed the joint's real speed
    by 49 times its acceleration limit in one period. Taken at the motion since the last
    q0, the arm keeps every acceleration limit; the step is recovering only where the
    reading was beyond the velocity limit."""
    from lpik.control.stepper import Stepper

    controller = (Stepper(PANDA, dt=1e-3, qdd_max=10.0) if engine == "numpy"
                  else Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0))  # fmt: skip
    path, said = _velocity_loop(controller, sign * off, joint, at, engine == "step_into",
                                added=True)  # fmt: skip
    acceleration = np.abs(np.diff(path, 2, axis=0)) / 1e-6
    assert acceleration.max() <= 10.0 * (1 + 1e-6)
    read = (path[at] - path[at - 1])[joint] / 1e-3 + sign * off
    assert (said[at][0] == "recovering") == (abs(read) > PANDA.qd_max[joint])
    assert controller.motion.corrected >= 1


@settings(max_examples=6, deadline=None)
@given(sigma=st.sampled_from([0.02, 0.05, 0.1]), seed=st.integers(0, 2**16))
def test_velocity_readings_noise_does_not_drive_the_tool_away(sigma: float, seed: int) -> None:
    """The getting-started move, ``q_prev`` built from velocity readings with ``sigma``
    rad/s of Gaussian noise per joint. Continued as motion, 0.1 rad/s of noise
    random-walked the velocities: the tool was up to 304 mm from the goal after the
    first second (82 mm at 0.05). Taken at the motion the positions show, it stays
    within 50 mm per rad/s of noise (1.5 to 3.6 mm at 0.1 in 30 seeds)."""
    controller = Lp2Controller(PANDA, dt=1e-3, qdd_max=10.0)
    rng = np.random.default_rng(seed)
    q = home_configuration("panda")
    target = PANDA.pose(q)
    target[0, 3] += 0.05
    before, error = q.copy(), []
    for _ in range(2000):
        speed = (q - before) / 1e-3 + rng.normal(0.0, sigma, q.size)
        before, q = q, controller.step(q, target, q - speed * 1e-3).q
        error.append(np.linalg.norm(PANDA.pose(q)[:3, 3] - target[:3, 3]))
    assert max(error[1000:]) < 50.0 * sigma * 1e-3
