"""One command law, one step: ``simulate`` and ``Lp2Controller`` follow the same joint path."""

from __future__ import annotations

import numpy as np
import pytest

from lpik.paper.scenarios import PLANAR, Setup, get_scenario

pytest.importorskip("numba")


def controller_run(setup: Setup, saturate: bool) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The scenario driven by the compiled controller, the way a control loop calls it."""
    controller = setup.controller(saturate=saturate)
    q, q_prev = setup.q0.copy(), None
    path, p, binding = [], [], []
    for _ in range(setup.steps):
        path.append(q)
        result = controller.step(q, setup.target, q_prev)
        p.append(result.p if result.moved else 0.0)
        binding.append(result.binding)
        q_prev, q = q, result.q
    return np.array(path), np.array(p), binding


CASES = [
    ("pull-in", PLANAR),
    ("pull-in", "panda"),
    ("pull-in", "iiwa14"),
    ("edge-singularity", PLANAR),
]


@pytest.mark.parametrize(("scenario", "robot"), CASES)
def test_simulate_and_the_controller_give_the_same_joint_path(scenario: str, robot: str) -> None:
    setup = get_scenario(scenario).setup(robot)
    if scenario == "edge-singularity":  # stop before the chattering stretch, where
        setup = type(setup)(**{**vars(setup), "steps": 300})  # rounding decides the path
    log = setup.run("lp2")  # lp2: its runs meet the limits (lp2s saturates past them)
    path, p, binding = controller_run(setup, saturate=False)
    np.testing.assert_allclose(path, log.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(p, log.p, rtol=0, atol=1e-9)
    assert binding == list(log.binding)
    assert (log.p < 1).any() and (log.p == 1).any()  # the run meets a limit


@pytest.mark.parametrize(("robot", "saturate"), [(PLANAR, False), ("panda", True)])
def test_a_smoothing_term_runs_alike_and_never_freezes_the_arm(robot: str, saturate: bool) -> None:
    """Lambda = 0.1 I with the default q_ref: its pull, scaled to fit each step, lets the
    arm move (it made every step infeasible), on both paths alike."""
    setup = get_scenario("pull-in").setup(robot)
    weights = {**dict(setup.weights), "Lambda": np.full(setup.model.n_joints, 0.1)}
    setup = type(setup)(**{**vars(setup), "weights": weights})
    log = setup.run("lp2s" if saturate else "lp2")
    assert set(log.status) == {"optimal"} and log.p[-1] == 1.0
    controller = setup.controller(saturate=saturate)
    q, prev = setup.q0.copy(), None
    for k in range(setup.steps):
        res = controller.step(q, setup.target, prev)
        np.testing.assert_allclose(res.q, log.q[k + 1] if k + 1 < setup.steps else log.q_end,
                                   rtol=0, atol=1e-9)  # fmt: skip
        prev, q = q, res.q
