"""The velocity damper's rows and the potential field, step by step and over whole runs."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.collision_cases import PULL_IN, Q0, arm, circle_scene
from tests.core_reference import hard_violation, lp1_reference, lp2_reference

from lpik.collision import DistanceRows, collision_avoidance, field_force, repulsion
from lpik.collision.avoidance import damper_row, field_scale
from lpik.collision.recovery import RECOVERY, inside_rows
from lpik.command import ClampedTarget
from lpik.control.simulate import simulate
from lpik.limits import build_problem, standard_limits
from lpik.methods import solve
from lpik.methods.progress import least_error_lp
from lpik.robots.planar import planar_arm
from lpik.tolerances import FEASIBILITY_TOL

DT = 0.01


def step_problem(model, avoid, q, target):  # type: ignore[no-untyped-def]
    J = model.jacobian(q)
    dw = ClampedTarget(target, v_max=0.5)(model, q, DT)
    limits = [*standard_limits(model), *avoid.limits()]
    return avoid.with_field(build_problem(J, dw, q, limits, dt=DT), DT)


def test_a_row_bounds_the_approach_as_faverjon_and_tournassoud_write_it() -> None:
    model = arm()
    scene = circle_scene((1.3, 1.75), 0.2)
    avoid = collision_avoidance(model, scene, None, self_collision=False)
    G, h, names = DistanceRows(avoid.proximities, approach_speed=0.4).rows(Q0, DT)
    near = [p for p in avoid.proximities.at(Q0) if p.distance < scene.influence_distance]
    assert names == tuple(p.label for p in near) and names
    for row, rhs, p in zip(G, h, near):
        np.testing.assert_allclose(row, -p.gradient)
        allowed = 0.4 * DT * max(p.distance - 0.05, 0.0) / (0.3 - 0.05)
        assert rhs - row @ Q0 == pytest.approx(allowed)


@settings(deadline=None, max_examples=40)
@given(
    lengths=st.lists(st.floats(0.3, 1.5), min_size=3, max_size=6),
    angles=st.lists(st.floats(-2.5, 2.5), min_size=6, max_size=6),
    center=st.tuples(st.floats(-3.5, 3.5), st.floats(-3.5, 3.5)),
    radius=st.floats(0.05, 0.5),
    target=st.tuples(st.floats(-3, 3), st.floats(-3, 3)),
    method=st.sampled_from(["lp1", "l1", "lp2"]),
)
def test_no_step_of_a_hard_row_method_brings_a_pair_below_the_safety_distance(
    lengths, angles, center, radius, target, method
) -> None:  # type: ignore[no-untyped-def]
    model = planar_arm(lengths, q_min=-np.pi, q_max=np.pi, qd_max=1.0)
    q = np.array(angles[: len(lengths)])
    avoid = collision_avoidance(model, circle_scene(center, radius), None)
    P = step_problem(model, avoid, q, np.array([*target, 0.0]))
    result = solve(P, method, model=model)
    inside = bool(avoid.inside(q))
    if inside:  # the recovery stage every stepper runs from inside d_s (lpik.collision.recovery)
        result = avoid.recovered(P, result, DT, least_error_lp)
    assert 0.0 <= result.p <= 1.0
    if not inside:  # (inside, the rows demand the distance back: checked below)
        assert hard_violation(P, result.q) <= 1e-7
    if result.moved and not inside:
        np.testing.assert_allclose(P.J @ (result.q - q), result.p * P.dw, atol=1e-7)
    # the LP's own answer against HiGHS on the paper's LP, written independently
    reference = {"lp1": lp1_reference, "lp2": lp2_reference}.get(method)
    if reference is not None and result.status == "optimal":
        ref = reference(P)
        assert ref.feasible and result.p == pytest.approx(ref.p, abs=1e-6)
    before = avoid.proximities.at(q)
    dq = result.q - q
    # to first order (what the rows hold exactly): no pair within d_i ends below
    # min(d_s, its distance now) ...
    near = [p for p in before if p.distance < 0.3]
    deeper = [p.label for p in near if p.distance + p.gradient @ dq < min(0.05, p.distance) - 1e-7]
    if deeper:  # ... but for pairs inside whose gradients contradict: the restoration lets
        # one go deeper where that lets the others come apart by more, the rows' total
        # shortfall no larger than standing still's (lpik.collision.recovery.restoration)
        assert result.method == RECOVERY and set(deeper) <= set(avoid.inside(q)), deeper
        rows_problem = avoid.with_rows(P, avoid.inside(q), DT)
        rows = inside_rows(rows_problem, avoid.inside(q))
        G = rows_problem.G[rows]
        demand = rows_problem.h[rows] - G @ q
        shortfall = np.maximum(G @ dq - demand, 0.0).sum()
        assert shortfall <= np.abs(demand).sum() + 1e-9
    # the true distance after the step, with an allowance for the second-order term
    # (at most |dq|^2 times the squared reach over the obstacle's radius)
    reach = sum(lengths)
    slack = (reach * np.abs(dq).sum()) ** 2 / radius + 1e-12  # (and the distances' rounding)
    distance_before = {p.label: p.distance for p in before}
    for p in avoid.proximities.at(result.q):
        assert p.distance >= min(0.05, distance_before[p.label]) - slack, p.label


def test_the_field_is_khatibs_force_along_the_distance_gradient() -> None:
    model = arm()
    scene = circle_scene((1.3, 1.75), 0.2)
    found = collision_avoidance(model, scene, None, self_collision=False).proximities.at(Q0)
    f = field_force(found, 0.01, 0.3, DT)
    expected = sum(DT * 0.01 * (1 / p.distance - 1 / 0.3) / p.distance**2 * p.gradient
                   for p in found if p.distance < 0.3)  # fmt: skip
    np.testing.assert_allclose(f, expected)
    assert repulsion(0.31, 1.0, 0.3) == 0.0
    assert repulsion(0.1, 1.0, 0.3) == pytest.approx((10 - 1 / 0.3) / 0.01)
    # the force increases every distance it acts on, to first order
    for p in found:
        if p.distance < 0.3:
            assert p.gradient @ f > 0


def test_the_fields_own_step_keeps_within_the_limits() -> None:
    J = np.array([[1.0, 1.0, 0.0]])
    force = np.array([0.0, 0.0, 1.0])
    lo, hi = np.full(3, -0.01), np.array([0.01, 0.01, 0.004])
    assert field_scale(force, J, np.eye(3), lo, hi) == pytest.approx(0.5 * 0.004)
    assert field_scale(force, J, np.eye(3), lo, np.array([0.01, 0.01, 0.0])) == 0.0
    # measured from the rest of the step at p = 0 (under acceleration limits: the motion kept)
    rest = np.array([0.0, 0.0, 0.002])
    assert field_scale(force, J, np.eye(3), lo, hi, rest) == pytest.approx(0.5 * 0.002)
    # never past a row: G dq <= g with G = e3, g = 0.0025 leaves 0.0005 beyond rest
    rows = (np.array([[0.0, 0.0, 1.0]]), np.array([0.0025]))
    assert field_scale(force, J, np.eye(3), lo, hi, rest, rows) == pytest.approx(0.0005)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 8), st.integers(1, 6), st.integers(0, 2))
def test_the_fields_null_space_motion_solves_the_kkt_system(
    seed: int, n: int, m: int, deficiency: int
) -> None:
    """null_space_motion against a least-squares solve of [[M, J^T], [J, 0]] [dq; lam] = [f; 0]
    (an independent path), J of full or deficient rank, M symmetric positive definite; and its
    compiled twin (the Jacobi SVD, :func:`lpik.fast.step.field_in_state`'s) against it."""
    from lpik.collision.avoidance import null_space_motion

    rng = np.random.default_rng(seed)
    m = min(m, n)
    rank = max(1, m - deficiency)
    J = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n)
    f = rng.normal(size=n)
    kkt = np.block([[M, J.T], [J, np.zeros((m, m))]])
    expected = np.linalg.lstsq(kkt, np.concatenate([f, np.zeros(m)]), rcond=None)[0][:n]
    dq = null_space_motion(J, M, f)
    size = np.abs(f).max()  # |dq| <= |f| / lambda_min(M), lambda_min(M) >= n
    # lstsq decides the rank of the whole KKT matrix, and its accuracy is that of its condition
    np.testing.assert_allclose(dq, expected, rtol=0, atol=1e-6 * size)
    np.testing.assert_allclose(J @ dq, 0.0, rtol=0, atol=1e-12 * np.abs(J).max() * size)
    pytest.importorskip("numba")
    from lpik.fast.step import null_space_motion as compiled

    np.testing.assert_allclose(compiled(J, M, f), dq, rtol=0, atol=1e-12 * size)


def run(method, mechanism, scene, target, steps):  # type: ignore[no-untyped-def]
    model = arm()
    avoid = collision_avoidance(model, scene, Q0, mechanism=mechanism)
    return model, simulate(model, ClampedTarget(target, v_max=0.5), Q0, steps,
                           method=method, dt=DT, scene=avoid, on_stall=None)  # fmt: skip


ELBOW = circle_scene((0.8, 2.0), 0.15)


@pytest.mark.parametrize(("method", "mechanism"), [("lp1", "rows"), ("lp2", "both")])
def test_beside_the_elbow_redundancy_moves_the_elbow_and_the_tool_arrives(
    method, mechanism
) -> None:  # type: ignore[no-untyped-def]
    _, log = run(method, mechanism, ELBOW, PULL_IN, 700)
    assert np.linalg.norm(log.position_end - PULL_IN[:2]) < 1e-3
    assert log.min_distance.min() >= 0.05 - 1e-3
    assert (log.min_distance < 0.3).any()  # the obstacle did act


def test_lp2_with_rows_alone_stops_at_the_obstacle_beside_the_elbow_and_names_it() -> None:
    _, log = run("lp2", "rows", ELBOW, PULL_IN, 400)
    assert log.p[-1] < 0.05
    assert log.binding[-1].startswith("collision link") and log.binding[-1].endswith("- ball")
    assert log.min_distance.min() >= 0.05 - 1e-3


def test_on_the_tools_path_the_tool_stops_at_the_safety_distance(tmp_path) -> None:  # type: ignore[no-untyped-def]
    scene = circle_scene((2.4, 0.866), 0.1)
    _, log = run("lp2", "rows", scene, np.array([1.5, 0.866, 0.0]), 300)
    assert log.p[-1] < 1e-2
    assert log.binding[-1] == "collision link 4 - ball"
    assert log.min_distance[-1] == pytest.approx(0.05, abs=2e-3)
    assert log.min_distance.min() >= 0.05 - 1e-3
    rows = list(csv.DictReader(open(log.to_csv(tmp_path / "run.csv"), encoding="utf-8")))
    assert rows[-1]["closest"] == "link 4 - ball"
    assert float(rows[-1]["min_distance"]) == pytest.approx(log.min_distance[-1])


#: A ball 0.107 m from the planar arm's second link at Q0: within the field's reach
#: (``d_i`` 0.3 m), outside the safety distance (0.05 m); and one 3 mm inside it.
BESIDE_LINK_2 = circle_scene((0.78, 1.382), 0.15)
INSIDE_LINK_2 = circle_scene((0.81, 1.33), 0.15)


def field_runs(scene, target, qdd_max, steps, mechanism="field"):  # type: ignore[no-untyped-def]
    """The numpy engine's and the compiled controller's runs with the field: (log, qs)."""
    from lpik import Lp2Controller

    model = arm()
    avoid = collision_avoidance(model, scene, Q0, mechanism=mechanism)
    log = simulate(model, ClampedTarget(target, v_max=0.5), Q0, steps, method="lp2s", dt=DT,
                   scene=avoid, qdd_max=qdd_max)  # fmt: skip
    controller = Lp2Controller(model, dt=DT, qdd_max=qdd_max, scene=avoid, v_max=0.5)
    q, prev, qs, statuses = Q0.copy(), Q0.copy(), [], []
    for _ in range(steps):
        result = controller.step(q, target, prev)
        q, prev = result.q, q
        qs.append(q)
        statuses.append(result.status)
    return log, np.array(qs), statuses


@pytest.mark.parametrize("qdd_max", [1.0, 5.0])
@pytest.mark.parametrize("scene", [BESIDE_LINK_2, INSIDE_LINK_2], ids=["beside", "inside"])
def test_under_acceleration_limits_the_field_moves_an_arm_at_rest_within_them(
    scene, qdd_max
) -> None:  # type: ignore[no-untyped-def]
    """The field's step at ``p = 0`` is measured against the acceleration band, not the
    velocity room alone: before, every step of an arm at rest within the field's reach was
    infeasible (held by the safe step), or, from inside ``d_s``, recovering for good at it."""
    hold = np.asarray(arm().pose(Q0))
    log, qs, statuses = field_runs(scene, hold, qdd_max, 200)
    np.testing.assert_allclose(qs, np.vstack([log.q[1:], log.q_end]), atol=1e-9)
    assert list(log.status) == statuses
    back = int(np.argmax(log.status != "recovering"))  # out of d_s (none from outside it)
    assert back < 60 and set(log.status[back:]) == {"optimal"}
    assert log.min_distance[-1] > log.min_distance[0] + 0.1  # the field pushed the link away
    q_all = np.vstack([log.q, log.q_end])
    assert np.abs(np.diff(q_all, 2, axis=0)).max() <= qdd_max * DT**2 * (1 + 1e-9)
    assert np.abs(log.position_end - hold[:2]).max() < 1e-6  # the tool held where it was


def test_under_acceleration_limits_the_field_and_rows_steer_the_tool_to_its_target() -> None:
    """Before, the field asked for more than the acceleration band: the tool never arrived."""
    log, qs, statuses = field_runs(BESIDE_LINK_2, PULL_IN, 5.0, 900, mechanism="both")
    # near the target rounding apart grows to 5e-5 rad between the two (the field alone,
    # without acceleration limits, did the same before: 6.6e-3)
    np.testing.assert_allclose(qs[:600], log.q[1:601], atol=1e-9)
    for taken in (list(log.status), statuses):
        assert "infeasible" not in taken
    assert np.linalg.norm(log.position_end - PULL_IN[:2]) < 1e-6
    assert np.linalg.norm(arm().position(qs[-1]) - PULL_IN[:2]) < 1e-6
    assert log.min_distance.min() >= 0.05 - 1e-9


def test_with_rows_and_field_the_field_never_pushes_a_pair_through_its_row() -> None:
    """Near the target the field pushed links 2 and 4 together while it pushed link 2 off
    the ball: its own step broke their row, and 375 of these 1000 steps were infeasible."""
    log, qs, statuses = field_runs(BESIDE_LINK_2, PULL_IN, None, 1000, mechanism="both")
    np.testing.assert_allclose(qs, np.vstack([log.q[1:], log.q_end]), atol=1e-9)
    assert "infeasible" not in set(log.status) and list(log.status) == statuses
    assert log.min_distance.min() >= 0.05 - 1e-9


def test_a_scene_for_the_plane_needs_a_planar_arm() -> None:
    from lpik.robots.registry import load_robot

    with pytest.raises(ValueError, match="^scene: a 2-D scene needs a planar arm"):
        collision_avoidance(load_robot("panda"), ELBOW, None)
    with pytest.raises(ValueError, match="^mechanism:"):
        collision_avoidance(arm(), ELBOW, None, mechanism="magic")
    with pytest.raises(ValueError, match="^approach_speed:"):
        collision_avoidance(arm(), ELBOW, None, approach_speed=float("nan"))


@settings(deadline=None, max_examples=15)
@given(
    offset=st.lists(st.floats(-0.4, 0.4), min_size=7, max_size=7),
    center=st.tuples(st.floats(-0.2, 0.8), st.floats(-0.5, 0.5), st.floats(0.0, 1.0)),
    radius=st.floats(0.03, 0.2),
    method=st.sampled_from(["lp1", "lp2"]),
)
def test_no_panda_step_brings_a_pair_below_the_safety_distance(
    offset, center, radius, method
) -> None:  # type: ignore[no-untyped-def]
    from lpik.collision import scene_from_dict
    from lpik.robots.registry import home_configuration, load_robot

    model = load_robot("panda", task="position")
    home = home_configuration("panda")
    q = np.clip(home + np.array(offset), model.q_min, model.q_max)
    scene = scene_from_dict({
        "obstacles": [{"name": "ball", "type": "sphere", "center": list(center), "radius": radius}],
        "safety_distance": 0.02, "influence_distance": 0.15,
    })  # fmt: skip
    avoid = collision_avoidance(model, scene, home)
    P = step_problem(model, avoid, q, np.array(center))  # toward the ball's centre
    result = solve(P, method, model=model)
    inside = bool(avoid.inside(q))
    if inside:  # the recovery stage every stepper runs from inside d_s (lpik.collision.recovery)
        result = avoid.recovered(P, result, DT, least_error_lp)
    assert 0.0 <= result.p <= 1.0
    if not inside:
        assert hard_violation(P, result.q) <= 1e-7
    ref = {"lp1": lp1_reference, "lp2": lp2_reference}[method](P)
    if result.status == "optimal":
        assert ref.feasible and result.p == pytest.approx(ref.p, abs=1e-6)
    step = float(np.abs(result.q - q).sum())
    slack = 0.5 * step**2 + 1e-12  # second order (|d2 d / dq2| <= 1 m: the arm spans 1 m)
    before = {p.label: p.distance for p in avoid.proximities.at(q)}
    for p in avoid.proximities.at(result.q):
        assert p.distance >= min(0.02, before[p.label]) - slack, p.label


@pytest.mark.parametrize("method", ["weighted", "robust", "lp2"])
def test_the_field_alone_steers_every_method_that_takes_f_around_the_obstacle(method) -> None:  # type: ignore[no-untyped-def]
    model, log = run(method, "field", ELBOW, PULL_IN, 700)
    assert log.min_distance.min() > 0.1  # the field keeps the elbow away by itself
    if method != "robust":  # robust's damping lags behind the command, obstacle or not
        assert np.linalg.norm(log.position_end - PULL_IN[:2]) < 1e-2
    _, without = run(method, "field", circle_scene((9.0, 9.0), 0.1), PULL_IN, 700)
    assert not np.allclose(log.q_end, without.q_end)  # it did act


def test_on_the_panda_tools_path_the_tool_stops_at_d_s_and_the_binding_names_it() -> None:
    from lpik.collision import scene_from_dict
    from lpik.paper.reach import reach_setup

    setup = reach_setup("panda", [0.6, 0.0, 0.3])
    ball = {"name": "ball", "type": "sphere", "center": [0.5, 0.0, 0.35], "radius": 0.04}
    scene = scene_from_dict({"obstacles": [ball], "safety_distance": 0.02,
                             "influence_distance": 0.12})  # fmt: skip
    log = setup.run("lp2", steps=150, scene=scene, on_stall=None)  # the strict step: it stops
    assert log.p[-1] < 1e-2
    assert log.binding[-1].startswith("collision panda_link") and log.binding[-1].endswith("ball")
    assert log.min_distance[-1] == pytest.approx(0.02, abs=2e-3)
    assert log.min_distance.min() >= 0.02 - 1e-3


def test_self_collision_rows_keep_the_pandas_hand_off_its_own_base() -> None:
    from lpik.collision import scene_from_dict
    from lpik.paper.reach import reach_setup

    setup = reach_setup("panda", [0.05, 0.0, 0.45])  # the hand moves in close to the base
    empty = scene_from_dict({"obstacles": [], "safety_distance": 0.02, "influence_distance": 0.12})
    log = setup.run("lp2", steps=250, scene=empty)
    self_bound = {
        b for b in log.binding if b and b.startswith("collision panda_link0 - panda_link7")
    }
    assert self_bound  # the hand's row against the base column stopped the command
    assert log.min_distance.min() >= 0.02 - 1e-3
    assert np.linalg.norm(log.position_end - [0.05, 0.0, 0.45]) < 1e-3


def test_a_pair_inside_the_safety_distance_by_less_than_the_check_tells_is_at_it() -> None:
    """Its row keeps the distance (no demanded increase that no check could tell from none)."""
    q0, gradient = np.array([0.3, -0.2]), np.array([0.5, 0.25])
    rows = {}
    for depth in (0.0, 0.5 * FEASIBILITY_TOL, 0.99 * FEASIBILITY_TOL, 3 * FEASIBILITY_TOL):
        row = np.empty(2)
        rows[depth] = damper_row(0.05 - depth, gradient, q0, 0.1, 0.05, row) - row @ q0
    assert rows[0.0] == rows[0.5 * FEASIBILITY_TOL] == rows[0.99 * FEASIBILITY_TOL] == 0.0
    assert rows[3 * FEASIBILITY_TOL] == pytest.approx(-0.1 * 3 * FEASIBILITY_TOL)


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    mechanism=st.sampled_from(["field", "both"]),
    qdd_max=st.sampled_from([None, 15.0]),
)
def test_the_compiled_field_keeps_every_limit_and_takes_the_numpy_steps(
    seed: int, mechanism: str, qdd_max: float | None
) -> None:
    """The Panda near a random ball with the potential field (alone or with the rows), from a
    random configuration toward a random pose, in a loop that passes q_prev: the compiled
    field (its force and share inside the compiled step) takes the numpy engine's steps, p is
    in [0, 1], no step breaks a bound or a row of its problem, and an optimal step without
    acceleration limits moves the task by exactly p dw."""
    pytest.importorskip("numba")
    from lpik.check import worst_violation
    from lpik.collision import scene_from_dict
    from lpik.control.controller import Lp2Controller
    from lpik.control.stepper import Stepper
    from lpik.result import OPTIMAL
    from lpik.robots.registry import home_configuration, load_robot

    rng = np.random.default_rng(seed)
    panda, home = load_robot("panda"), home_configuration("panda")
    q = np.clip(home + rng.normal(scale=0.3, size=7), panda.q_min + 0.1, panda.q_max - 0.1)
    elbow = panda.kinematics.joint_frames(q)[3][:3, 3]  # joint 4, the elbow
    ball = {"name": "ball", "type": "sphere", "radius": float(rng.uniform(0.02, 0.05)),
            "center": (elbow + rng.normal(scale=0.1, size=3)).tolist()}  # fmt: skip
    scene = scene_from_dict({"obstacles": [ball], "safety_distance": 0.02,
                             "influence_distance": 0.12})  # fmt: skip
    avoid = collision_avoidance(panda, scene, home, mechanism=mechanism)
    dt = 0.01
    compiled = Lp2Controller(panda, dt=dt, qdd_max=qdd_max, scene=avoid)
    numpy_engine = Stepper(panda, dt=dt, qdd_max=qdd_max, scene=avoid)
    target = panda.pose(q)
    target[:3, 3] += rng.normal(scale=0.1, size=3)
    prev = q.copy()
    for _ in range(6):
        got, ref = compiled.step(q, target, prev), numpy_engine.step(q, target, prev)
        np.testing.assert_allclose(got.q, ref.q, rtol=0, atol=1e-9)
        assert 0.0 <= got.p <= 1.0 and got.status == ref.status
        problem = compiled.problem(q, target, prev)
        if got.status == OPTIMAL:
            assert worst_violation(problem, got.dq).amount <= FEASIBILITY_TOL
            if qdd_max is None:
                np.testing.assert_allclose(problem.J @ got.dq, got.p * problem.dw, rtol=0,
                                           atol=1e-9)  # fmt: skip
        prev, q = q, got.q
