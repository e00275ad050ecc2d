"""The damper's stop ahead of ``d_i`` under acceleration limits (lpik.collision.avoidance
.braking_row, capsule_reach): the rule against its own braking guarantee, the culling of
pairs against the rule, the compiled rows against coal's, and a Panda reaching into the
shelf at the peers' command on both engines."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_strategies import examples
from lpik.bands import braking_room, stopping_distance
from lpik.collision import load_scene
from lpik.collision.avoidance import (
    ROW_BRAKING_SHARE,
    DistanceRows,
    approach_row,
    braking_row,
    damper_share,
)
from lpik.control.stepper import Stepper
from lpik.paper.collision_runs import SHELF_TARGET
from lpik.paper.reach import reach_setup

DT = 0.001
#: The shelf scene's damper (xi = 0.5 m/s): r, d_s, d_i.
SHELF = load_scene("panda-shelf")
DAMPER = (damper_share(0.5, DT, SHELF.safety_distance, SHELF.influence_distance),
          SHELF.safety_distance, SHELF.influence_distance)  # fmt: skip
#: The Panda's joints at 10 rad/s^2 either way.
QDD = (np.full(7, -10.0), np.full(7, 10.0))


@settings(max_examples=examples(200), deadline=None)
@given(room=st.floats(0.0, 0.5), step=st.floats(1e-7, 1e-2), decel=st.floats(1e-8, 1e-3))
def test_a_step_at_the_stop_ahead_leaves_a_full_braking_step_within_the_next(room, step, decel):
    """braking_room's guarantee, which the stop ahead relies on: after a step at the bound,
    the bound one step nearer is at least that step less one step of deceleration; and
    stopping_distance is braking_room's inverse."""
    assert braking_room(stopping_distance(step, decel), decel) == pytest.approx(step, rel=1e-9)
    bound = braking_room(room, decel)
    if bound <= room:
        assert braking_room(room - bound, decel) >= bound - decel - 1e-12


def pair_row(distance, gradient, q0, q_prev):  # type: ignore[no-untyped-def]
    """approach_row for one pair of the shelf's damper, the Panda's limits: ``(h - G q0, G)``."""
    row = np.zeros(gradient.size)
    h = approach_row(distance, gradient, q0, q_prev, *QDD, DT, DAMPER, row)
    return h - row @ q0, row


def test_at_d_i_the_stop_ahead_is_the_dampers_speed_and_beyond_it_grows() -> None:
    r, d_s, d_i = DAMPER
    q0, gradient = np.zeros(7), np.array([0.3, -0.2, 0.1, 0.0, 0.05, 0.0, 0.0])
    toward = q0 + 5.0 * DT * gradient  # q_prev: the pair approaching at 5 |grad|^2 = 0.71 m/s
    inside, _ = pair_row(d_i - 1e-12, gradient, q0, toward)
    at, row = pair_row(d_i, gradient, q0, toward)
    np.testing.assert_array_equal(row, -gradient)
    assert inside == pytest.approx(r * (d_i - d_s), rel=1e-9) and at == pytest.approx(inside)
    rooms = [pair_row(d_i + x, gradient, q0, toward)[0] for x in (1e-4, 1e-3, 5e-3)]
    assert at < rooms[0] < rooms[1] < rooms[2]
    decel = ROW_BRAKING_SHARE * 10.0 * DT**2 * np.abs(gradient).sum()
    assert rooms[2] == pytest.approx(
        braking_room(5e-3 + stopping_distance(r * (d_i - d_s), decel), decel), rel=1e-12
    )
    # at rest, no step within the acceleration bands can reach the bound: no row
    assert math.isnan(pair_row(d_i + 1e-3, gradient, q0, q0)[0])
    # nor without acceleration limits, nor where the pair hardly depends on q
    row = np.zeros(7)
    assert math.isnan(braking_row(d_i + 1e-3, gradient, q0, toward, np.full(7, -np.inf),
                                  np.full(7, np.inf), DT, r * (d_i - d_s), d_i, row))  # fmt: skip
    assert math.isnan(pair_row(d_i + 1e-3, np.full(7, 1e-12), q0, toward)[0])


@st.composite
def moving_pandas(draw):  # type: ignore[no-untyped-def]
    """A Panda configuration in the shelf scene and a previous one up to 2.5 rad/s away."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    setup = reach_setup("panda", SHELF_TARGET)
    q0 = rng.uniform(setup.model.q_min, setup.model.q_max)
    speed = rng.uniform(0.0, 2.5) * rng.uniform(-1.0, 1.0, 7) * rng.integers(0, 2, 7)
    return q0, q0 - speed * DT


@settings(max_examples=examples(40), deadline=None)
@given(state=moving_pandas())
def test_no_pair_left_out_beyond_its_reach_needs_a_stop_ahead(state) -> None:
    """capsule_reach's culling against the rule: a pair farther than d_i plus its capsules'
    reach has no row when its gradient is taken after all."""
    pytest.importorskip("coal")
    q0, q_prev = state
    rows = DistanceRows(Stepper(reach_setup("panda", SHELF_TARGET).model, dt=DT,
                                scene=SHELF).avoidance.proximities, accelerations=QDD)  # fmt: skip
    reach = rows._pair_reach(q0, q_prev, *QDD, DT)
    for p, ahead in zip(rows.proximities.at(q0), reach):
        if p.distance >= SHELF.influence_distance + ahead:
            assert math.isnan(pair_row(p.distance, p.gradient, q0, q_prev)[0]), p.label


def shelf_reach(compile):  # type: ignore[no-untyped-def]
    """The Panda from its shelf setup towards the target under the shelf's top, the command
    unclamped (the peers' V = error / dt), 10 rad/s^2, on the numpy engine or compiled."""
    from lpik.control.controller import Lp2Controller

    setup = reach_setup("panda", SHELF_TARGET)
    options = dict(dt=DT, qdd_max=10.0, v_max=1e6, w_max=1e6, scene=SHELF)
    if compile:
        return setup, Lp2Controller(setup.model, compile="now", **options)
    return setup, Stepper(setup.model, **options)


@pytest.mark.parametrize("compiled", [False, True], ids=["numpy", "compiled"])
def test_a_panda_reaching_into_the_shelf_at_full_command_keeps_every_damper_row(compiled):
    """Before the stop ahead, link 7 met d_i at about 0.6 m/s: six steps came nearer than
    their rows allow, and eight were braking stops. Now each pair within d_i keeps its row
    (to second order), no step is a stop, and the tool arrives."""
    if compiled:
        pytest.importorskip("numba")
    pytest.importorskip("coal")
    setup, controller = shelf_reach(compiled)
    r, d_s, d_i = DAMPER
    proximities = controller.avoidance.proximities
    q, q_prev = setup.q0.copy(), setup.q0.copy()
    ahead = 0
    for _ in range(400):
        before = np.array([p.distance for p in proximities.at(q)])
        result = controller.step(q, setup.target, q_prev)
        assert result.status in ("optimal", "off_direction"), result.status
        after = np.array([p.distance for p in proximities.at(result.q)])
        watched = (before >= d_s) & (before < d_i)
        assert np.all(after[watched] >= (1 - r) * before[watched] + r * d_s - 1e-5)
        ahead += (result.binding or "").startswith("collision") and before.min() >= d_i
        q_prev, q = q, np.asarray(result.q, dtype=np.float64)
    assert ahead > 0  # a stop ahead of d_i bound the arm
    while np.linalg.norm(setup.model.kinematics.fk(q)[:3, 3] - SHELF_TARGET) > 1e-6 and _ < 3000:
        result = controller.step(q, setup.target, q_prev)
        q_prev, q, _ = q, np.asarray(result.q, dtype=np.float64), _ + 1
    assert np.linalg.norm(setup.model.kinematics.fk(q)[:3, 3] - SHELF_TARGET) <= 1e-6


@pytest.mark.parametrize("speed", [1.0, 2.5])
def test_the_compiled_stop_ahead_is_coals_in_motion(speed) -> None:
    """The compiled distance rows, the stops ahead among them, equal coal's rows at random
    configurations moving at up to ``speed`` rad/s (as test_avoiding_step does at rest)."""
    pytest.importorskip("numba")
    pytest.importorskip("coal")
    from lpik.control.controller import Lp2Controller

    setup = reach_setup("panda", SHELF_TARGET)
    controller = Lp2Controller(setup.model, dt=DT, qdd_max=10.0, scene=SHELF, compile="now")
    rng, ahead = np.random.default_rng(11), 0
    for _ in range(80):
        q = rng.uniform(setup.model.q_min, setup.model.q_max)
        q_prev = q - rng.uniform(-speed, speed, 7) * DT
        controller.step(q, setup.target, q_prev)
        rows = controller.scene_rows
        G, h = rows.G.copy(), rows.h.copy()
        controller.problem(q, setup.target, q_prev)  # coal's rows into the same block
        active = h < 1e8
        np.testing.assert_array_equal(active, rows.h < 1e8)
        beyond = active & (controller.found[:, 0] >= SHELF.influence_distance)
        np.testing.assert_allclose(G[beyond], rows.G[beyond], rtol=0, atol=1e-9)
        np.testing.assert_allclose((h - G @ q)[beyond], (rows.h - rows.G @ q)[beyond], rtol=0,
                                   atol=1e-9)  # fmt: skip
        ahead += int(beyond.sum())
    assert ahead > 0
