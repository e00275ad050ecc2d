"""Scenes, capsules and the distances by coal, against closed forms and finite differences."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from tests.collision_cases import Q0, arm, circle_scene

from lpik.collision import (
    Proximities,
    collision_avoidance,
    frame_capsules,
    load_scene,
    robot_bodies,
    scene_from_dict,
    signed_distance,
    urdf_capsules,
)
from lpik.collision.bodies import RobotBodies, candidate_self_pairs
from lpik.collision.distance import design_samples
from lpik.collision.shapes import Obstacle, capsule_geometry
from lpik.robots.registry import home_configuration, load_robot
from lpik.robots.rotations import transform
from lpik.robots.urdf import load_urdf, parse_urdf

RNG = np.random.default_rng(13)


def point_segment(p, a, b):  # type: ignore[no-untyped-def]
    t = np.clip((p - a) @ (b - a) / max((b - a) @ (b - a), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t * (b - a)))


def point_box(p, center, size, R):  # type: ignore[no-untyped-def]
    local = R.T @ (p - center)
    half = size / 2
    outside = np.maximum(np.abs(local) - half, 0.0)
    if outside.any():
        return np.linalg.norm(outside)
    return -np.min(half - np.abs(local))


def sphere(center, radius):  # type: ignore[no-untyped-def]
    return Obstacle("s", "sphere", 3, center=np.asarray(center), radius=radius).geometry()


@pytest.mark.parametrize("trial", range(300))
def test_coal_distances_equal_the_closed_forms_penetrating_ones_included(trial: int) -> None:
    c, r = RNG.uniform(-1, 1, 3), RNG.uniform(0.05, 0.5)
    a, b, rc = RNG.uniform(-1, 1, 3), RNG.uniform(-1, 1, 3), RNG.uniform(0.05, 0.3)
    # sphere - capsule (the robot's body is the capsule): the segment's distance less radii
    d, p1, p2, n = signed_distance(capsule_geometry(a, b, rc), sphere(c, r))
    assert d == pytest.approx(point_segment(c, a, b) - r - rc, abs=1e-9)
    if abs(d) > 1e-6:
        assert np.linalg.norm(n) == pytest.approx(1.0)
        # moving the capsule against the normal separates the two
        d2 = signed_distance(capsule_geometry(a - 1e-6 * n, b - 1e-6 * n, rc), sphere(c, r))[0]
        assert d2 > d
    # sphere - half-space (plane through `a` with outward normal `b`)
    plane = Obstacle("p", "plane", 3, center=a, normal=b / np.linalg.norm(b)).geometry()
    d = signed_distance(sphere(c, r), plane)[0]
    assert d == pytest.approx((c - a) @ b / np.linalg.norm(b) - r, abs=1e-9)
    # sphere - box
    size, rpy = RNG.uniform(0.1, 1.0, 3), RNG.uniform(-np.pi, np.pi, 3)
    box = Obstacle("b", "box", 3, center=a, size=size, rpy=rpy).geometry()
    d = signed_distance(sphere(c, r), box)[0]
    expected = point_box(c, a, size, transform(a, rpy)[:3, :3]) - r
    assert d == pytest.approx(expected, abs=1e-6)


def test_two_d_shapes_give_the_distances_in_the_plane() -> None:
    scene = scene_from_dict(
        {
            "obstacles": [
                {"name": "wall", "type": "box", "center": [2, 0], "size": [0.5, 1], "angle": 0.3},
                {"name": "edge", "type": "plane", "point": [0, -1], "normal": [0, 1]},
                {"name": "rod", "type": "capsule", "a": [0, 2], "b": [1, 2], "radius": 0.1},
            ],
            "safety_distance": 0.0,
            "influence_distance": 0.5,
        }
    )
    assert scene.dims == 2
    wall, edge, rod = (o.geometry() for o in scene.obstacles)
    for p in RNG.uniform(-3, 3, (50, 2)):
        ball = sphere([*p, 0.0], 0.01)
        R = transform((0, 0, 0), (0, 0, 0.3))[:3, :3]
        expected = point_box(np.append(p, 0), np.array([2, 0, 0.0]), np.array([0.5, 1, 99]), R)
        assert signed_distance(ball, wall)[0] == pytest.approx(expected - 0.01, abs=1e-6)
        assert signed_distance(ball, edge)[0] == pytest.approx(p[1] + 1 - 0.01, abs=1e-9)
        seg = point_segment(np.append(p, 0), np.array([0, 2, 0.0]), np.array([1, 2, 0.0]))
        assert signed_distance(ball, rod)[0] == pytest.approx(seg - 0.11, abs=1e-9)


def finite_difference(prox: Proximities, q: np.ndarray, label: str, eps: float = 1e-6):  # type: ignore[no-untyped-def]
    def distance(x: np.ndarray) -> float:
        return next(p.distance for p in prox.at(x) if p.label == label)

    grad = np.zeros(q.size)
    for k in range(q.size):
        e = np.zeros(q.size)
        e[k] = eps
        grad[k] = (distance(q + e) - distance(q - e)) / (2 * eps)
    return grad


@pytest.mark.parametrize("robot", ["planar", "panda"])
def test_the_distance_gradient_is_a_finite_difference_of_the_distance(robot: str) -> None:
    if robot == "planar":
        model, q = arm(), Q0
        scene = circle_scene((1.3, 1.6), 0.2)  # overlaps link 3 at q
    else:
        model, q = load_robot("panda", task="position"), home_configuration("panda")
        scene = scene_from_dict(
            {
                "obstacles": [
                    {"name": "shelf", "type": "box", "center": [0.5, 0, 0.3],
                     "size": [0.2, 0.6, 0.02]},
                    {"name": "post", "type": "capsule", "a": [0.3, 0.3, 0], "b": [0.6, -0.2, 1],
                     "radius": 0.05},
                ],
                "safety_distance": 0.02,
                "influence_distance": 0.2,
            }
        )  # fmt: skip
    found = collision_avoidance(model, scene, q).proximities
    assert any(p.distance < 0 for p in found.at(q)) or robot == "panda"
    for p in found.at(q):
        assert np.abs(finite_difference(found, q, p.label) - p.gradient).max() < 1e-5, p.label


def test_panda_capsules_carry_franka_radii_and_self_pairs_skip_neighbours() -> None:
    panda = load_robot("panda")
    home = home_configuration("panda")
    empty = {"obstacles": [], "safety_distance": 0.01, "influence_distance": 0.1}
    avoid = collision_avoidance(panda, scene_from_dict(empty), home)
    bodies = avoid.proximities.bodies
    radii = {c.link: c.radius for c in bodies.capsules}
    assert radii["panda_link0"] == 0.06 and radii["panda_link7"] == 0.04
    for i, j in bodies.self_pairs:
        assert abs(bodies.capsules[i].joint - bodies.capsules[j].joint) >= 2
    assert min(p.distance for p in avoid.proximities.at(home)) > 0.01


def test_urdf_collision_cylinders_and_spheres_become_capsules() -> None:
    urdf = """<robot name="two">
      <link name="base"/>
      <link name="arm"><collision><origin xyz="0 0 0.25"/>
        <geometry><cylinder radius="0.04" length="0.5"/></geometry></collision></link>
      <link name="hand"><collision><geometry><sphere radius="0.03"/></geometry></collision></link>
      <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
      <joint name="j2" type="revolute"><parent link="arm"/><child link="hand"/>
        <origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
        <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
    </robot>"""
    chain = load_urdf(urdf, tip_link="hand")
    capsules = urdf_capsules(chain, parse_urdf(urdf))
    assert [(c.link, c.joint, c.radius) for c in capsules] == [("arm", 0, 0.04), ("hand", 1, 0.03)]
    np.testing.assert_allclose(capsules[0].a, [0, 0, 0])
    np.testing.assert_allclose(capsules[0].b, [0, 0, 0.5])
    assert frame_capsules(chain, 0.02)[1].b.tolist() == [0.0, 0.0, 0.5]


def test_pairs_that_touch_at_home_are_not_checked() -> None:
    model = arm()
    capsules = frame_capsules(model, 0.3, base=False)
    folded = np.array([0.0, 2.6, 2.6, 0.0])  # links 1 and 3 overlap here, not everywhere
    with_home = robot_bodies(model, capsules, folded)
    without = robot_bodies(model, capsules, None)
    assert set(without.self_pairs) == set(candidate_self_pairs(capsules))
    assert set(with_home.self_pairs) < set(without.self_pairs)


def test_pairs_that_touch_everywhere_are_not_checked_even_without_a_home() -> None:
    """Fat links: capsules 1 and 3 (and 2 and 4) overlap round the joint between them at
    every configuration, so no step moves them apart; capsules 1 and 4 do not."""
    model = arm()
    capsules = frame_capsules(model, 0.6, base=False)
    kept = robot_bodies(model, capsules, None).self_pairs
    assert set(kept) == {(0, 3)}
    for i, j in set(candidate_self_pairs(capsules)) - set(kept):  # at every drawn configuration
        for q in design_samples(model):
            a, b, _ = RobotBodies(model.kinematics, tuple(capsules)).world_capsules(q)
            placed = [capsule_geometry(a[k], b[k], capsules[k].radius) for k in (i, j)]
            assert signed_distance(*placed)[0] <= 0.0


GOOD = {
    "obstacles": [{"name": "ball", "type": "sphere", "center": [1, 2, 3], "radius": 0.1}],
    "safety_distance": 0.02,
    "influence_distance": 0.2,
}


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"safety_distance": None}, "safety_distance"),
        ({"influence_distance": 0.01}, "influence_distance"),
        ({"extra": 1}, "extra"),
        ({"obstacles": [{"name": "b", "type": "cone"}]}, "obstacles[0].type"),
        ({"obstacles": [{"name": "b", "type": "sphere", "center": [1, 2, 3], "radius": -1}]},
         "obstacles[0].radius"),
        ({"obstacles": [{"name": "b", "type": "sphere", "center": [1, 2], "radius": 1},
                        {"name": "c", "type": "sphere", "center": [1, 2, 3], "radius": 1}]},
         "obstacles[1].center"),
        ({"obstacles": [{"name": "b", "type": "box", "center": [1, 2, 3], "size": [1, 0, 1]}]},
         "obstacles[0].size"),
        ({"obstacles": [{"name": "b", "type": "plane", "point": [0, 0, 0], "normal": [0, 0, 0]}]},
         "obstacles[0].normal"),
        ({"obstacles": [{"name": "b", "type": "sphere", "center": [1, float("nan"), 3],
                         "radius": 1}]}, "obstacles[0].center[1]"),
        ({"obstacles": [{"type": "sphere", "center": [1, 2, 3], "radius": 1}]},
         "obstacles[0].name"),
        ({"obstacles": [GOOD["obstacles"][0], GOOD["obstacles"][0]]}, "obstacles"),
    ],
)  # fmt: skip
def test_a_bad_scene_names_its_key(change: dict, key: str) -> None:
    data = {**GOOD, **change}
    data = {k: v for k, v in data.items() if v is not None}
    with pytest.raises(ValueError, match="^" + re.escape(key) + ":"):
        scene_from_dict(data)


def test_load_scene_reads_a_file_and_refuses_bad_json(tmp_path) -> None:  # type: ignore[no-untyped-def]
    good = tmp_path / "good.json"
    good.write_text(json.dumps(GOOD))
    assert load_scene(good).names == ("ball",)
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(ValueError, match="^scene: unreadable JSON"):
        load_scene(bad)
    with pytest.raises(ValueError, match="^scene: cannot read"):
        load_scene(tmp_path / "missing.json")


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"kind": "sphere", "center": [0, NAN, 0], "radius": 0.1}, "center[1]"),
        ({"kind": "sphere", "center": np.array([INF, 0, 0]), "radius": 0.1}, "center[0]"),
        ({"kind": "sphere", "center": [0, 0, 0], "radius": NAN}, "radius"),
        ({"kind": "sphere", "center": [0, 0, 0], "radius": -0.1}, "radius"),
        ({"kind": "sphere", "center": [0, 0, 0], "radius": 0.0}, "radius"),
        ({"kind": "sphere", "center": [0, 0], "radius": 0.1}, "center"),
        ({"kind": "sphere", "radius": 0.1}, "center"),
        ({"kind": "sphere", "center": [0, 0, 0], "radius": 0.1, "size": [1, 1, 1]}, "size"),
        ({"kind": "capsule", "a": [INF, 0, 0], "b": [0, 0, 1], "radius": 0.1}, "a[0]"),
        ({"kind": "capsule", "a": [0, 0, 0], "b": [0, 0, 1], "radius": INF}, "radius"),
        ({"kind": "box", "center": [0, 0, 0], "size": [1, 0, 1]}, "size"),
        ({"kind": "box", "center": [0, 0, 0], "size": [1, -2, 1]}, "size"),
        ({"kind": "box", "center": [0, 0, 0], "size": [1, NAN, 1]}, "size[1]"),
        ({"kind": "box", "center": [0, 0, 0], "size": [1, 1, 1], "rpy": [0, INF, 0]}, "rpy[1]"),
        ({"kind": "box", "center": [0, 0, 0], "size": [1, 1, 1], "radius": 0.2}, "radius"),
        ({"kind": "box", "dims": 2, "center": [0, 0], "size": [1, 1], "rpy": [0.3, 0, 0]}, "rpy"),
        ({"kind": "plane", "center": [0, 0, 0], "normal": [0, 0, 0]}, "normal"),
        ({"kind": "plane", "center": [0, 0, 0], "normal": [0, 0, NAN]}, "normal[2]"),
        ({"kind": "plane", "center": [0, 0, NAN], "normal": [0, 0, 1]}, "center[2]"),
        ({"kind": "cone", "center": [0, 0, 0], "radius": 0.1}, "kind"),
        ({"kind": "sphere", "dims": 4, "center": [0, 0, 0, 0], "radius": 0.1}, "dims"),
        ({"kind": "sphere", "name": " ", "center": [0, 0, 0], "radius": 0.1}, "name"),
        ({"kind": "sphere", "center": [0, "1", 0], "radius": 0.1}, "center[1]"),
        ({"kind": "sphere", "center": [0, 0, 0], "radius": True}, "radius"),
    ],
)  # fmt: skip
def test_an_obstacle_built_in_python_is_checked_at_construction(kwargs: dict, field: str) -> None:
    kwargs = {"name": "o", **kwargs}
    with pytest.raises(ValueError, match="^" + re.escape(field) + ":") as bad:
        Obstacle(**kwargs)
    if field not in ("name", "kind"):
        assert f"(obstacle 'o', a {kwargs['kind']})" in str(bad.value)


@pytest.mark.parametrize(
    ("item", "kwargs"),
    [
        ({"type": "sphere", "center": [0, 0, 0], "radius": -1},
         {"kind": "sphere", "center": [0, 0, 0], "radius": -1}),
        ({"type": "box", "center": [0, 0, 0], "size": [1, 0, 1]},
         {"kind": "box", "center": [0, 0, 0], "size": [1, 0, 1]}),
        ({"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 0]},
         {"kind": "plane", "center": [0, 0, 0], "normal": [0, 0, 0]}),
        ({"type": "sphere", "center": [0, 1e300, 0], "radius": 1},
         {"kind": "sphere", "center": [0, 1e300, 0], "radius": 1}),
        ({"type": "cone", "center": [0, 0, 0], "radius": 1},
         {"kind": "cone", "center": [0, 0, 0], "radius": 1}),
    ],
)  # fmt: skip
def test_json_and_python_refuse_a_bad_obstacle_by_the_same_rule(item: dict, kwargs: dict) -> None:
    with pytest.raises(ValueError) as from_json:
        scene_from_dict({**GOOD, "obstacles": [{"name": "o", **item}]})
    with pytest.raises(ValueError) as from_python:
        Obstacle("o", **kwargs)
    json_reason = from_json.value.reason  # type: ignore[attr-defined]
    assert from_python.value.reason.startswith(json_reason)  # type: ignore[attr-defined]


def test_a_scene_built_in_python_is_checked_too() -> None:
    from lpik.collision import Scene

    ball = Obstacle("ball", "sphere", center=[0.5, 0, 0.5], radius=0.1)
    flat = Obstacle("disc", "sphere", dims=2, center=[0.5, 0], radius=0.1)
    for args, field in (
        (((ball,), NAN, 0.2), "safety_distance"),
        (((ball,), 0.02, INF), "influence_distance"),
        (((ball,), 0.02, 0.01), "influence_distance"),
        (((flat,), 0.02, 0.2), "obstacles[0]"),
        ((("ball",), 0.02, 0.2), "obstacles[0]"),
        (((ball, ball), 0.02, 0.2), "obstacles"),
    ):
        with pytest.raises(ValueError, match="^" + re.escape(field) + ":"):
            Scene(*args)  # type: ignore[arg-type]
    scene = Scene([ball], 0.02, 0.2)  # type: ignore[arg-type]
    assert scene.obstacles == (ball,) and isinstance(ball.center, np.ndarray)


def test_a_plane_built_in_python_gets_a_unit_normal() -> None:
    plane = Obstacle("floor", "plane", center=(0, 0, 0), normal=(0, 0, 3))
    np.testing.assert_array_equal(plane.normal, [0.0, 0.0, 1.0])
    assert plane.placed()["offset"] == 0.0


def test_load_scene_takes_a_bundled_scene_by_name(tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    from lpik.collision.scene_json import bundled_scenes

    assert "panda-shelf" in bundled_scenes()
    names = load_scene("panda-shelf").names
    assert "shelf top" in names and load_scene("panda-shelf.json").names == names
    with pytest.raises(ValueError, match="^scene: no file 'kitchen'.*bundled scenes: panda-shelf"):
        load_scene("kitchen")
    monkeypatch.chdir(tmp_path)  # a file of that name in the working folder comes first
    (tmp_path / "panda-shelf").write_text(json.dumps(GOOD))
    assert load_scene("panda-shelf").names == ("ball",)
