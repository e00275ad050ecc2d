"""The motion-quality scenarios: commanded target trajectories and start configurations.

Every scenario is one or more *legs*; a leg is a start configuration (at
rest), one commanded target pose per control step and, per step, whether that
target is reachable with every joint within its end-stops (checked by
:func:`lpik_bench.quality_reach.reachable_mask`, not assumed). Every library
runs every leg from the same start on the same targets. The parameters of each
scenario are the constants below; :data:`SCENARIOS` holds the builders in the
order of the report, so a new scenario is one builder and one entry.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from lpik.robots.registry import home_configuration
from lpik.robots.tasks import PoseTask
from lpik.types import FloatArray
from lpik_bench.quality_reach import (
    blend,
    moved,
    reach_along,
    reachable_mask,
    smoothstep,
    unlimited_path,
)
from lpik_bench.workload import QDD_MAX

#: Circle: diameter [m], period [s], speed ramp [s], duration [s].
CIRCLE = {"diameter": 0.10, "period": 2.0, "ramp": 0.5, "duration": 4.0}
#: Out of reach: distance beyond reach [m], target speed out and back [m/s], hold and settle [s].
BEYOND = {"beyond": 0.5, "speed": 1.0, "hold": 0.3, "settle": 2.5}
#: End-stop: start this far inside the stop [rad], move [s], leg [s], candidates, goal spread [rad].
END_STOP = {"inside": 0.15, "move": 1.0, "duration": 2.5, "candidates": 40, "spread": 0.6}
#: Steps: jump [m], every [s], duration [s].
STEPS = {"jump": 0.05, "every": 0.05, "duration": 2.1}
#: Singular: swing of joint 4 below / above its singular angle [rad], period [s].
SINGULAR = {"below": 0.8, "above": 0.3, "period": 5.0}
#: Acceleration: reversal jump [m] and period [s], circle at full speed from rest, duration [s].
ACCEL = {"jump": 0.10, "every": 0.2, "duration": 2.0}
#: Point to point: the step along +x [m] and its leg [s]; moves to the poses of random
#: configurations (how many, spread about home [rad], least distance [m] and turn [rad]
#: of the pose, leg [s], seed of the draw).
POINT = {"step": 0.05, "step_duration": 1.0, "moves": 3, "spread": 0.6, "distance": 0.15,
         "turn": 0.3, "duration": 2.0, "seed": 7}  # fmt: skip
#: Goals anywhere: how many, seed of the draw (lpik_bench.random_goals), seconds per goal.
GOALS = {"goals": 10, "seed": 0, "duration": 5.0}

AXES = {
    "+x": (1, 0, 0),
    "-x": (-1, 0, 0),
    "+y": (0, 1, 0),
    "-y": (0, -1, 0),
    "+z": (0, 0, 1),
    "-z": (0, 0, -1),
}


@dataclass(frozen=True, eq=False)
class Leg:
    """One run from rest: start, targets and their reachability.

    Attributes:
        label: Short name (a direction, a joint).
        q0: Start configuration (n,) [rad], at rest.
        targets: Commanded poses, one per step, (N, 4, 4) [m].
        reachable: Per step, whether the target is reachable within the end-stops, (N,).
        settle_from: First step of the final hold the library must recover on (None: none).
        note: How the leg was built (found values).
        held: The target is one pose from the first step on (a point-to-point move):
            its settle time and overshoot are measured.
        scene: Obstacles the leg runs among (an lpik ``Scene``; None: none): only the
            libraries with obstacle support run it (:mod:`lpik_bench.quality_obstacle`).
    """

    label: str
    q0: FloatArray
    targets: FloatArray
    reachable: FloatArray
    settle_from: int | None = None
    note: str = ""
    held: bool = False
    scene: Any = None


@dataclass(frozen=True, eq=False)
class Scenario:
    """A named set of legs.

    Attributes:
        key: Short name. title: Heading. what: One paragraph for the report.
        legs: The legs.
        acceleration_checked: An acceleration-limited scenario: every library's
            accelerations are checked against ``qdd_max`` (otherwise only the
            variants that claim acceleration limits), and the peers that take
            acceleration limits run with them.
    """

    key: str
    title: str
    what: str
    legs: tuple[Leg, ...]
    acceleration_checked: bool = False

    @property
    def steps(self) -> int:
        """Control steps over all legs."""
        return sum(len(leg.targets) for leg in self.legs)


def make_leg(
    model: PoseTask,
    label: str,
    q0: FloatArray,
    target: Callable[[float], FloatArray],
    duration: float,
    dt: float,
    max_steps: int | None,
    settle_at: float | None = None,
    note: str = "",
    hints: tuple[FloatArray, ...] = (),
    witness: Callable[[float], FloatArray] | None = None,
    held: bool = False,
) -> Leg:
    """Sample ``target(t)`` every ``dt`` for ``duration`` (at most ``max_steps``) and check it.

    ``witness(t)``, when given, is a configuration whose pose is ``target(t)``:
    the target counts as reachable where the witness is within the end-stops.
    Without one, reachability is solved for (:func:`reachable_mask`, with
    ``hints`` as extra seeds).
    """
    n = int(round(duration / dt))
    if max_steps is not None:
        n = min(n, max_steps)
    targets = np.array([target(k * dt) for k in range(n)])
    if witness is None:
        reachable = reachable_mask(model, targets, q0, hints)
    else:
        qs = np.array([witness(k * dt) for k in range(n)])
        reachable = ((qs >= model.q_min) & (qs <= model.q_max)).all(axis=1)
    settle = None if settle_at is None else int(round(settle_at / dt))
    return Leg(
        label,
        np.array(q0, dtype=float),
        targets,
        reachable,
        settle if settle is not None and settle < n else None,
        note,
        held,
    )


def circle(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """A circle in the y-z plane through the start pose, orientation held."""
    q0 = home_configuration(model.name)
    start = model.pose(q0)
    radius, omega, ramp = CIRCLE["diameter"] / 2, 2 * np.pi / CIRCLE["period"], CIRCLE["ramp"]

    def target(t: float) -> FloatArray:
        phase = omega * (t * t / (2 * ramp) if t < ramp else t - ramp / 2)  # speed ramps up
        return moved(start, radius * np.array([0.0, 1 - np.cos(phase), np.sin(phase)]))

    leg = make_leg(model, "circle", q0, target, CIRCLE["duration"], dt, max_steps)
    what = (
        f"A {CIRCLE['diameter'] * 100:g} cm circle in the y-z plane through the home pose, "
        f"orientation held, one turn per {CIRCLE['period']:g} s (speed "
        f"{np.pi * CIRCLE['diameter'] / CIRCLE['period']:.3f} m/s, ramped up over "
        f"{ramp:g} s), {CIRCLE['duration']:g} s."
    )
    return Scenario("circle", "1. Smooth reachable path", what, (leg,))


@functools.lru_cache(maxsize=2)
def beyond_reach(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Six legs: the target driven beyond reach along +-x, +-y, +-z, held, and brought back.

    Built once per model, period and length (the reach is found by bisection, some
    seconds per direction): scenario 10 runs the same legs under acceleration limits.
    """
    q0 = home_configuration(model.name)
    start = model.pose(q0)
    legs = []
    for label, axis in AXES.items():
        unit = np.array(axis, dtype=float)
        reach = reach_along(model, q0, unit)
        far = reach + BEYOND["beyond"]
        ramp = far / BEYOND["speed"]
        back = 2 * ramp + BEYOND["hold"]

        def target(
            t: float,
            unit: FloatArray = unit,
            far: float = far,
            ramp: float = ramp,
            back: float = back,
        ) -> FloatArray:
            s = min(t / ramp, 1.0, max(0.0, (back - t) / ramp))
            return moved(start, s * far * unit)

        legs.append(
            make_leg(
                model,
                label,
                q0,
                target,
                back + BEYOND["settle"],
                dt,
                max_steps,
                settle_at=back,
                note=f"reach {reach:.3f} m",
            )
        )
    reaches = ", ".join(f"{leg.label} {leg.note[6:]}" for leg in legs)
    what = (
        f"From the home pose the target moves at {BEYOND['speed']:g} m/s along each of "
        f"+-x, +-y, +-z to {BEYOND['beyond']:g} m beyond reach (orientation held; reach "
        f"found by bisection with a bounded solve: {reaches}), is held {BEYOND['hold']:g} s, "
        f"comes back at the same speed and is held {BEYOND['settle']:g} s at the home "
        f"pose. Each direction is a run of its own from the home configuration."
    )
    return Scenario("beyond", "2. Targets beyond the workspace and back", what, tuple(legs))


def _end_stop_leg(model: PoseTask, joint: int, dt: float, max_steps: int | None) -> Leg:
    """A reachable goal whose straight-line path drives ``joint`` (0-based) into its end-stop.

    The start is the home configuration with ``joint`` moved next to its nearer
    end-stop; among seeded goal configurations within the limits, the one whose
    unlimited least-norm path passes furthest beyond that stop is taken.
    """
    home = home_configuration(model.name)
    lo, hi = model.q_min, model.q_max
    upper = hi[joint] - home[joint] < home[joint] - lo[joint]
    stop, sign = (hi[joint], 1.0) if upper else (lo[joint], -1.0)
    q0 = home.copy()
    q0[joint] = stop - sign * END_STOP["inside"]
    start = model.pose(q0)
    rng = np.random.default_rng(joint)
    coarse = np.linspace(0.0, 1.0, 50)
    move, steps = END_STOP["move"], int(round(END_STOP["duration"] / dt))
    ranked = []
    for _ in range(END_STOP["candidates"]):
        goal_q = np.clip(
            q0 + rng.uniform(-1, 1, q0.size) * END_STOP["spread"], lo + 0.05, hi - 0.05
        )
        goal = model.pose(goal_q)
        if np.linalg.norm(goal[:3, 3] - start[:3, 3]) < 0.05:
            continue
        path = np.array([blend(start, goal, s) for s in coarse])
        past = float(np.max(sign * (unlimited_path(model, q0, path)[:, joint] - stop)))
        if past > 0:
            ranked.append((past, goal_q, goal))
    ranked.sort(key=lambda item: -item[0])
    moving = min(steps, int(round(move / dt)) + 1)  # then held at the goal
    for past, best, goal in ranked:  # the furthest past whose path is reachable throughout
        path = [blend(start, goal, float(smoothstep(k * dt / move))) for k in range(moving)]
        if reachable_mask(model, np.array(path), q0, (best,)).all():
            best_past = past
            break
    else:
        raise RuntimeError(f"no end-stop goal found for joint {joint + 1}")

    def target(t: float) -> FloatArray:
        return blend(start, goal, float(smoothstep(t / move)))

    name = model.joint_names[joint]
    note = (
        f"{name} starts {END_STOP['inside']:g} rad inside its {'upper' if upper else 'lower'} "
        f"end-stop; the unlimited least-norm path passes it by {best_past:.2f} rad; the goal "
        f"is the pose of a configuration within the limits"
    )
    return make_leg(
        model, name, q0, target, END_STOP["duration"], dt, max_steps, note=note, hints=(best,)
    )


def end_stop(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Joint 7, then joint 2, driven into an end-stop on the way to a reachable pose."""
    legs = tuple(_end_stop_leg(model, j, dt, max_steps) for j in (6, 1))
    what = (
        f"A straight-line move (smoothstep, {END_STOP['move']:g} s, then held; "
        f"{END_STOP['duration']:g} s per leg) to a pose whose least-norm path would carry "
        "a joint past its end-stop while the other joints can reach it: "
        + "; ".join(leg.note for leg in legs)
        + "."
    )
    return Scenario("end-stop", "3. A joint driven into its end-stop", what, legs)


def step_inputs(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Target jumps of 5 cm every 50 ms along +x, +y, +z, -x, -y, -z, repeated."""
    q0 = home_configuration(model.name)
    start = model.pose(q0)
    walk = np.cumsum(
        np.array([(0, 0, 0), *list(AXES.values())[::2], *list(AXES.values())[1::2]], dtype=float),
        axis=0,
    )
    corners = walk[:-1] * STEPS["jump"]  # returns to the start after six jumps

    def target(t: float) -> FloatArray:
        return moved(start, corners[int(t / STEPS["every"] + 1e-9) % len(corners)])

    leg = make_leg(model, "steps", q0, target, STEPS["duration"], dt, max_steps)
    what = (
        f"The target jumps {STEPS['jump'] * 100:g} cm every {STEPS['every'] * 1e3:g} ms "
        f"along +x, +y, +z, -x, -y, -z (the edges of a cube, back to the start), orientation "
        f"held, {STEPS['duration']:g} s: demands beyond the velocity limits."
    )
    return Scenario("steps", "4. Step inputs that saturate the velocity limits", what, (leg,))


def smallest_singular_value(model: PoseTask, q: FloatArray) -> float:
    """The smallest singular value of the task Jacobian at ``q``."""
    return float(np.linalg.svd(model.jacobian(q), compute_uv=False)[-1])


def _singular_leg(
    model: PoseTask, label: str, base: FloatArray, dt: float, max_steps: int | None
) -> Leg:
    """Joint 4 swings through the angle that stretches the arm straight (least singular value)."""
    lo, hi = model.q_min[3], model.q_max[3]

    def sigma(a: float) -> float:
        q = base.copy()
        q[3] = a
        return smallest_singular_value(model, q)

    found = minimize_scalar(sigma, bounds=(lo, hi), method="bounded", options={"xatol": 1e-6})
    a = float(found.x)
    low, high = max(lo + 0.05, a - SINGULAR["below"]), min(hi - 0.05, a + SINGULAR["above"])
    q0 = base.copy()
    q0[3] = low

    def joints(t: float) -> FloatArray:
        q = base.copy()
        q[3] = low + (high - low) * 0.5 * (1 - np.cos(2 * np.pi * t / SINGULAR["period"]))
        return q

    def target(t: float) -> FloatArray:
        return model.pose(joints(t))

    note = (
        f"{label}: joint 4 swings {low:.2f} -> {high:.2f} -> {low:.2f} rad through "
        f"{a:.3f} rad, where the smallest singular value of J is {sigma(a):.1e} "
        f"(home: {smallest_singular_value(model, home_configuration(model.name)):.2f})"
    )
    return make_leg(
        model, label, q0, target, SINGULAR["period"], dt, max_steps, note=note, witness=joints
    )


def singular(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """The arm stretched out straight (a boundary singularity), upwards and leaning forward."""
    home = home_configuration(model.name)
    forward = home.copy()
    forward[1] = 0.8
    legs = (
        _singular_leg(model, "up", home, dt, max_steps),
        _singular_leg(model, "forward", forward, dt, max_steps),
    )
    what = (
        "The target is the pose of a joint path (so it is reachable) that stretches the arm "
        f"out straight and back over {SINGULAR['period']:g} s: "
        + "; ".join(leg.note for leg in legs)
        + "."
    )
    return Scenario("singular", "5. Through a singular configuration", what, legs)


def acceleration(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Reversals and a circle started at full speed, with every library's accelerations checked."""
    q0 = home_configuration(model.name)
    start = model.pose(q0)
    every, jump = ACCEL["every"], ACCEL["jump"]

    def reversals(t: float) -> FloatArray:
        k = int(t / every + 0.5 + 1e-9)  # the first half period at the start pose
        side = 0.0 if k == 0 else (0.5 if k % 2 else -0.5)
        return moved(start, np.array([0.0, side * jump, 0.0]))

    radius, omega = CIRCLE["diameter"] / 2, 2 * np.pi / CIRCLE["period"]

    def sudden(t: float) -> FloatArray:
        phase = omega * t
        return moved(start, radius * np.array([0.0, 1 - np.cos(phase), np.sin(phase)]))

    legs = (
        make_leg(model, "reversals", q0, reversals, ACCEL["duration"], dt, max_steps),
        make_leg(model, "sudden circle", q0, sudden, ACCEL["duration"], dt, max_steps),
    )
    what = (
        f"Reversals: the target jumps {jump * 100:g} cm back and forth along y every "
        f"{every * 1e3:g} ms; sudden circle: scenario 1's circle started at full speed from "
        f"rest; {ACCEL['duration']:g} s each. Every library's joint accelerations are checked "
        "against the acceleration limit of the +acc variants (the peers have none: their "
        "violations show the accelerations they ask for)."
    )
    return Scenario("acceleration", "6. Acceleration limits", what, legs, acceleration_checked=True)


def rest_to_rest_times(distance: FloatArray, qd_max: FloatArray, qdd_max: float) -> FloatArray:
    """The least time [s] in which each joint alone covers ``distance`` from rest to rest.

    At its velocity limit and ``qdd_max``: bang-bang, or trapezoidal where it
    reaches its velocity limit.
    """
    d = np.abs(np.asarray(distance, dtype=float))
    bang = 2.0 * np.sqrt(d / qdd_max)
    cruise = d / qd_max + qd_max / qdd_max
    return np.where(d <= qd_max**2 / qdd_max, bang, cruise)


def rest_to_rest_time(distance: FloatArray, qd_max: FloatArray, qdd_max: float) -> float:
    """The least time [s] in which every joint covers ``distance`` from rest to rest:
    the slowest joint's (:func:`rest_to_rest_times`)."""
    return float(np.max(rest_to_rest_times(distance, qd_max, qdd_max)))


def least_time_velocities(
    distance: FloatArray, qd_max: FloatArray, qdd_max: float, dt: float, steps: int
) -> FloatArray:
    """Joint velocities (steps, n) [rad/s] of a rest-to-rest move over ``distance`` in the
    least time the limits allow (:func:`rest_to_rest_time`).

    Every joint follows the slowest joint's speed profile (at ``qdd_max`` and its
    velocity limit), scaled to its own distance, so that all arrive together;
    sampled at the middle of each period, at rest after the move.
    """
    d = np.asarray(distance, dtype=float)
    times = rest_to_rest_times(d, qd_max, qdd_max)
    slowest = int(np.argmax(times))
    length = abs(d[slowest])
    if length == 0.0:
        return np.zeros((steps, d.size))
    peak = min(math.sqrt(length * qdd_max), float(qd_max[slowest]))
    t = (np.arange(steps) + 0.5) * dt
    speed = np.clip(np.minimum(qdd_max * t, qdd_max * (times[slowest] - t)), 0.0, peak)
    return (speed / length)[:, None] * d[None, :]


def _random_moves(model: PoseTask, q0: FloatArray) -> list[tuple[FloatArray, str]]:
    """Goal configurations about ``q0`` within the end-stops whose poses are far enough."""
    rng = np.random.default_rng(POINT["seed"])
    start = model.pose(q0)
    out: list[tuple[FloatArray, str]] = []
    while len(out) < POINT["moves"]:
        spread = rng.uniform(-1, 1, q0.size) * POINT["spread"]
        goal_q = np.clip(q0 + spread, model.q_min + 0.05, model.q_max - 0.05)
        d = model.difference(start, model.pose(goal_q))
        distance, turn = float(np.linalg.norm(d[:3])), float(np.linalg.norm(d[3:]))
        if distance >= POINT["distance"] and turn >= POINT["turn"]:
            out.append((goal_q, f"{distance * 100:.0f} cm, {turn:.2f} rad"))
    return out


def point_step(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """The getting-started example: a pose 5 cm along +x held from rest at home."""
    q0 = home_configuration(model.name)
    goal = moved(model.pose(q0), np.array([POINT["step"], 0.0, 0.0]))
    leg = make_leg(model, f"{POINT['step'] * 100:g} cm +x", q0, lambda t: goal,
                   POINT["step_duration"], dt, max_steps, held=True)  # fmt: skip
    what = (
        f"The 1 kHz loop of docs/getting-started.md: from rest at the home configuration the "
        f"target is the home pose moved {POINT['step'] * 100:g} cm along +x, held for "
        f"{POINT['step_duration']:g} s, each step given the last configuration as `q_prev`. "
        f"Every library's accelerations are checked against {QDD_MAX:g} rad/s^2, and those "
        "that take acceleration limits run with them."
    )
    return Scenario("step", "7. Point-to-point step under acceleration limits", what, (leg,),
                    acceleration_checked=True)  # fmt: skip


def _held_pose_leg(
    model: PoseTask, label: str, q0: FloatArray, goal_q: FloatArray, duration: float, dt: float,
    max_steps: int | None, note: str,
) -> Leg:  # fmt: skip
    """From rest at ``q0``, the pose at ``goal_q`` held from the first step (``goal_q`` the
    configuration that reaches it: the leg's witness)."""
    pose = model.pose(goal_q)
    return make_leg(model, label, q0, lambda t: pose, duration, dt, max_steps, held=True,
                    note=note, witness=lambda t: goal_q)  # fmt: skip


def _held_poses_text(draw: str, legs: list[Leg], remark: str = "") -> str:
    """A held-pose scenario's description: ``draw`` (how the poses were drawn, up to the
    legs' notes), each leg's note, ``remark``, and how accelerations are judged."""
    notes = "; ".join(f"{leg.label}: {leg.note}" for leg in legs)
    return (
        "The target is one pose from the first step on, held, from rest at the home "
        f"configuration: the poses of {draw}{notes}). {remark}Every library's accelerations "
        "are checked, and those that take acceleration limits run with them."
    )


def point_to_point(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Step targets held from rest: the poses of random configurations about home."""
    q0 = home_configuration(model.name)
    legs = []
    for k, (goal_q, size) in enumerate(_random_moves(model, q0)):
        least = rest_to_rest_time(goal_q - q0, model.qd_max, QDD_MAX)
        note = f"{size}; joint move at the limits {least * 1e3:.0f} ms"
        legs.append(_held_pose_leg(model, f"move {k + 1}", q0, goal_q, POINT["duration"], dt,
                                   max_steps, note))  # fmt: skip
    what = _held_poses_text(
        f"{POINT['moves']} configurations drawn within {POINT['spread']:g} rad of home and the "
        f"end-stops, at least {POINT['distance'] * 100:g} cm and {POINT['turn']:g} rad away "
        f"({POINT['duration']:g} s each; distance, turn, and the least time in which the "
        f"joints reach that configuration at their velocity limits and {QDD_MAX:g} rad/s^2: ",
        legs,
    )
    return Scenario("point", "8. Point to point: larger moves under acceleration limits", what,
                    tuple(legs), acceleration_checked=True)  # fmt: skip


def goals_anywhere(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Step targets held from rest: the poses of configurations anywhere in the joint ranges.

    The draw is :func:`lpik_bench.random_goals.goal_configurations` (the benchmark that
    runs every arm with and without acceleration limits), so that a goal is reachable
    within the end-stops, though not always on the branch a local step follows from home.
    """
    from lpik_bench.random_goals import MIDDLE, goal_configurations

    q0 = home_configuration(model.name)
    start = model.pose(q0)
    legs = []
    for k, goal_q in enumerate(goal_configurations(model, GOALS["goals"], GOALS["seed"])):
        d = model.difference(start, model.pose(goal_q))
        size = f"{np.linalg.norm(d[:3]) * 100:.0f} cm, {np.linalg.norm(d[3:]):.2f} rad"
        legs.append(_held_pose_leg(model, f"goal {k}", q0, goal_q, GOALS["duration"], dt,
                                   max_steps, size))  # fmt: skip
    what = _held_poses_text(
        f"{GOALS['goals']} configurations drawn uniformly from the middle {MIDDLE:.0%} of every "
        f"joint's range (seed {GOALS['seed']}, the first goals of benchmarks/random_goals.py), "
        f"{GOALS['duration']:g} s each (distance, turn: ",
        legs,
        "Each is reachable within the end-stops, some only on another branch of the inverse "
        "kinematics than the one a local step follows from home. ",
    )
    return Scenario("goals", "11. Reachable goals anywhere in the joint ranges", what,
                    tuple(legs), acceleration_checked=True)  # fmt: skip


def obstacle(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Two legs from home with the sphere overlapping link 4, then inside ``d_s``.

    The sphere, the distances and mink among obstacles: :mod:`lpik_bench.quality_obstacle`.
    """
    from lpik_bench.quality_obstacle import OBSTACLE, closest, sphere_scene

    q0 = home_configuration(model.name)
    goal = model.pose(q0)
    goal[:3, 3] = OBSTACLE["target"]
    center = np.array(OBSTACLE["overlapping"], dtype=float)
    near = closest(model, q0, center)
    inside = center + (OBSTACLE["inside"] - near.distance) * near.normal
    legs = []
    for label, c in (("overlapping", center), ("inside d_s", inside)):
        d = closest(model, q0, c)
        at = ", ".join(f"{x:.3f}" for x in c)
        note = f"{d.body} {d.distance * 1e3:.1f} mm from the sphere at ({at})"
        leg = make_leg(model, label, q0, lambda t: goal, OBSTACLE["duration"], dt, max_steps,
                       note=note, held=True)  # fmt: skip
        legs.append(replace(leg, scene=sphere_scene(c)))
    what = (
        f"A {OBSTACLE['radius'] * 100:g} cm sphere at the Panda's link 4 at the home "
        f"configuration, with d_s = {OBSTACLE['safety'] * 1e3:g} mm and d_i = "
        f"{OBSTACLE['influence'] * 1e3:g} mm: "
        + "; ".join(f"{leg.label}: {leg.note}" for leg in legs)
        + f". The target is held from the first step: the tool at "
        f"({', '.join(f'{x:g}' for x in OBSTACLE['target'])}) m, home orientation, "
        f"{OBSTACLE['duration']:g} s per leg. Libraries without obstacles in their adapters "
        "(drake, pink, rtb) are n/a; mink runs with its CollisionAvoidanceLimit over the "
        "same capsules and distances."
    )
    return Scenario("obstacle", "9. Start inside an obstacle's safety distance", what,
                    tuple(legs))  # fmt: skip


def beyond_reach_limited(model: PoseTask, dt: float, max_steps: int | None) -> Scenario:
    """Scenario 2's legs under acceleration limits: every library's accelerations checked,
    the libraries that take acceleration limits run with them (decision 4)."""
    plain = beyond_reach(model, dt, max_steps)
    what = (
        "Scenario 2's targets (beyond reach along +-x, +-y, +-z and back) under acceleration "
        "limits: the libraries that take them run with them, and every library's "
        "accelerations are checked."
    )
    return Scenario("beyond-acc", "10. Targets beyond the workspace and back under "
                    "acceleration limits", what, plain.legs, acceleration_checked=True)  # fmt: skip


#: Scenario builders, in the order of the report: ``builder(model, dt, max_steps) -> Scenario``.
SCENARIOS: dict[str, Callable[[PoseTask, float, int | None], Scenario]] = {
    "circle": circle,
    "beyond": beyond_reach,
    "end-stop": end_stop,
    "steps": step_inputs,
    "singular": singular,
    "acceleration": acceleration,
    "step": point_step,
    "point": point_to_point,
    "obstacle": obstacle,
    "beyond-acc": beyond_reach_limited,
    "goals": goals_anywhere,
}
