"""Recovery from inside the safety distance or from penetration (issue 23, item 3).

A pair closer than ``d_s`` is outside the limit its distance row keeps, as a
joint past its end-stop is outside its end-stop (tests/test_recovery.py): every
step from there is ``recovering`` and names the pair, the distance grows at
least at the damper's rate (``r (d_s - d)`` per step, to first order), no
joint limit breaks, and the rest of the command is carried out as far as the
rows allow (:mod:`lpik.collision.recovery`), for the damper's rows and for the
potential field, on the numpy and the compiled paths.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("coal")

from core_strategies import examples  # noqa: E402
from lpik import ClampedTarget, planar_arm, simulate  # noqa: E402
from lpik.collision import collision_avoidance, scene_from_dict  # noqa: E402
from lpik.collision.avoidance import damper_share  # noqa: E402
from lpik.result import RECOVERING  # noqa: E402
from lpik.robots.registry import home_configuration, load_robot  # noqa: E402

#: The issue's ball: 3 cm, inside link 4's capsule at the Panda's home configuration.
BALL, BALL_RADIUS = np.array([-0.03, 0.02, 0.70]), 0.03
#: The issue's target for the tool point [m] (the home orientation held).
PANDA_TARGET = np.array([0.55, 0.0, 0.487])
PANDA_DT, PANDA_SCENE = 0.01, (0.02, 0.1)  # d_s, d_i
PLANAR_DT, PLANAR_SCENE = 0.01, (0.05, 0.3)
#: Second-order allowance on the distance's true growth per step [m]: the rows hold
#: the first-order growth ``grad . dq`` exactly, the true distance differs by O(|dq|^2)
#: (up to 6e-5 m seen on the Panda at full speed).
SECOND_ORDER = 1e-4


def ball_scene(center, radius, safety, influence):  # type: ignore[no-untyped-def]
    """One ball (a circle in 2-D) as a scene."""
    ball = {"name": "ball", "type": "sphere", "center": [float(c) for c in center],
            "radius": radius}  # fmt: skip
    return scene_from_dict({"obstacles": [ball], "safety_distance": safety,
                            "influence_distance": influence})  # fmt: skip


def ball_at_depth(model, q0, center, radius, depth, scene, mechanism="rows"):  # type: ignore[no-untyped-def]
    """Avoidance of a ball moved along its closest pair's normal to the distance ``depth``."""
    avoid = collision_avoidance(model, ball_scene(center, radius, *scene), q0)
    near = min(avoid.proximities.at(q0), key=lambda p: p.distance)
    moved = np.asarray(center) + (depth - near.distance) * near.normal[: len(center)]
    avoid = collision_avoidance(model, ball_scene(moved, radius, *scene), q0, mechanism=mechanism)
    assert avoid.closest(q0)[0] == pytest.approx(depth, abs=1e-9)
    return avoid


def assert_recovers(model, avoid, qs, statuses, bindings, dt) -> int:  # type: ignore[no-untyped-def]
    """The contract of every step from inside ``d_s``; returns how many steps recovered."""
    safety = avoid.scene.safety_distance
    r = damper_share(avoid.approach_speed, dt, safety, avoid.scene.influence_distance)
    recovered = 0
    for k in range(len(statuses)):
        found = {p.label: p for p in avoid.proximities.at(qs[k])}
        before = {label: p.distance for label, p in found.items()}
        after = {p.label: p.distance for p in avoid.proximities.at(qs[k + 1])}
        dq = qs[k + 1] - qs[k]
        assert (qs[k + 1] >= model.q_min - 1e-9).all() and (qs[k + 1] <= model.q_max + 1e-9).all()
        assert (np.abs(dq) <= model.qd_max * dt + 1e-9).all(), k
        inside = {label: d for label, d in before.items() if d < safety - 1e-7}
        if not inside:
            continue
        recovered += 1
        assert statuses[k] == RECOVERING, (k, statuses[k])
        binding = bindings[k]
        assert binding.kind == "collision" and binding.recovering and binding in inside, k
        # the deepest pair; where two tie (links sharing a joint, the ball nearest that joint)
        # the compiled distances and coal's may round them apart either way
        assert inside[binding] <= min(inside.values()) + 1e-12, k
        for label, d in inside.items():  # at least at the damper's rate, each pair inside
            demand = r * (safety - d)
            assert found[label].gradient @ dq >= demand - 1e-12, (k, label)  # the row, exactly
            assert after[label] - d >= demand - SECOND_ORDER, (k, label)
    return recovered


# ------------------------------------------------------------------------ the planar arm


def planar():  # type: ignore[no-untyped-def]
    """The paper's 4-link arm, velocity limits of 1 rad/s."""
    return planar_arm([1.0, 1.0, 1.0, 1.0], q_min=np.full(4, -2.5), q_max=np.full(4, 2.5),
                      qd_max=1.0)  # fmt: skip


@settings(max_examples=examples(15), deadline=None)
@given(
    depth=st.floats(-0.04, 0.049),
    side=st.sampled_from([1.0, -1.0]),
    mechanism=st.sampled_from(["rows", "field"]),
)
def test_a_planar_arm_inside_d_s_recovers_at_the_dampers_rate(depth, side, mechanism) -> None:
    arm = planar()
    q0 = np.array([0.3, 0.4, 0.5, 0.6])
    frames = arm.kinematics.joint_frames(q0)
    elbow, wrist = frames[1][:2, 3], frames[2][:2, 3]  # link 2 runs between them
    along = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    normal = side * np.array([-along[1], along[0]])
    center = 0.5 * (elbow + wrist) + 0.3 * normal
    avoid = ball_at_depth(arm, q0, center, 0.15, depth, PLANAR_SCENE, mechanism)
    goal = arm.pose(q0) - np.append(0.3 * normal, 0.0)  # away from the ball's side
    log = simulate(arm, ClampedTarget(goal), q0, 200, dt=PLANAR_DT, scene=avoid)
    qs = [*log.q, log.q_end]
    assert assert_recovers(arm, avoid, qs, log.status, log.binding, PLANAR_DT) >= 1
    assert avoid.closest(log.q_end)[0] >= PLANAR_SCENE[0] - 1e-3  # back at d_s
    assert np.linalg.norm(arm.pose(log.q_end)[:2] - goal[:2]) < 1e-3  # and on target


# ---------------------------------------------------------------------------- the Panda


def panda_goal(model, q0):  # type: ignore[no-untyped-def]
    """The issue's target pose: the tool point at PANDA_TARGET, the home orientation."""
    goal = model.pose(q0).copy()
    goal[:3, 3] = PANDA_TARGET
    return goal


@settings(max_examples=examples(5), deadline=None)
@given(depth=st.floats(-0.035, 0.019), mechanism=st.sampled_from(["rows", "field"]))
def test_the_panda_inside_d_s_recovers_at_the_dampers_rate(depth, mechanism) -> None:
    panda, q0 = load_robot("panda"), home_configuration("panda")
    avoid = ball_at_depth(panda, q0, BALL, BALL_RADIUS, depth, PANDA_SCENE, mechanism)
    # the stall stage (opt-in) carries the command on along the obstacle once back at d_s,
    # where the damper's row alone stops the tool short of the target
    log = simulate(panda, ClampedTarget(panda_goal(panda, q0)), q0, 60, dt=PANDA_DT,
                   scene=avoid, on_stall=1)  # fmt: skip
    qs = [*log.q, log.q_end]
    assert assert_recovers(panda, avoid, qs, log.status, log.binding, PANDA_DT) >= 1
    tool = [np.linalg.norm(panda.pose(q)[:3, 3] - PANDA_TARGET) for q in qs]
    assert tool[-1] < tool[0] - 0.04  # the command carried on meanwhile (4.98 cm seen at least)


# ----------------------------------------------------------- the two cases of the issue


@pytest.mark.parametrize("mechanism", ["rows", "field"])
@pytest.mark.parametrize("depth", [-0.0315357527829987, 0.0158])
def test_the_reported_starts_recover_and_reach_the_target(depth, mechanism) -> None:
    """-31.5 mm (the ball inside link 4's capsule) and 15.8 mm (inside d_s = 20 mm): both
    froze (p = 0, status optimal) or stayed in penetration before."""
    panda, q0 = load_robot("panda"), home_configuration("panda")
    avoid = ball_at_depth(panda, q0, BALL, BALL_RADIUS, depth, PANDA_SCENE, mechanism)
    log = simulate(panda, ClampedTarget(panda_goal(panda, q0)), q0, 600, dt=PANDA_DT,
                   scene=avoid, on_stall=1)  # fmt: skip
    qs = [*log.q, log.q_end]
    assert log.status[0] == RECOVERING and log.binding[0] == "collision panda_link4 - ball"
    assert assert_recovers(panda, avoid, qs, log.status, log.binding, PANDA_DT) >= 1
    assert avoid.closest(log.q_end)[0] >= PANDA_SCENE[0] - 1e-3
    assert np.linalg.norm(panda.pose(log.q_end)[:3, 3] - PANDA_TARGET) < 1e-3


# ------------------------------------------------------------------- the compiled path


@pytest.mark.parametrize("mechanism", ["rows", "field"])
@pytest.mark.parametrize("compiled_distances", [True, False])
@pytest.mark.parametrize("depth", [-0.0315357527829987, 0.0158])
def test_the_compiled_controller_recovers_as_the_numpy_loop(
    depth, compiled_distances, mechanism
) -> None:  # type: ignore[no-untyped-def]
    """From inside the ball (penetrating, or inside d_s), with the damper's rows or the
    field alone (its force inside the compiled step, or through coal), under step and
    step_into alike: recovering, naming the pair, out of d_s by the end."""
    from lpik.control.avoiding_controller import AvoidingLp2Controller

    panda, q0 = load_robot("panda"), home_configuration("panda")
    avoid = ball_at_depth(panda, q0, BALL, BALL_RADIUS, depth, PANDA_SCENE, mechanism)
    goal = panda_goal(panda, q0)
    controller = AvoidingLp2Controller(panda, avoid, dt=PANDA_DT,
                                       compiled_distances=compiled_distances)  # fmt: skip
    qs, statuses, bindings, prev = [q0.copy()], [], [], None
    out = np.empty(panda.n_joints)
    for k in range(80):
        q = qs[-1]
        if k % 2:  # step_into takes the same steps
            controller.step_into(q, goal, prev, out=out)
            status, binding, q_next = controller.last_status, controller.last_binding, out.copy()
        else:
            result = controller.step(q, goal, prev)
            status, binding, q_next = result.status, result.binding, result.q
        statuses.append(status)
        bindings.append(binding)
        prev = q
        qs.append(q_next)
    assert statuses[0] == RECOVERING and bindings[0] == "collision panda_link4 - ball"
    assert assert_recovers(panda, avoid, qs, statuses, bindings, PANDA_DT) >= 1
    assert avoid.closest(qs[-1])[0] >= PANDA_SCENE[0] - 1e-3


def test_a_compiled_recovering_step_reads_the_kernels_distances_and_rows() -> None:
    """The recovery stage after a compiled step asks coal nothing: the step's own distances
    and rows (in the state) serve it, so a recovering step costs no second distance query."""
    from lpik.control.avoiding_controller import AvoidingLp2Controller

    panda, q0 = load_robot("panda"), home_configuration("panda")
    avoid = ball_at_depth(panda, q0, BALL, BALL_RADIUS, -0.0315357527829987, PANDA_SCENE)
    controller = AvoidingLp2Controller(panda, avoid, dt=PANDA_DT, compiled_distances=True)
    goal = panda_goal(panda, q0)
    expected = AvoidingLp2Controller(panda, avoid, dt=PANDA_DT, compiled_distances=False)
    asked = []
    at = avoid.proximities.at
    avoid.proximities.at = lambda q: asked.append(q) or at(q)  # type: ignore[method-assign]
    try:
        result = controller.step(q0, goal)
    finally:
        avoid.proximities.at = at  # type: ignore[method-assign]
    assert result.status == RECOVERING and result.binding == "collision panda_link4 - ball"
    assert asked == []
    reference = expected.step(q0, goal)  # coal's rows, coal's distances: the same step
    np.testing.assert_allclose(result.q, reference.q, atol=1e-9)


@pytest.mark.parametrize("compiled_distances", [True, False])
@pytest.mark.parametrize("qdd_max", [None, 10.0])
def test_the_recovery_rule_on_the_state_rows_is_the_rule_on_the_problem(
    compiled_distances: bool, qdd_max: float | None
) -> None:
    """Recovering steps on the state's rows and LP inputs, no numpy problem built (both cases
    of the rule: a step that keeps the direction and the rows, marked; the recovery step's
    LPs): step for step, the same steps, statuses and bindings as the rule on the step's
    problem (:func:`lpik.collision.recovery.recovered`), with and without acceleration
    limits."""
    from lpik.control.avoiding_controller import AvoidingLp2Controller

    panda, q0 = load_robot("panda"), home_configuration("panda")
    avoid = ball_at_depth(panda, q0, BALL, BALL_RADIUS, -0.0315357527829987, PANDA_SCENE)
    fast, slow = (AvoidingLp2Controller(panda, avoid, dt=PANDA_DT, v_max=0.2,
                                        qdd_max=qdd_max, compiled_distances=compiled_distances)
                  for _ in range(2))  # fmt: skip
    slow._recovered_in_state = lambda *args: None  # type: ignore[method-assign]
    in_state = fast._recovered_in_state
    hits = []
    fast._recovered_in_state = (  # type: ignore[method-assign]
        lambda *args: hits.append(in_state(*args)) or hits[-1]
    )
    goal = panda_goal(panda, q0)
    q, prev = q0.copy(), q0.copy()
    for _ in range(150):
        a, b = fast.step(q, goal, prev), slow.step(q, goal, prev)
        np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
        assert (a.status, a.method) == (b.status, b.method)
        assert a.p == pytest.approx(b.p, abs=1e-12)
        assert (None if a.binding is None else a.binding.as_dict()) == (
            None if b.binding is None else b.binding.as_dict()
        )
        prev, q = q, a.q
    served = [hit for hit in hits if hit is not None]
    assert sum(hit.method != "recovery" for hit in served) >= 10  # marked, from the state's rows
    assert sum(hit.method == "recovery" for hit in served) >= 5  # the LPs on the state's arrays


# ---------------------------------------------------- pairs whose gradients contradict

#: A UR5e folded onto itself (elbow on its end-stop at pi): seven link pairs overlap by up
#: to 97 mm, and no step moves all of them apart (a closed-loop fuzz with one bad
#: ``q_prev`` sample ended here).
FOLDED_UR5E = np.array([-1.503, -1.79, np.pi, -1.672, -2.608, 1.069])


def total_penetration(avoid, q) -> float:  # type: ignore[no-untyped-def]
    """The sum over pairs of how far each is inside ``d_s`` [m]."""
    safety = avoid.scene.safety_distance
    return sum(max(0.0, safety - p.distance) for p in avoid.proximities.at(q))


def test_a_folded_arm_comes_apart_where_no_step_moves_every_pair_apart() -> None:
    """Where the pairs' distance gradients contradict each other (the largest share of their
    demand is 0), the recovery step is the step of least total penetration: the arm comes
    apart instead of standing still, the compiled rule on the state's rows takes the same
    steps as the rule on the step's problem, and no joint limit breaks."""
    from lpik import Lp2Controller

    ur5e = load_robot("ur5e", task="position")
    far = ball_scene([3.0, 3.0, 3.0], 0.05, 0.02, 0.1)
    avoid = collision_avoidance(ur5e, far, home_configuration("ur5e"))
    fast, slow = (Lp2Controller(ur5e, dt=0.01, scene=avoid, qdd_max=10.0) for _ in range(2))
    slow._recovered_in_state = lambda *args: None  # type: ignore[method-assign]
    in_state, hits = fast._recovered_in_state, []
    fast._recovered_in_state = (  # type: ignore[method-assign]
        lambda *args: hits.append(in_state(*args)) or hits[-1]
    )
    target = np.array([0.3, 0.2, 0.5])
    q, prev = FOLDED_UR5E.copy(), FOLDED_UR5E.copy()
    before = total_penetration(avoid, q)
    for _ in range(60):
        a, b = fast.step(q, target, prev), slow.step(q, target, prev)
        np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-9)
        assert a.status == b.status == RECOVERING
        assert np.all(a.q >= ur5e.q_min - 1e-9) and np.all(a.q <= ur5e.q_max + 1e-9)
        prev, q = q, a.q
    # served from the state's rows, but where the acceleration limits carry the arm into
    # another pair's d_s whatever the step (no LP answers: the braking safe step, alike)
    assert sum(hit is not None for hit in hits) >= 55
    assert total_penetration(avoid, q) < before - 0.05


def test_only_the_rows_of_pairs_inside_demand_an_increase() -> None:
    """A label names one row per capsule pair: of a link pair inside ``d_s``, the row of a
    capsule pair outside it is an ordinary row and a reserved row left empty (``0 dq <=
    1e9``) is none; neither is asked to move apart (a demand of 1e9 broke the share LP)."""
    from lpik.collision.avoidance import INACTIVE_RHS
    from lpik.collision.recovery import demanding_rows, inside_pairs

    labels = ["a - b", "a - b", "a - b", "c - d"]
    G = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    g = np.array([INACTIVE_RHS, -0.002, 0.003, -0.001])
    inside = inside_pairs(["a - b", "a - b", "c - d"], [0.015, -0.03, 0.01], safety=0.02)
    assert inside == {"a - b": -0.03, "c - d": 0.01}  # the deepest of a label's pairs
    assert demanding_rows(labels, G, g, inside) == [1, 3]  # deepest first


def test_a_pair_no_joint_moves_apart_is_reported_inside() -> None:
    """A ball at the Panda's shoulder, 6.6 mm from links 1 and 2 (inside ``d_s``), where their
    closest points lie on the first joints' axes: no joint changes the distance, so the
    pair has no row and no step recovers. The arm still follows its command, and every
    step is ``recovering``, naming the pair, on both paths (the compiled one raised an
    IndexError on its empty rows, the numpy one said ``optimal``)."""
    from lpik import Lp2Controller

    panda = load_robot("panda", task="position")
    home = home_configuration("panda")
    scene = ball_scene([0.10164088326575398, 0.03279898085930831, 0.29332339766886983],
                       0.047352300548661075, 0.02, 0.1)  # fmt: skip
    target = panda_goal(load_robot("panda"), home)[:3, 3]
    avoid = collision_avoidance(panda, scene, home)
    controller = Lp2Controller(panda, dt=0.01, scene=avoid, qdd_max=10.0)
    numpy_log = simulate(panda, ClampedTarget(target), home, 100, dt=0.01, scene=avoid,
                         qdd_max=10.0)  # fmt: skip
    q, prev = home.copy(), home.copy()
    for k in range(100):
        assert avoid.closest(q)[0] < 0.02
        result = controller.step(q, target, prev)
        assert result.status == numpy_log.status[k] == RECOVERING
        assert result.binding.kind == "collision" and result.binding.recovering
        assert result.binding.name in {"panda_link1 - ball", "panda_link2 - ball"}
        prev, q = q, result.q
    assert np.linalg.norm(panda.pose(q) - target) < np.linalg.norm(panda.pose(home) - target) / 2
