"""The Panda reaching over a table into a shelf: lpik's distance rows against mink's.

    python -m lpik_bench.collision_peer [--steps N] [--json]

The same run for every variant: from the Panda's home configuration the tool
point moves straight to ``SHELF_TARGET`` at ``v_max`` with its orientation
held (``lpik simulate reach``), each step commanding the clamped pose
(:mod:`lpik.command`), among the obstacles of
``lpik/data/scenes/panda-shelf.json`` and with self-collision between
non-neighbouring links. The robot's bodies are the same capsules in every
variant (:func:`lpik.collision.default_capsules`), added to mink's MuJoCo model
as capsule geoms, and the scene's boxes and plane as world geoms.

* ``lpik lp2 with the rows``: the loop of ``simulate`` with LP2 and the velocity
  damper's rows (:class:`lpik.collision.DistanceRows`), timed whole;
* ``lpik compiled``: :class:`~lpik.control.avoiding_controller.AvoidingLp2Controller`;
* ``mink``: ``solve_ik`` (daqp) with a ``FrameTask``, ``ConfigurationLimit``
  (gain 1), ``VelocityLimit`` and ``CollisionAvoidanceLimit`` over the same
  pairs, its ``minimum_distance_from_collisions`` = ``d_s``, its
  ``collision_detection_distance`` = ``d_i``, and its gain either the share of
  ``d - d_s`` lpik's rows allow per step (``xi dt / (d_i - d_s)``) or mink's
  default 0.85.

Every run is measured the same way, with lpik's coal distances on its joint
path: the smallest signed distance reached (self-collision included), the tool's
distance to the target at the end, and the median wall time of a step.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from lpik.collision import collision_avoidance, load_scene
from lpik.control.avoiding_controller import AvoidingLp2Controller
from lpik.limits import build_problem
from lpik.methods.lp2 import lp2
from lpik.paper.collision_runs import SHELF_TARGET, shelf_scene_path
from lpik.paper.reach import reach_setup
from lpik.robots.rotations import transform
from lpik_bench.workload import arm_only_urdf

ROBOT = "panda"
TIP = "panda_hand_tcp"


def _mink_model(avoid: Any) -> tuple[Any, list[int], list[int], list[tuple[int, int]]]:
    """mink's MuJoCo model with the capsules and obstacles; robot and obstacle geom ids."""
    import mujoco

    from lpik.robots.mujoco_adapter import kinematic_urdf

    spec = mujoco.MjSpec.from_string(kinematic_urdf(arm_only_urdf(ROBOT)))
    bodies = avoid.proximities.bodies
    robot_names = []
    for k, capsule in enumerate(bodies.capsules):
        body = spec.body(capsule.link)
        name = f"capsule {k} {capsule.link}"
        if np.linalg.norm(capsule.b - capsule.a) < 1e-9:  # a capsule of length 0: a sphere
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                          size=[capsule.radius, 0, 0], pos=capsule.a)  # fmt: skip
        else:
            geom = body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                                 size=[capsule.radius, 0, 0])  # fmt: skip
            geom.fromto = np.concatenate([capsule.a, capsule.b])
        robot_names.append(name)
    obstacle_names = []
    for o in avoid.scene.obstacles:
        if o.kind == "box":
            pose = transform(o.center, o.rpy)
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, pose[:3, :3].ravel())
            spec.worldbody.add_geom(name=o.name, type=mujoco.mjtGeom.mjGEOM_BOX,
                                    size=o.size / 2, pos=o.center, quat=quat)  # fmt: skip
        elif o.kind == "plane":
            quat = np.zeros(4)
            mujoco.mju_quatZ2Vec(quat, o.normal)
            spec.worldbody.add_geom(name=o.name, type=mujoco.mjtGeom.mjGEOM_PLANE,
                                    size=[5, 5, 0.01], pos=o.center, quat=quat)  # fmt: skip
        elif o.kind == "sphere":
            spec.worldbody.add_geom(name=o.name, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                                    size=[o.radius, 0, 0], pos=o.center)  # fmt: skip
        else:
            raise ValueError(f"obstacle {o.name!r}: capsules are not added to mink's model")
        obstacle_names.append(o.name)
    model = spec.compile()
    robot = [model.geom(n).id for n in robot_names]
    obstacles = [model.geom(n).id for n in obstacle_names]
    moving = [g for g, c in zip(robot, bodies.capsules) if c.joint >= 0]
    self_pairs = [(robot[i], robot[j]) for i, j in bodies.self_pairs]
    return model, moving, obstacles, self_pairs


def mink_run(setup: Any, avoid: Any, steps: int, gain: float) -> tuple[np.ndarray, list[float]]:
    """The run with mink; the joint path (steps + 1, n) and each step's wall time [s]."""
    import mink

    model, moving, obstacles, self_pairs = _mink_model(avoid)
    names = setup.model.joint_names
    order = [int(model.joint(j).qposadr[0]) for j in names]
    configuration = mink.Configuration(model, np.zeros(model.nq))
    task = mink.FrameTask(TIP, "body", position_cost=1.0, orientation_cost=1.0)
    velocities = dict(zip(names, (float(v) for v in setup.model.qd_max)))
    pairs = [([g], obstacles) for g in moving] + [([a], [b]) for a, b in self_pairs]
    limits = [
        mink.ConfigurationLimit(model, gain=1.0),
        mink.VelocityLimit(model, velocities),
        mink.CollisionAvoidanceLimit(
            model, geom_pairs=pairs, gain=gain,
            minimum_distance_from_collisions=avoid.scene.safety_distance,
            collision_detection_distance=avoid.scene.influence_distance,
        ),
    ]  # fmt: skip
    command = setup.command()
    q, path, times = setup.q0.copy(), [setup.q0.copy()], []
    full = np.zeros(model.nq)
    for _ in range(steps):
        start = time.perf_counter()
        dw = command(setup.model, q, setup.dt)
        pose = setup.model.pose(q)
        target = pose.copy()
        target[:3, 3] += dw[:3]
        target[:3, :3] = _rotated(pose[:3, :3], dw[3:])
        full[order] = q
        configuration.update(full)
        task.set_target(mink.SE3.from_matrix(target))
        v = mink.solve_ik(configuration, [task], setup.dt, solver="daqp", limits=limits)
        q = q + v[order] * setup.dt
        times.append(time.perf_counter() - start)
        path.append(q.copy())
    return np.array(path), times


def _rotated(rotation: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``rotation`` turned by the rotation vector ``angle`` (world axes) [rad]."""
    theta = float(np.linalg.norm(angle))
    if theta < 1e-15:
        return rotation
    k = angle / theta
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return (np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K) @ rotation


def measure(name: str, path: np.ndarray, times: list[float], setup: Any, avoid: Any) -> dict:
    """Smallest distance on the joint path, tool error at the end, median step time."""
    found = [min(p.distance for p in avoid.proximities.at(q)) for q in path]
    end = setup.model.kinematics.fk(path[-1])[:3, 3]
    return {
        "variant": name,
        "smallest_distance_m": float(min(found)),
        "final_tool_error_m": float(np.linalg.norm(end - np.asarray(SHELF_TARGET))),
        "median_step_us": float(np.median(times) * 1e6),
    }


def run(steps: int) -> list[dict]:
    """Every variant of the benchmark."""
    setup = reach_setup(ROBOT, SHELF_TARGET)
    scene = load_scene(shelf_scene_path())
    avoid = collision_avoidance(setup.model, scene, setup.q0)
    rows = []
    limits = [*setup.limits(), *avoid.limits()]
    command = setup.command()
    q, path, times = setup.q0.copy(), [setup.q0.copy()], []
    for _ in range(steps):  # the loop of lpik.control.simulate, timed whole
        start = time.perf_counter()
        J = setup.model.jacobian(q)
        dw = command(setup.model, q, setup.dt)
        problem = build_problem(J, dw, q, limits, dt=setup.dt, **setup.weights,
                                joint_names=setup.model.joint_names)  # fmt: skip
        q = lp2(problem).q
        times.append(time.perf_counter() - start)
        path.append(q.copy())
    rows.append(measure("lpik lp2 with the rows (numpy)", np.array(path), times, setup, avoid))
    controller = AvoidingLp2Controller(setup.model, avoid, dt=setup.dt)
    q, path_c, times = setup.q0.copy(), [setup.q0.copy()], []
    for _ in range(steps):
        start = time.perf_counter()
        q = controller.step(q, setup.target).q
        times.append(time.perf_counter() - start)
        path_c.append(q.copy())
    rows.append(measure("lpik AvoidingLp2Controller", np.array(path_c), times, setup, avoid))
    share = min(1.0, avoid.approach_speed * setup.dt
                / (scene.influence_distance - scene.safety_distance))  # fmt: skip
    for gain, label in ((share, f"mink, gain {share:.3g} (lpik's share)"),
                        (0.85, "mink, gain 0.85 (its default)")):  # fmt: skip
        path_m, times_m = mink_run(setup, avoid, steps, gain)
        rows.append(measure(label, path_m, times_m, setup, avoid))
    return rows


def main(argv: list[str] | None = None) -> int:
    """Print the table (markdown) or JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    rows = run(args.steps)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print("| variant | smallest distance [m] | tool error at the end [m] | median step [us] |")
    print("|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r['variant']} | {r['smallest_distance_m']:.4f} | "
              f"{r['final_tool_error_m']:.2e} | {r['median_step_us']:.0f} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
