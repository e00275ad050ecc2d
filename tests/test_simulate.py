"""The closed loop: command law, stepping, what is applied, the log and its CSV."""

from __future__ import annotations

import csv
import dataclasses

import numpy as np
import pytest

from lpik.command import ClampedTarget, along_screw, clamp_command, commanded_displacement
from lpik.control.log import SimulationLog
from lpik.control.simulate import simulate
from lpik.limits import EndStops, VelocityLimits
from lpik.methods import ALL_METHODS, registry
from lpik.paper.scenarios import get_scenario
from lpik.robots.planar import planar_arm
from lpik.robots.registry import home_configuration, load_robot
from paper_runs import lp2_pull_in, run

PULL_IN = get_scenario("pull-in")


def short_run(method: str = "lp2", steps: int = 20, **kw: object) -> SimulationLog:
    return PULL_IN.run(method, steps=steps, **kw)  # type: ignore[arg-type]


# --- command law ---------------------------------------------------------------------------


def clamped(dw: list[float], rows: list[int], v_max: float, w_max: float = 1.0) -> np.ndarray:
    out = np.array(dw, dtype=float)
    clamp_command(out, np.array(rows, dtype=float), v_max, w_max, 1.0, np.inf)
    return out


def test_clamp_keeps_short_and_scales_long() -> None:
    short = np.array([0.001, -0.002])
    np.testing.assert_array_equal(clamped(short, [0, 1], 0.005), short)
    long = np.array([3.0, 4.0])
    out = clamped(long, [0, 1], 0.5)
    assert np.linalg.norm(out) == pytest.approx(0.5)
    np.testing.assert_allclose(out / np.linalg.norm(out), long / 5.0)


def test_clamp_limits_linear_and_angular_speed_each_and_keeps_the_direction() -> None:
    dw = [0.3, 0.0, 0.4, 0.0, 0.0, 2.0]  # 0.5 m and 2 rad
    rows = [0, 1, 2, 3, 4, 5]
    by_angle = clamped(dw, rows, v_max=1.0, w_max=0.5)  # the angular part binds: scale 1/4
    np.testing.assert_allclose(by_angle, np.array(dw) / 4)
    by_length = clamped(dw, rows, v_max=0.1, w_max=10.0)  # the linear part binds: scale 1/5
    np.testing.assert_allclose(by_length, np.array(dw) / 5)
    np.testing.assert_array_equal(clamped(dw, rows, v_max=1.0, w_max=3.0), dw)


def test_clamped_target_points_at_target_with_length_v_max_dt(paper_arm, paper_q0) -> None:
    target = np.array([0.2, 0.866, 0.0])
    dw = ClampedTarget(target, 0.5)(paper_arm, paper_q0, 0.01)
    to_target = (target - paper_arm.pose(paper_q0))[:2]
    assert np.linalg.norm(dw) == pytest.approx(0.005)
    np.testing.assert_allclose(dw / 0.005, to_target / np.linalg.norm(to_target))
    near = paper_arm.pose(paper_q0) + np.array([0.001, 0.0, 0.0])
    np.testing.assert_allclose(ClampedTarget(near, 0.5)(paper_arm, paper_q0, 0.01), [0.001, 0])


@pytest.mark.parametrize("joint", range(7))
def test_a_target_one_joints_turn_reaches_is_commanded_exactly(joint: int) -> None:
    # Along the screw, the displacement to the pose one joint's turn reaches is that
    # joint's Jacobian column times the angle, to rounding, on the numpy and compiled
    # paths alike; the chord p_target - p is off by half the turn times the chord.
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller

    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    turned = q.copy()
    turned[joint] += 3e-4
    target = panda.pose(turned)
    exact = panda.jacobian(q)[:, joint] * 3e-4
    dw = commanded_displacement(panda, panda.pose(q), target, 0.5, 1.0, 1e-3)
    np.testing.assert_allclose(dw, exact, rtol=0, atol=1e-15)
    controller = Lp2Controller(panda, dt=1e-3)
    np.testing.assert_allclose(controller.problem(q, target).dw, dw, rtol=0, atol=1e-18)
    step = controller.step(q, target)
    np.testing.assert_allclose(panda.jacobian(q) @ step.dq, dw, rtol=0, atol=1e-15)
    if joint in (1, 3, 5):  # no self-motion moves this joint alone: the step is the turn
        np.testing.assert_allclose(step.dq, turned - q, rtol=0, atol=1e-13)
    chord = panda.difference(panda.pose(q), target)
    assert np.abs(chord - exact).max() > 1e-9 or np.abs(exact[:3]).max() < 1e-12


def test_along_screw_leaves_translations_and_tasks_without_both_kinds_of_rows() -> None:
    e6 = np.array([0.3, -0.2, 0.1, 0.0, 0.0, 0.0])
    out = e6.copy()
    assert not along_screw(out, np.arange(6.0), 0.5)
    np.testing.assert_array_equal(out, e6)  # no turn: the chord is the screw
    turning = np.array([0.3, -0.2, 0.1, 0.2, -0.1, 0.4])
    for rows in ([0.0, 1.0, 2.0], [3.0, 4.0, 5.0]):
        out = turning.copy()
        assert not along_screw(out, np.array(rows), 1.0)
        np.testing.assert_array_equal(out, turning)
    # rotation rows the task does not keep do not count: a turn about z alone
    out = turning.copy()
    assert along_screw(out, np.array([0.0, 1.0, 2.0, 5.0]), 1.0)
    expected = turning.copy()
    expected[:3] = _screw_displacement(turning[:3], np.array([0.0, 0.0, 0.4]))
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-15)


@pytest.mark.parametrize("angle", [1e-9, 1e-4, 2e-3, 0.5, 3.0])
def test_along_screw_is_the_se3_logarithm_at_the_task_point(angle: float) -> None:
    rng = np.random.default_rng(7)
    axis = rng.normal(size=3)
    phi = angle * axis / np.linalg.norm(axis)
    dp = rng.normal(size=3)
    out = np.concatenate([dp, phi]) / 0.25
    assert along_screw(out, np.arange(6.0), 0.25)  # the clamp's factor first, then the screw
    np.testing.assert_allclose(out[:3], _screw_displacement(dp, phi), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(out[3:], phi, rtol=1e-15, atol=0)


def test_a_far_target_is_approached_along_the_chord_each_step_along_its_screw() -> None:
    # Clamped, the step goes to the pose a clamped chord-and-turn reaches, along that
    # step's own screw: far from the target the tool still heads straight for it.
    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    pose = panda.pose(q)
    turned = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z
    target = pose.copy()
    target[:3, :3] = turned @ pose[:3, :3]
    target[:3, 3] += [0.3, -0.2, 0.1]
    dw = commanded_displacement(panda, pose, target, 0.5, 1.0, 1e-3)
    chord = panda.difference(pose, target)
    np.testing.assert_allclose(
        dw[3:] / np.linalg.norm(dw[3:]), chord[3:] / np.linalg.norm(chord[3:])
    )
    assert np.linalg.norm(dw[:3]) <= 0.5e-3 * (1 + 1e-12) and np.linalg.norm(dw[3:]) <= 1e-3
    heading = dw[:3] @ chord[:3] / (np.linalg.norm(dw[:3]) * np.linalg.norm(chord[:3]))
    assert 1 - heading < 1e-6  # within a milliradian-sized step's screw of the chord
    full_screw = np.concatenate([chord[:3], chord[3:]])
    assert along_screw(full_screw, np.arange(6.0), 1.0)  # the whole move's screw heads off
    whole = (
        full_screw[:3] @ chord[:3] / (np.linalg.norm(full_screw[:3]) * np.linalg.norm(chord[:3]))
    )
    assert 1 - whole > 1e-2


def _screw_displacement(dp: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """The independent form: the twist v with exp([v; phi]) translating by dp, V(phi) v = dp."""
    t = np.linalg.norm(phi)
    W = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if t == 0.0:
        return dp.copy()
    a = 2 * np.sin(t / 2) ** 2 / t**2  # (1 - cos t) / t^2, without the cancellation
    b = 1 / 6 - t**2 / 120 if t < 1e-3 else (t - np.sin(t)) / t**3
    V = np.eye(3) + a * W + b * W @ W
    return np.linalg.solve(V, dp)


@pytest.mark.parametrize("v_max", [0.0, -1.0, float("nan"), float("inf")])
def test_clamped_target_rejects_bad_speed(v_max: float) -> None:
    with pytest.raises(ValueError, match="v_max"):
        ClampedTarget(np.zeros(2), v_max)


def test_any_command_law_plugs_in(paper_arm, paper_q0) -> None:
    def constant(model, q, dt):  # a law of another task: always move up at 0.1 m/s
        return np.array([0.0, 0.1 * dt])

    log = simulate(paper_arm, constant, paper_q0, 10, dt=0.01)
    np.testing.assert_allclose(np.diff(log.position[:, 1]), 0.001, atol=1e-5)
    np.testing.assert_allclose(np.diff(log.position[:, 0]), 0.0, atol=1e-5)


# --- argument checks -----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"steps": 0}, "steps"),
        ({"steps": -3}, "steps"),
        ({"steps": 2.5}, "steps"),
        ({"dt": 0.0}, "dt"),
        ({"dt": -0.01}, "dt"),
        ({"dt": float("nan")}, "dt"),
        ({"method": "simplex"}, "method"),
        ({"q0": [0.0, 0.0]}, "q0"),
        ({"q0": [0.0, 0.0, np.nan, 0.0]}, "q0"),
    ],
)
def test_simulate_rejects_bad_arguments(paper_arm, paper_q0, kwargs, word) -> None:
    args = {"steps": 5, "dt": 0.01, "method": "lp2", "q0": paper_q0} | kwargs
    with pytest.raises(ValueError, match=word):
        simulate(
            paper_arm,
            ClampedTarget(np.array([0.2, 0.866, 0.0]), 0.5),
            args["q0"],
            args["steps"],
            method=args["method"],
            dt=args["dt"],
        )


def test_unknown_method_lists_the_methods(paper_arm, paper_q0) -> None:
    with pytest.raises(ValueError) as info:
        simulate(paper_arm, ClampedTarget(np.zeros(3), 0.5), paper_q0, 3, method="x", dt=0.01)
    for name in ALL_METHODS:
        assert name in str(info.value)


# --- the log -------------------------------------------------------------------------------


def test_log_rows_are_the_state_before_each_step() -> None:
    log = short_run(steps=25)
    model = PULL_IN.setup().model
    assert log.steps == 25
    assert log.q.shape == (25, 4) and log.lam.shape == (25, 2) and log.position.shape == (25, 2)
    np.testing.assert_allclose(log.t, np.arange(25) * 0.01)
    np.testing.assert_allclose(log.q[0], PULL_IN.paper.q0)
    np.testing.assert_allclose(log.position[0], [3.2321, 0.8660], atol=1e-4)
    for k in range(25):
        np.testing.assert_allclose(log.position[k], model.position(log.q[k]))
    np.testing.assert_allclose(log.position_end, model.position(log.q_end))
    # the commanded step is 0.005 m and LP2 follows it (p = 1) away from the limits, up to
    # the error of the linearisation (eq. 2)
    assert (log.p == 1.0).all()
    steps = np.diff(np.vstack([log.position, log.position_end]), axis=0)
    np.testing.assert_allclose(np.linalg.norm(steps, axis=1), 0.005, rtol=1e-2)


def test_velocity_limits_hold_on_every_applied_step() -> None:
    for log in (lp2_pull_in(), run("pull-in", "lp1")):
        assert np.abs(log.joint_velocities()).max() <= 1.0 + 1e-9


def test_multipliers_nan_for_methods_without_them() -> None:
    assert np.isnan(short_run("lp1", steps=5).lam).all()
    assert np.isnan(short_run("l1", steps=5).lam).all()
    assert np.isfinite(short_run("lp2", steps=5).lam).all()


def test_nlp_runs_in_the_loop_with_the_model() -> None:
    log = short_run("nlp", steps=3)
    assert list(log.status) == ["optimal"] * 3
    np.testing.assert_allclose(log.p, 1.0)
    # the NLP keeps the nonlinear kinematics: the end effector lands exactly on w0 + dw
    dw = PULL_IN.setup().command()(PULL_IN.setup().model, log.q[0], log.dt)
    np.testing.assert_allclose(log.position[1] - log.position[0], dw, atol=1e-9)


def test_jitter_is_total_variation_of_joint_velocities() -> None:
    log = short_run("lp1", steps=30)
    qd = np.diff(np.vstack([log.q, log.q_end]), axis=0) / log.dt
    np.testing.assert_allclose(log.joint_velocities(), qd)
    assert log.jitter() == pytest.approx(np.abs(np.diff(qd, axis=0)).sum())
    assert short_run(steps=1).jitter() == 0.0


def test_log_is_read_only() -> None:
    log = short_run(steps=3)
    with pytest.raises(ValueError):
        log.q[0, 0] = 1.0
    with pytest.raises(ValueError):
        log.p[0] = 0.5


def test_metrics_summarise_the_log() -> None:
    log = lp2_pull_in()
    m = log.metrics()
    assert m.steps == 400 and sum(m.statuses.values()) == 400
    assert m.jitter == pytest.approx(log.jitter())
    np.testing.assert_allclose(m.max_q, np.vstack([log.q, log.q_end]).max(axis=0))
    np.testing.assert_allclose(m.final_position, log.position_end)
    assert m.final_p == log.p[-1]
    assert m.max_abs_lambda == pytest.approx(np.abs(log.lam).max())
    assert 0 < m.median_solve_time <= m.p99_solve_time
    assert np.isnan(run("pull-in", "lp1").metrics().max_abs_lambda)


def test_one_solver_serves_every_step(monkeypatch) -> None:
    seen = []
    real = registry.METHODS["lp1"]

    def spy(problem, *, solver=None):
        seen.append(solver)
        return real.function(problem, solver=solver)

    monkeypatch.setitem(registry.METHODS, "lp1", dataclasses.replace(real, function=spy))
    short_run("lp1", steps=6)
    assert len(seen) == 6 and seen[0] is not None and all(s is seen[0] for s in seen)
    seen.clear()
    short_run("lp1", steps=3, warm_start=False)
    assert seen == [None, None, None]  # a fresh HiGHS instance per step


# --- what the loop applies -----------------------------------------------------------------


def test_a_joint_past_its_end_stop_moves_back_at_its_speed_limit(paper_arm) -> None:
    # q1 starts 2 rad above its end-stop: 0.01 s steps at 1 rad/s bring it back by 0.01 each
    q0 = np.array([1.0, 0.2, 0.2, 0.2])
    limits = [EndStops([-np.pi, -np.pi, -np.pi, -np.pi], [-1.0, np.pi, np.pi, np.pi]),
              VelocityLimits(np.ones(4))]  # fmt: skip
    log = simulate(paper_arm, ClampedTarget(np.array([1.0, 1.0, 0.0]), 0.5), q0, 4, dt=0.01,
                   limits=limits)  # fmt: skip
    assert set(log.status) == {"recovering"}
    assert set(log.binding) == {"joint 1 upper end-stop"}
    np.testing.assert_allclose(log.q[:, 0], [1.0, 0.99, 0.98, 0.97])
    assert log.q_end[0] == pytest.approx(0.96)
    assert log.metrics().recovery_steps == 4


def test_classical_step_is_clamped_to_the_end_stop_and_logged() -> None:
    log = run("pull-in", "pinv")
    q1_max = PULL_IN.paper.q_max[0]
    assert log.q[:, 0].max() <= q1_max and log.q_end[0] <= q1_max
    bad = log.status == "violates_limits"
    assert bad.any()
    np.testing.assert_array_equal(bad, log.clamped)
    assert set(log.binding[bad]) == {"joint 1 upper end-stop"}
    assert np.isclose(log.q[np.argmax(bad) + 1 :, 0], q1_max).all()


# --- CSV -----------------------------------------------------------------------------------


def test_csv_contract(tmp_path) -> None:
    log = short_run(steps=12)
    path = log.to_csv(tmp_path / "run.csv")
    with path.open() as handle:
        rows = list(csv.reader(handle))
    assert rows[0][:10] == "t,q1,q2,q3,q4,x,y,p,lam1,lam2".split(",")
    assert rows[0][10:] == ["status", "binding", "path", "clamped", "solve_time_us", "pull_scale"]
    assert len(rows) == 13
    numbers = np.array([[float(v) for v in row[:10]] for row in rows[1:]])
    expected = np.column_stack([log.t, log.q, log.position, log.p, log.lam])
    np.testing.assert_allclose(numbers, expected, rtol=1e-11, atol=1e-14)
    assert [row[10] for row in rows[1:]] == list(log.status)


def test_csv_writes_nan_for_missing_multipliers(tmp_path) -> None:
    path = short_run("lp1", steps=3).to_csv(tmp_path / "lp1.csv")
    row = path.read_text().splitlines()[1].split(",")
    assert row[8:10] == ["nan", "nan"]


def test_csv_unwritable_is_a_value_error(tmp_path) -> None:
    with pytest.raises(ValueError, match="cannot write"):
        short_run(steps=2).to_csv(tmp_path / "missing" / "run.csv")


def test_planar_arm_without_limits_uses_model_limits() -> None:
    arm = planar_arm([1.0, 1.0], q_min=-1.0, q_max=1.0, qd_max=0.5)
    log = simulate(arm, ClampedTarget(np.array([0.0, 2.0, 0.0]), 1.0), [0.0, 0.0], 50, dt=0.1)
    assert np.abs(log.joint_velocities()).max() <= 0.5 + 1e-9
    assert log.q.max() <= 1.0 + 1e-12


def test_simulate_and_reproduce_need_no_numba() -> None:
    """`lpik reproduce`'s extra has no numba: the numpy engine imports nothing compiled."""
    import subprocess
    import sys

    code = (
        "import sys; sys.modules['numba'] = None\n"
        "import lpik, lpik.paper.reproduce, lpik.cli.main\n"
        "lpik.cli.main.build_parser()  # every command's options, lpik map's too\n"
        "from lpik.paper.scenarios import get_scenario\n"
        "assert get_scenario('pull-in').run('lp2', steps=3).steps == 3\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
