"""The motion-quality scenario that starts inside an obstacle, and mink among obstacles.

A 3 cm sphere is placed at link 4 of the Panda at the home configuration:
once overlapping it (a reported case: the sphere at (-0.03, 0.02, 0.70),
31.5 mm into the link's capsule), once moved out along the pair's normal to
15.8 mm, inside the safety distance ``d_s`` of 20 mm. From there the target is
one pose, held: the tool at (0.55, 0, 0.487) m with the home orientation.
Every library with obstacle support runs among the same sphere: lpik's
variants with ``scene=`` (the velocity damper's rows, the default avoidance),
mink with its ``CollisionAvoidanceLimit`` over the same capsules
(:func:`lpik_bench.collision_peer`'s model) and the same ``d_s`` and ``d_i``,
its gain the share of ``d - d_s`` lpik's rows allow per step. The others have
no obstacles in their adapters: n/a.

The clearance of a run (:func:`clearance`) is measured with lpik's coal
distances between the robot's capsules and the sphere.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from lpik.robots.tasks import PoseTask
from lpik.types import FloatArray

#: The sphere's radius [m], its overlapping centre [m], the distance [m] of the second
#: start (inside ``d_s``), ``d_s`` and ``d_i`` [m], the held target point [m], a leg [s].
OBSTACLE = {"radius": 0.03, "overlapping": (-0.03, 0.02, 0.70), "inside": 0.0158,
            "safety": 0.02, "influence": 0.15, "target": (0.55, 0.0, 0.487),
            "duration": 2.5}  # fmt: skip
#: The obstacle's name in the scene (and in ``binding``).
BALL = "ball"


def sphere_scene(center: FloatArray) -> Any:
    """The scene: the sphere at ``center`` with :data:`OBSTACLE`'s ``d_s`` and ``d_i``."""
    from lpik.collision.shapes import Obstacle, Scene

    ball = Obstacle(BALL, "sphere", center=np.asarray(center, dtype=float),
                    radius=OBSTACLE["radius"])  # fmt: skip
    return Scene((ball,), OBSTACLE["safety"], OBSTACLE["influence"])


def ball_distances(model: PoseTask, scene: Any, q0: FloatArray) -> Callable[[FloatArray], float]:
    """``distance(q)``: the smallest signed distance [m] of a robot capsule to the sphere."""
    from lpik.collision import collision_avoidance

    proximities = collision_avoidance(model, scene, q0).proximities

    def distance(q: FloatArray) -> float:
        return min(p.distance for p in proximities.at(q) if p.other == BALL)

    return distance


def closest(model: PoseTask, q0: FloatArray, center: FloatArray) -> Any:
    """The capsule-sphere proximity with the smallest distance at ``q0``."""
    from lpik.collision import collision_avoidance

    found = collision_avoidance(model, sphere_scene(center), q0).proximities.at(q0)
    return min((p for p in found if p.other == BALL), key=lambda p: p.distance)


def has_scene(legs: tuple[Any, ...]) -> bool:
    """Whether the legs run among obstacles."""
    return any(leg.scene is not None for leg in legs)


def mink_among(scene: Any, q0: FloatArray) -> Callable[[FloatArray, FloatArray], FloatArray]:
    """mink's step ``step(q, target) -> dq`` among ``scene``'s obstacles (module docstring)."""
    import mink

    from lpik.collision import collision_avoidance
    from lpik.robots.registry import load_robot
    from lpik_bench.collision_peer import TIP, _mink_model
    from lpik_bench.workload import DT

    model = load_robot("panda", task="pose")
    avoid = collision_avoidance(model, scene, q0)
    mmodel, moving, obstacles, self_pairs = _mink_model(avoid)
    order = [int(mmodel.joint(j).qposadr[0]) for j in model.joint_names]
    configuration = mink.Configuration(mmodel, np.zeros(mmodel.nq))
    task = mink.FrameTask(TIP, "body", position_cost=1.0, orientation_cost=1.0)
    velocities = dict(zip(model.joint_names, (float(v) for v in model.qd_max)))
    pairs = [([g], obstacles) for g in moving] + [([a], [b]) for a, b in self_pairs]
    share = min(1.0, avoid.approach_speed * DT / (scene.influence_distance - scene.safety_distance))
    limits = [
        mink.ConfigurationLimit(mmodel, gain=1.0),
        mink.VelocityLimit(mmodel, velocities),
        mink.CollisionAvoidanceLimit(
            mmodel, geom_pairs=pairs, gain=share,
            minimum_distance_from_collisions=scene.safety_distance,
            collision_detection_distance=scene.influence_distance,
        ),
    ]  # fmt: skip
    full = np.zeros(mmodel.nq)

    def step(q: FloatArray, target: FloatArray) -> FloatArray:
        full[order] = q
        configuration.update(full)
        task.set_target(mink.SE3.from_matrix(target))
        v = mink.solve_ik(configuration, [task], DT, solver="daqp", limits=limits)
        return v[order] * DT

    return step
