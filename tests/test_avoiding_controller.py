"""The compiled controller with distance rows written in per step, against the numpy path."""

from __future__ import annotations

import numpy as np
import pytest

from lpik.collision import collision_avoidance, load_scene
from lpik.control.avoiding_controller import AvoidingLp2Controller
from lpik.methods.lp2 import lp2
from lpik.paper.collision_runs import SHELF_TARGET, shelf_scene_path
from lpik.paper.reach import reach_setup
from lpik.paper.scenarios import get_scenario


def active(problem, q, label) -> bool:  # type: ignore[no-untyped-def]
    """Whether the row called ``label`` holds with equality at ``q`` (a tie is named either way)."""
    k = list(problem.row_labels).index(label)
    return abs(problem.G[k] @ q - problem.h[k]) <= 1e-9 * max(1.0, abs(problem.h[k]))


@pytest.mark.parametrize(
    ("mechanism", "method"), [("rows", "lp2"), ("both", "lp2"), ("rows", "lp2s")]
)
def test_the_compiled_steps_follow_the_numpy_run_of_the_obstacle_scenario(
    mechanism, method
) -> None:  # type: ignore[no-untyped-def]
    setup = get_scenario("obstacle").setup()
    avoid = collision_avoidance(setup.model, setup.scene, setup.q0, mechanism=mechanism)
    log = setup.run(method, scene=avoid)
    controller = AvoidingLp2Controller(setup.model, avoid, dt=setup.dt, saturate=method == "lp2s")
    q, q_prev = setup.q0.copy(), None
    for k in range(setup.steps):
        np.testing.assert_allclose(q, log.q[k], atol=1e-9)
        result = controller.step(q, setup.target, q_prev)  # as the loop steps: q_prev too
        assert result.path == "compiled" and result.p == pytest.approx(log.p[k], abs=1e-9)
        if result.binding != log.binding[k]:  # two rows that tie (a shared joint)
            problem = controller.problem(q, setup.target, q_prev)
            assert active(problem, result.q, result.binding)
            assert active(problem, result.q, str(log.binding[k]))
        q_prev, q = q, result.q
    np.testing.assert_allclose(q, log.q_end, atol=1e-9)


def test_the_panda_in_its_shelf_matches_lp2_step_by_step() -> None:
    setup = reach_setup("panda", SHELF_TARGET)
    scene = load_scene(shelf_scene_path())
    controller = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt)
    q, bound = setup.q0.copy(), 0
    for _ in range(120):
        problem = controller.problem(q, setup.target)
        reference = lp2(problem)
        result = controller.step(q, setup.target)
        np.testing.assert_allclose(result.q, reference.q, atol=1e-9)
        assert result.p == pytest.approx(reference.p, abs=1e-9)
        if result.binding != reference.binding:  # two rows that tie (links sharing a joint)
            assert active(problem, result.q, result.binding)
            assert active(problem, result.q, reference.binding)
        bound += (result.binding or "").startswith("collision")
        q = result.q
    assert bound > 0  # the shelf's rows did stop the command on some steps
    found = controller.avoidance.proximities.at(q)
    assert min(p.distance for p in found) >= scene.safety_distance - 1e-3


def test_the_rows_are_the_scenes() -> None:
    setup = get_scenario("obstacle").setup()
    with pytest.raises(ValueError, match="^G: the rows of a controller with a scene"):
        AvoidingLp2Controller(setup.model, setup.scene, dt=0.01, G=np.zeros((1, 4)))
    with pytest.raises(ValueError, match="^scene: expected a Scene"):
        AvoidingLp2Controller(setup.model, None, dt=0.01)
    controller = AvoidingLp2Controller(setup.model, setup.scene, dt=0.01)
    with pytest.raises(ValueError, match="^q0:"):
        controller.step([0.0, np.nan, 0.0, 0.0], setup.target)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled distances", "coal"])
def test_the_automatic_bound_is_applied_inside_the_avoiding_step(compiled: bool) -> None:
    """At and near the Panda's singular configurations in its shelf: the default bound, in the
    fused step, equals the numpy rule on the unbounded step and the step under that bound."""
    pytest.importorskip("numba")
    from lpik.command import task_rows
    from lpik.limits import MultiplierBounds
    from lpik.methods.autobound import bound_for_step
    from lpik_bench.singular import singular_workload

    work = singular_workload(bases=1, seed=4)
    scene, home = load_scene(shelf_scene_path()), reach_setup("panda", SHELF_TARGET).q0
    model = work.model

    def make(**options):  # type: ignore[no-untyped-def]
        return AvoidingLp2Controller(model, scene, home, dt=1e-3, compiled_distances=compiled,
                                     on_stall=None, **options)  # the method's step  # fmt: skip

    controller, free_twin = make(), make(lambda_bound=None)
    auto = controller.automatic_bound
    bounded = 0
    for q, prev, target in zip(work.q, work.q_prev, work.targets):
        got, free = controller.step(q, target, prev), free_twin.step(q, target, prev)
        bound = bound_for_step(auto, model.jacobian, q, model.jacobian(q), task_rows(model), 1e-3,
                               free)  # fmt: skip
        ref = free if bound is None else make(
            lambda_bound=MultiplierBounds(-bound, bound)).step(q, target, prev)  # fmt: skip
        assert (got.status, got.binding, got.path) == (ref.status, ref.binding, ref.path)
        assert got.path in ("compiled", "recovery")  # recovery: from inside the safety distance
        assert abs(got.p - ref.p) <= 1e-12
        np.testing.assert_allclose(got.q, ref.q, atol=1e-12, rtol=0)
        bounded += bound is not None
    assert bounded > 0


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_without_a_home_no_step_recovers_from_capsules_that_touch_by_design(engine) -> None:
    """The Panda's capsules round joints 2, 4-5 and 6-7 overlap at every configuration; a
    controller given a scene and no ``home`` drops those pairs (lpik.collision.robot_bodies),
    so a free step from home is ``optimal`` (it was ``recovering`` from panda_link0 -
    panda_link2, 12 cm deep, on every step)."""
    from lpik.control.controller import Lp2Controller
    from lpik.control.stepper import Stepper
    from lpik.robots.registry import home_configuration, load_robot

    panda = load_robot("panda")
    q = home_configuration("panda")
    scene = load_scene("panda-shelf")
    if engine == "compiled":
        controller = Lp2Controller(panda, dt=1e-3, scene=scene)
    else:
        controller = Stepper(panda, dt=1e-3, scene=scene)
    watched = {p.label for p in controller.avoidance.proximities.at(q)}
    assert "collision panda_link0 - panda_link2" not in watched
    assert "collision panda_link0 - panda_link4" in watched  # apart at home: still watched
    target = panda.pose(q)
    target[:3, 3] += [0.0, 0.0, 0.001]
    result = controller.step(q, target, q)
    assert result.status == "optimal" and result.p == 1.0
