"""The fused step with compiled distance rows against coal and the numpy layers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")
pytest.importorskip("coal")

from lpik.collision import load_scene  # noqa: E402
from lpik.control.avoiding_controller import AvoidingLp2Controller  # noqa: E402
from lpik.methods.lp2 import lp2  # noqa: E402
from lpik.paper.collision_runs import SHELF_TARGET  # noqa: E402
from lpik.paper.reach import reach_setup  # noqa: E402

#: The benchmark's scene: the shelf and a sphere, a capsule and a turned box (10 obstacles).
SCENE = Path(__file__).resolve().parents[1] / "benchmarks" / "scenes" / "panda-shelf-10.json"


def active(problem, q, label) -> bool:  # type: ignore[no-untyped-def]
    """Whether the row called ``label`` holds with equality at ``q``."""
    k = list(problem.row_labels).index(label)
    return abs(problem.G[k] @ q - problem.h[k]) <= 1e-9 * max(1.0, abs(problem.h[k]))


def panda_in_clutter() -> tuple:  # type: ignore[type-arg]
    setup = reach_setup("panda", SHELF_TARGET)
    scene = load_scene(SCENE)
    return setup, scene, AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt)


def compiled_rows(controller, q, target) -> tuple:  # type: ignore[no-untyped-def,type-arg]
    """The step's result and the rows the compiled step wrote, then coal's rows at ``q``."""
    result = controller.step(q, target)
    G, h = controller.scene_rows.G.copy(), controller.scene_rows.h.copy()
    problem = controller.problem(q, target)  # writes coal's rows into the same block
    return result, G, h, controller.scene_rows.G.copy(), controller.scene_rows.h.copy(), problem


def assert_found_matches_coal(controller, q) -> None:  # type: ignore[no-untyped-def]
    """Each pair's kernel distance against coal's, or its bound for a pair culled beyond d_i.

    Within d_i also the normal; the witness points enter the rows (:func:`assert_rows_agree`).
    """
    d_i = controller.avoidance.scene.influence_distance
    for found, p in zip(controller.found, controller.avoidance.proximities.at(q)):
        if np.isnan(found[1]):  # culled: a lower bound beyond d_i
            assert d_i < found[0] <= p.distance + 1e-9  # coal: to 1e-9
            continue
        assert abs(found[0] - p.distance) <= 1e-9
        if p.distance < d_i:
            np.testing.assert_allclose(found[7:], p.normal, rtol=0, atol=1e-9)


def assert_rows_agree(controller, q, G, h, G_coal, h_coal) -> int:  # type: ignore[no-untyped-def]
    """The compiled rows equal coal's, but for ties; returns how many rows were ties.

    A tie: a link parallel to a box's face has a segment of closest points, and
    coal's GJK returns one of them, the kernel another. Both must then be closest
    points: the same distance and normal, ``p2 - p1 = d n`` on both sides.
    """
    ties, room = 0, np.abs((h - G @ q) - (h_coal - G_coal @ q))  # the rows' room, h - G q0
    for k in np.nonzero(np.abs(G - G_coal).max(axis=1) + np.where(h < 1e8, room, 0) > 1e-9)[0]:
        p, found = controller.avoidance.proximities.at(q)[k], controller.found[k]
        assert abs(found[0] - p.distance) <= 1e-9
        np.testing.assert_allclose(found[7:], p.normal, rtol=0, atol=1e-9)
        np.testing.assert_allclose(found[4:7] - found[1:4], p.distance * p.normal, atol=1e-9)
        np.testing.assert_allclose(p.other_point - p.point, p.distance * p.normal, atol=1e-9)
        ties += 1
    return ties


def test_the_panda_among_ten_obstacles_keeps_its_distances_in_one_compiled_call() -> None:
    setup, scene, controller = panda_in_clutter()
    assert controller.compiled and len(controller.pair_labels) == 7 * 10 + 16
    q, bound, rows, ties = setup.q0.copy(), 0, 0, 0
    for _ in range(200):
        result = controller.step(q, setup.target)
        G, h = controller.scene_rows.G.copy(), controller.scene_rows.h.copy()
        # the fused LP2 step equals lp2 on the problem the numpy layers build with its rows
        reference = lp2(controller.problem(q, setup.target))
        assert result.path == "compiled"
        np.testing.assert_allclose(result.q, reference.q, rtol=0, atol=1e-9)
        assert result.p == pytest.approx(reference.p, abs=1e-9)
        assert result.binding == reference.binding
        # and its rows equal coal's (ties aside)
        assert_found_matches_coal(controller, q)
        controller.problem(q, setup.target)  # coal's rows into the same block
        coal = controller.scene_rows
        ties += assert_rows_agree(controller, q, G, h, coal.G, coal.h)
        bound += (result.binding or "").startswith("collision")
        rows += int((h < 1e8).sum())
        q = result.q
    assert bound > 0 and rows > 200  # rows were written and they did stop the arm
    assert ties < 200  # link 6 runs parallel to the shelf's top for a while
    tool = setup.model.kinematics.fk(q)[:3, 3]
    assert np.linalg.norm(tool - SHELF_TARGET) < 1e-6
    assert min(p.distance for p in controller.avoidance.proximities.at(q)) >= scene.safety_distance


def test_rows_agree_at_random_configurations_some_in_collision() -> None:
    setup, scene, controller = panda_in_clutter()
    model, rng = setup.model, np.random.default_rng(5)
    close = 0
    for _ in range(60):
        q = rng.uniform(model.q_min, model.q_max)
        _, G, h, G_coal, h_coal, _ = compiled_rows(controller, q, setup.target)
        assert_found_matches_coal(controller, q)
        assert assert_rows_agree(controller, q, G, h, G_coal, h_coal) == 0
        close += min(p.distance for p in controller.avoidance.proximities.at(q)) < 0
    assert close > 5  # overlapping pairs (self-collision, the table) were among them


def test_step_into_and_the_coal_path_take_the_same_steps() -> None:
    setup, scene, controller = panda_in_clutter()
    through_coal = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt,
                                         compiled_distances=False)  # fmt: skip
    assert not through_coal.compiled
    q, out = setup.q0.copy(), np.zeros(7)
    for _ in range(60):
        p = controller.step_into(q, setup.target, out=out)
        reference = through_coal.step(q, setup.target)
        np.testing.assert_allclose(out, reference.q, rtol=0, atol=1e-9)
        assert p == pytest.approx(reference.p, abs=1e-9)
        if controller.last_binding != reference.binding:  # a tie, as above
            problem = through_coal.problem(q, setup.target)
            assert active(problem, out, controller.last_binding)
            assert active(problem, out, reference.binding)
        q = out.copy()
    with pytest.raises(ValueError, match="^q0"):
        controller.step([0.0, np.nan, 0, 0, 0, 0, 0], setup.target)
