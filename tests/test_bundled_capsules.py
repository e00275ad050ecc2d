"""The bundled arms' capsules: collision-free at home, a sensible self-collision filter."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("coal")

from lpik.collision import default_capsules, robot_bodies, scene_from_dict  # noqa: E402
from lpik.collision.bodies import candidate_self_pairs  # noqa: E402
from lpik.collision.distance import signed_distance  # noqa: E402
from lpik.collision.shapes import capsule_geometry  # noqa: E402
from lpik.robots.registry import home_configuration, load_robot  # noqa: E402

ROBOTS = ("panda", "ur5e", "iiwa14")
D_S = 0.02


def self_distances(name: str, q: np.ndarray) -> dict:  # type: ignore[type-arg]
    """Every candidate self-collision pair's signed distance at ``q``."""
    chain = load_robot(name).kinematics
    capsules = default_capsules(chain)
    ends_a, ends_b, _ = robot_bodies(chain, capsules, None, self_collision=False).world_capsules(q)
    placed = [capsule_geometry(ends_a[i], ends_b[i], c.radius) for i, c in enumerate(capsules)]
    return {
        (i, j): signed_distance(placed[i], placed[j])[0] for i, j in candidate_self_pairs(capsules)
    }


@pytest.mark.parametrize("name", ROBOTS)
def test_home_is_collision_free_and_few_pairs_are_filtered(name) -> None:  # type: ignore[no-untyped-def]
    chain = load_robot(name).kinematics
    home = home_configuration(name)
    capsules = default_capsules(chain)
    assert all(c.radius > 0 and c.joint >= -1 for c in capsules)
    found = self_distances(name, home)
    kept = robot_bodies(chain, capsules, home, touching=D_S).self_pairs
    # only pairs that touch at home by design are dropped, and they are few
    assert set(found) - set(kept) == {pair for pair, d in found.items() if d <= D_S}
    assert len(kept) >= 0.75 * len(found)
    # pairs three or more joints apart do not touch at home, but for the Panda's wrist
    # (link 4 against link 7, which franka_ros leaves unchecked too)
    apart = [d for (i, j), d in found.items() if capsules[j].joint - capsules[i].joint >= 3]
    assert name == "panda" or min(apart) > 0
    # no moving capsule reaches below the floor at home
    ends_a, ends_b, _ = robot_bodies(chain, capsules, None).world_capsules(home)
    low = [min(a[2], b[2]) - c.radius for a, b, c in zip(ends_a, ends_b, capsules)]
    assert min(z for z, c in zip(low, capsules) if c.joint >= 0) > 0


@pytest.mark.parametrize("name", ROBOTS)
def test_the_kept_pairs_catch_the_arm_folding_onto_itself(name) -> None:  # type: ignore[no-untyped-def]
    chain = load_robot(name).kinematics
    capsules = default_capsules(chain)
    kept = set(robot_bodies(chain, capsules, home_configuration(name), touching=D_S).self_pairs)
    rng = np.random.default_rng(3)
    caught = 0
    for _ in range(300):
        found = self_distances(name, rng.uniform(chain.q_min, chain.q_max))
        caught += any(d < 0 for pair, d in found.items() if pair in kept)
    # some random configurations fold links into each other (seed 3: 4 of the Panda's,
    # 56 of the UR5e's, 2 of the iiwa14's 300): the filter keeps the pairs that do
    assert caught >= 1


def test_the_ur5e_upper_arm_runs_off_the_line_of_its_joints() -> None:
    """Menagerie's upper-arm tube is 0.138 m from the segment between the shoulder-lift
    and elbow origins, along their axes; a link-frame capsule would miss it."""
    chain = load_robot("ur5e").kinematics
    q = home_configuration("ur5e")
    frames = chain.joint_frames(q)
    tube = next(
        c for c in default_capsules(chain) if c.link == "upper_arm_link" and c.radius == 0.05
    )
    a = frames[1][:3, :3] @ tube.a + frames[1][:3, 3]
    shoulder, elbow = frames[1][:3, 3], frames[2][:3, 3]
    axis = (elbow - shoulder) / np.linalg.norm(elbow - shoulder)
    off = (a - shoulder) - ((a - shoulder) @ axis) * axis
    assert np.linalg.norm(off) == pytest.approx(0.138, abs=1e-3)


def test_links_with_two_capsules_get_one_row_each_in_the_compiled_step() -> None:
    pytest.importorskip("numba")
    from lpik.control.avoiding_controller import AvoidingLp2Controller
    from lpik.paper.reach import reach_setup

    setup = reach_setup("ur5e", (0.3, 0.35, 0.25))
    scene = scene_from_dict(
        {
            "obstacles": [
                {"name": "post", "type": "capsule", "a": [0.25, 0.15, 0.0], "b": [0.25, 0.15, 0.8],
                 "radius": 0.04},
            ],
            "safety_distance": D_S,
            "influence_distance": 0.15,
        }
    )  # fmt: skip
    compiled = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt, on_stall=None)
    through_coal = AvoidingLp2Controller(setup.model, scene, setup.q0, dt=setup.dt,
                                         compiled_distances=False, on_stall=None)  # fmt: skip
    labels = compiled.pair_labels
    assert labels.count("collision upper_arm_link - post") == 2
    q, q_coal, bound = setup.q0.copy(), setup.q0.copy(), set()
    for _ in range(150):
        result = compiled.step(q, setup.target)
        q, q_coal = result.q, through_coal.step(q_coal, setup.target).q
        np.testing.assert_allclose(q, q_coal, rtol=0, atol=1e-9)
        bound.add(str(result.binding))
    assert any(label.startswith("collision") for label in bound)
    assert compiled.avoidance.closest(q)[0] >= D_S - 1e-6
