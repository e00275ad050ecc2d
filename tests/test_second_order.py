"""The command's second-order term: what the Jacobian's prediction of the last step missed.

``Lp2Controller(second_order=True)`` (the default) takes off each step's command
the second-order term of the last step's task motion
(:func:`lpik.command.second_order_term`). These tests hold the term to
its purpose (it predicts the next step's miss to third order), the compiled
step to the numpy problem on every path (the fused chain, a Python kinematics
backend, a batch; the kinematics kept from the last step or computed anew),
and the closed loop to the third-order error it promises.
"""

from __future__ import annotations

import numpy as np
import pytest

from lpik.command import second_order_term, task_rows
from lpik.robots.registry import home_configuration, load_chain, load_robot
from lpik.robots.tasks import PoseTask, pose_difference

pytest.importorskip("numba")
from lpik.control.controller import Lp2Controller  # noqa: E402
from lpik.methods.lp2s import lp2s  # noqa: E402


@pytest.fixture(scope="module")
def panda() -> PoseTask:
    return load_robot("panda", task="pose")


def _miss(model: PoseTask, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """What the step ``dq`` from ``q`` missed of its task motion: measured after the fact."""
    from lpik.command import command_rows

    e6 = pose_difference(model.pose(q), model.pose(q + dq))
    screw = np.empty(6)
    command_rows(e6, task_rows(model), screw, np.inf, np.inf, 1.0, np.inf)
    return screw - model.jacobian(q) @ dq


@pytest.mark.parametrize("seed", range(5))
def test_the_term_of_the_last_step_predicts_the_next_steps_miss_to_third_order(
    panda: PoseTask, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    q = home_configuration("panda") + rng.normal(scale=0.3, size=7)
    direction = rng.normal(size=7)
    direction /= np.linalg.norm(direction)
    for eps in (1e-3, 2e-3):  # a joint speed of 1-2 rad/s over one 1 ms period
        dq = eps * direction
        rho = second_order_term(panda, q - dq, q)  # the last step, at the same joint velocity
        miss = _miss(panda, q, dq)  # what the next step, the same motion, misses
        assert np.abs(miss).max() > 1e-8  # second order: eps^2 times the curvature
        # the prediction is off by the change of the term over one step: third order
        assert np.abs(rho - miss).max() <= 1e-2 * np.abs(miss).max()
    # second order: twice the step, four times the term
    big, small = (second_order_term(panda, q - e * direction, q) for e in (2e-3, 1e-3))
    assert np.abs(big - 4 * small).max() <= 1e-2 * np.abs(4 * small).max()


def test_the_term_is_zero_at_rest_and_none_without_q_prev(panda: PoseTask) -> None:
    q = home_configuration("panda")
    np.testing.assert_array_equal(second_order_term(panda, q, q), np.zeros(6))
    c = Lp2Controller(panda, dt=1e-3)
    target = panda.pose(q)
    target[:3, 3] += 0.01
    np.testing.assert_array_equal(c.problem(q, target).dw, c.problem(q, target, q).dw)


def _states(model: PoseTask, count: int, seed: int):  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(seed)
    home = home_configuration("panda")
    for _ in range(count):
        q = np.clip(home + rng.normal(scale=0.4, size=7), model.q_min + 0.05, model.q_max - 0.05)
        prev = q - rng.uniform(-1.0, 1.0, 7) * model.qd_max * 1e-3
        target = model.pose(q)
        target[:3, 3] += rng.normal(scale=0.02, size=3)
        yield q, prev, target


def test_the_compiled_step_equals_the_numpy_problem_with_the_term(panda: PoseTask) -> None:
    c = Lp2Controller(panda, dt=1e-3)
    off = Lp2Controller(panda, dt=1e-3, second_order=False)
    moved = 0
    for q, prev, target in _states(panda, 60, seed=3):
        P = c.problem(q, target, prev)
        np.testing.assert_allclose(
            P.dw, off.problem(q, target, prev).dw - second_order_term(panda, prev, q),
            rtol=0, atol=1e-18,
        )  # fmt: skip
        got, ref = c.step(q, target, prev), lp2s(P)
        assert (got.status, got.binding) == (ref.status, ref.binding)
        np.testing.assert_allclose(got.q, ref.q, rtol=0, atol=1e-12)
        moved += bool(np.any(got.q != off.step(q, target, prev).q))
    assert moved > 50  # the term changes the step


def test_kinematics_kept_from_the_last_step_give_the_same_step_as_computed_anew(
    panda: PoseTask,
) -> None:
    """In a loop, q_prev is the last step's q0, whose kinematics the state keeps."""
    loop = Lp2Controller(panda, dt=1e-3)
    q = prev = home_configuration("panda")
    centre = panda.pose(q)[:3, 3]
    for k in range(40):
        target = panda.pose(home_configuration("panda"))
        target[:3, 3] = centre + 0.05 * np.array([0.0, np.sin(0.05 * k), 1 - np.cos(0.05 * k)])
        kept = loop.step(q, target, prev)  # the state holds the kinematics at prev
        fresh = Lp2Controller(panda, dt=1e-3).step(q, target, prev)  # computes them
        np.testing.assert_array_equal(kept.q, fresh.q)
        prev, q = q, kept.q


def _faulty_states(model: PoseTask, count: int, seed: int):  # type: ignore[no-untyped-def]
    """:func:`_states` with one joint's implied step beyond its velocity limit: a bad sample."""
    rng = np.random.default_rng(seed)
    for q, prev, target in _states(model, count, seed):
        i = rng.integers(7)
        prev = prev.copy()
        prev[i] = q[i] - rng.choice([-1.0, 1.0]) * rng.uniform(1.01, 50.0) * model.qd_max[i] * 1e-3
        yield q, prev, target


def test_a_step_the_drives_could_not_have_made_has_no_term(panda: PoseTask) -> None:
    """A q_prev whose implied step is beyond a velocity limit (a bad sample, 0.05 rad off: an
    implied 50 rad/s) described a motion the arm did not make; its term steered the tool 1.1 mm
    off a 0.5 mm step along x. Without acceleration limits (which take such a q_prev at the step
    the drives could have made) the command then has no term: the step from q0 at rest, on the
    compiled step, the numpy problem, a Python kinematics backend and a batch alike."""
    from lpik.command import made_by_drives

    c, wrapped = Lp2Controller(panda, dt=1e-3), Lp2Controller(PoseTask(_PythonKinematics()),
                                                              dt=1e-3)  # fmt: skip
    states = list(_faulty_states(panda, 30, seed=5))
    for q, prev, target in states:
        assert not made_by_drives(q, prev, -panda.qd_max, panda.qd_max, 1e-3)
        at_rest = c.step(q, target, q)
        np.testing.assert_array_equal(c.problem(q, target, prev).dw, c.problem(q, target, q).dw)
        np.testing.assert_array_equal(c.step(q, target, prev).q, at_rest.q)
        np.testing.assert_allclose(wrapped.step(q, target, prev).q, at_rest.q, rtol=0, atol=1e-12)
    Q0, PREV, TARGETS = (np.array(x) for x in zip(*states, strict=True))
    batch = c.step_batch(Q0, TARGETS, PREV)
    for b, (q, _, target) in enumerate(states):
        np.testing.assert_array_equal(batch.q[b], c.step(q, target, q).q)
    # a step at the velocity limits (to the ratio test's tolerance) is one the drives made
    q = home_configuration("panda")
    assert made_by_drives(q, q - panda.qd_max * 1e-3, -panda.qd_max, panda.qd_max, 1e-3)
    assert made_by_drives(q, q + panda.qd_max * 1e-3 * (1 + 1e-12), -panda.qd_max,
                          panda.qd_max, 1e-3)  # fmt: skip


class _PythonKinematics:
    """lpik's chain behind a plain Python object: the step takes the backend's path."""

    def __init__(self) -> None:
        self.chain = chain = load_chain("panda")
        self.name, self.n_joints, self.joint_names = "wrapped", chain.n_joints, chain.joint_names
        self.q_min, self.q_max, self.qd_max = chain.q_min, chain.q_max, chain.qd_max

    def fk(self, q: np.ndarray) -> np.ndarray:
        return self.chain.fk(q)

    def jacobian(self, q: np.ndarray) -> np.ndarray:
        return self.chain.jacobian(q)


def test_a_backends_step_and_a_batch_take_off_the_same_term() -> None:
    from lpik.control.backend_step import fuses_kinematics

    wrapped = PoseTask(_PythonKinematics())
    assert not fuses_kinematics(wrapped)
    backend, own = Lp2Controller(wrapped, dt=1e-3), Lp2Controller(PoseTask(load_chain("panda")),
                                                                  dt=1e-3)  # fmt: skip
    states = list(_states(wrapped, 30, seed=11))
    for q, prev, target in states:
        got = backend.step(q, target, prev)
        np.testing.assert_allclose(got.q, lp2s(backend.problem(q, target, prev)).q, rtol=0,
                                   atol=1e-12)  # fmt: skip
        np.testing.assert_allclose(got.q, own.step(q, target, prev).q, rtol=0, atol=1e-12)
    Q0, PREV, TARGETS = (np.array(x) for x in zip(*states, strict=True))
    for c in (backend, own):
        batch = c.step_batch(Q0, TARGETS, PREV)
        for b, (q, prev, target) in enumerate(states):
            np.testing.assert_array_equal(batch.q[b], c.step(q, target, prev).q)


def test_the_closed_loop_error_on_a_circle_falls_from_second_to_third_order(
    panda: PoseTask,
) -> None:
    """Scenario 1 of docs/quality.md, a quarter of it: a 10 cm circle at 0.16 m/s."""
    errors = {}
    for second_order in (False, True):
        c = Lp2Controller(panda, dt=1e-3, second_order=second_order)
        q = prev = home_configuration("panda")
        start = panda.pose(q)
        squares = []
        for k in range(1, 1001):
            t = k * 1e-3  # one turn per 2 s, the speed ramped up over 0.5 s
            angle = np.pi * (t * t if t < 0.5 else t - 0.25)
            target = start.copy()
            target[1:3, 3] += 0.05 * np.array([np.sin(angle), 1 - np.cos(angle)])
            result = c.step(q, target, prev)
            prev, q = q, result.q
            assert result.status == "optimal" and result.p == 1.0
            if k > 500:  # at full speed
                squares.append(float(np.sum((panda.pose(q)[:3, 3] - target[:3, 3]) ** 2)))
        errors[second_order] = np.sqrt(np.mean(squares))
    assert errors[False] > 1e-8  # second order in the step: 3e-8 m RMS at this speed
    assert errors[True] < 1e-2 * errors[False]
