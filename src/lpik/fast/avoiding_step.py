"""The fused LP2 step with the velocity damper's distance rows computed in the same call.

:func:`avoiding_step` does, in one compiled call, what
:class:`lpik.control.avoiding_controller.AvoidingLp2Controller` does through
coal on its numpy path: the robot's capsules placed by the chain's joint
frames, the signed distance of every watched pair (:mod:`lpik.fast.distances`,
held equal to coal), the gradient ``-n^T (J_1 - J_2)`` of each pair within the
influence distance (as :mod:`lpik.collision.distance` defines it) and its row
by :func:`lpik.collision.avoidance.approach_row` (compiled here as it is; under
acceleration limits also a pair beyond ``d_i`` that must brake ahead of it),
written into the state's rows block; then the fused step itself
(:func:`lpik.fast.step.task_step`). A pair inside the safety distance gets
the damper's row mirrored, which demands that its distance grow; where no
step keeps it, or ``p`` is frozen near 0, the kernel's outcome goes to the
recovery step of :mod:`lpik.collision.recovery`, which
:class:`~lpik.control.avoiding_controller.AvoidingLp2Controller` takes in
Python on the step's problem (its distances: ``found``).

The robot and the scene travel as a few arrays (:func:`pack_bodies`):
``capsules`` (k, 8): joint, ``a``, ``b`` in that joint's frame, radius;
``obstacles`` (o, 17): a kind (:data:`KINDS`) and its numbers;
``pairs`` (P, 3): 0 and (capsule, obstacle), or 1 and (capsule, capsule), in
the order of :meth:`lpik.collision.Proximities.at`; ``damper`` (5,):
the share ``r``, ``d_s``, ``d_i``, the potential field's gain ``eta`` (0: none)
and 1 for the field alone (rows only inside ``d_s``); and their scratch, among which
``found`` (P, 10): each pair's distance, witness points and normal after a step.

With the potential field (``mechanism="field"`` or ``"both"``) the same pass sums
each pair's repulsion into the force (the state's ``field`` block), which the
step adds to its criterion at the share of its room that
:func:`lpik.collision.avoidance.field_scale_for` gives
(:func:`lpik.fast.step.field_in_state`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types

from lpik import bands
from lpik.collision import avoidance
from lpik.collision.avoidance import INACTIVE_RHS, damper_share
from lpik.fast import layout as L
from lpik.fast.command_law import previous_kinematics
from lpik.fast.distances import (
    FOUND,
    capsule_box,
    capsule_capsule,
    capsule_halfspace,
    capsule_sphere,
)
from lpik.fast.kinematics import _axis_rotation, _mul3, _mul33, _rotation, chain_fk_jacobian
from lpik.fast.signatures import loaded_kernel, typed_kernel
from lpik.fast.step import (
    BAD_INPUT,
    STEP_SIGNATURES,
    TARGET_AXES,
    _finite_joints,
    fused_task_step,
    row_deceleration,
    task_step,
)
from lpik.fast.twins import compiled_twin, rebound
from lpik.fast.views import matrix
from lpik.tolerances import FEASIBILITY_TOL

#: Obstacle kinds, by their code in the ``obstacles`` array.
KINDS = ("sphere", "capsule", "box", "plane")
#: A pair is skipped when a lower bound on its distance exceeds ``d_i`` by this much [m].
BOUND_MARGIN = 1e-9
#: Floats per obstacle: the kind, then up to 16 numbers (a box: centre, rotation, half sizes).
OBSTACLE_WIDTH = 17

_braking_room = njit(cache=True)(bands.braking_room)
#: :func:`lpik.collision.avoidance.damper_row`, compiled.
compiled_damper_row = njit(cache=True)(avoidance.damper_row)
#: :func:`lpik.collision.avoidance.repulsion` (the field's magnitude), compiled.
compiled_repulsion = njit(cache=True)(avoidance.repulsion)
#: :func:`lpik.collision.avoidance.approach_row` (the damper's row, or the stop ahead of
#: ``d_i``), compiled.
compiled_approach_row = compiled_twin(
    avoidance.approach_row,
    damper_row=compiled_damper_row,
    braking_row=compiled_twin(avoidance.braking_row, braking_room=_braking_room,
                              stopping_distance=njit(cache=True)(bands.stopping_distance),
                              row_deceleration=row_deceleration),
)  # fmt: skip
#: :func:`lpik.collision.avoidance.capsule_reach`, compiled.
compiled_capsule_reach = compiled_twin(avoidance.capsule_reach)


@njit(cache=True)
def joint_frames(origins, axes, revolute, q, frames):
    """Each joint's frame after its motion (:meth:`~lpik.robots.chain.SerialChain.joint_frames`).

    ``frames`` (n, 12): the rotation row-major, then the origin.
    """
    R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    px, py, pz = 0.0, 0.0, 0.0
    for i in range(q.shape[0]):
        origin = origins[i]
        dx, dy, dz = _mul3(R, origin[0, 3], origin[1, 3], origin[2, 3])
        px, py, pz = px + dx, py + dy, pz + dz
        R = _mul33(R, _rotation(origin))
        if revolute[i]:
            R = _mul33(R, _axis_rotation(axes[i], q[i]))
        else:
            ax, ay, az = _mul3(R, axes[i, 0], axes[i, 1], axes[i, 2])
            px, py, pz = px + ax * q[i], py + ay * q[i], pz + az * q[i]
        for k in range(9):
            frames[i, k] = R[k]
        frames[i, 9], frames[i, 10], frames[i, 11] = px, py, pz


@njit(cache=True)
def place_capsules(capsules, frames, ends):
    """Every capsule's ends in the world frame: ``ends`` (k, 6)."""
    for k in range(capsules.shape[0]):
        j = int(capsules[k, 0])
        for e in range(2):
            x, y, z = capsules[k, 1 + 3 * e], capsules[k, 2 + 3 * e], capsules[k, 3 + 3 * e]
            if j < 0:
                ends[k, 3 * e], ends[k, 3 * e + 1], ends[k, 3 * e + 2] = x, y, z
            else:
                F = frames[j]
                ends[k, 3 * e] = F[0] * x + F[1] * y + F[2] * z + F[9]
                ends[k, 3 * e + 1] = F[3] * x + F[4] * y + F[5] * z + F[10]
                ends[k, 3 * e + 2] = F[6] * x + F[7] * y + F[8] * z + F[11]


@njit(cache=True)
def obstacle_distance(capsule, a, b, obstacle, out, scratch):
    """The signed distance of one placed capsule to one obstacle (``out``: 10 floats)."""
    kind, radius = int(obstacle[0]), capsule[7]
    if kind == 0:
        return capsule_sphere(a, b, radius, obstacle[1:4], obstacle[4], out)
    if kind == 1:
        return capsule_capsule(a, b, radius, obstacle[1:4], obstacle[4:7], obstacle[7], out)
    if kind == 2:
        rotation = matrix(obstacle, 4, 3, 3)
        return capsule_box(a, b, radius, obstacle[1:4], rotation, obstacle[13:16], out, scratch)
    return capsule_halfspace(a, b, radius, obstacle[1:4], obstacle[4], out)


@njit(cache=True)
def _ball(ends, k, radius):
    """Capsule ``k``'s midpoint and the radius of a ball about it holding it (``ends``: (k, 6))."""
    ux, uy, uz = ends[k, 3] - ends[k, 0], ends[k, 4] - ends[k, 1], ends[k, 5] - ends[k, 2]
    reach = radius + 0.5 * math.sqrt(ux * ux + uy * uy + uz * uz)
    return (0.5 * (ends[k, 0] + ends[k, 3]), 0.5 * (ends[k, 1] + ends[k, 4]),
            0.5 * (ends[k, 2] + ends[k, 5]), reach)  # fmt: skip


@njit(cache=True)
def _apart(x1, y1, z1, reach1, x2, y2, z2, reach2):
    """The distance of two balls (negative when they overlap)."""
    dx, dy, dz = x1 - x2, y1 - y2, z1 - z2
    return math.sqrt(dx * dx + dy * dy + dz * dz) - reach1 - reach2


@njit(cache=True)
def obstacle_bound(ends, k, radius, obstacles, o):
    """A lower bound on capsule ``k``'s distance to obstacle ``o``, cheaper than the distance.

    The capsule lies within its bounding ball (:func:`_ball`), so its distance is
    at least the obstacle's distance to the ball's centre less the ball's
    radius: for a sphere or capsule obstacle, through its own bounding ball;
    for a box, the centre clamped in the box's frame; for a plane, exactly.
    """
    mx, my, mz, reach = _ball(ends, k, radius)
    kind, ob = int(obstacles[o, 0]), obstacles[o]
    if kind == 0:
        return _apart(mx, my, mz, reach, ob[1], ob[2], ob[3], ob[4])
    if kind == 1:
        vx, vy, vz = ob[4] - ob[1], ob[5] - ob[2], ob[6] - ob[3]
        extent = ob[7] + 0.5 * math.sqrt(vx * vx + vy * vy + vz * vz)
        return _apart(mx, my, mz, reach, 0.5 * (ob[1] + ob[4]), 0.5 * (ob[2] + ob[5]),
                      0.5 * (ob[3] + ob[6]), extent)  # fmt: skip
    if kind == 3:
        return ob[1] * mx + ob[2] * my + ob[3] * mz - ob[4] - reach
    dx, dy, dz = mx - ob[1], my - ob[2], mz - ob[3]
    gap = 0.0
    for c in range(3):  # the rotation's column c is the box's axis c
        x = abs(dx * ob[4 + c] + dy * ob[7 + c] + dz * ob[10 + c])
        if x > ob[13 + c]:
            gap += (x - ob[13 + c]) ** 2
    return math.sqrt(gap) - reach


@njit(cache=True)
def add_velocity(frames, axes, revolute, joint, p, sign, normal, gradient):
    """``gradient += sign * n^T J(p)`` for ``p`` fixed in the frame of ``joint``.

    Column ``i <= joint`` of ``J``: ``z_i x (p - o_i)`` (revolute) or ``z_i``
    (prismatic), with ``z_i``, ``o_i`` from the frames after the motion
    (:func:`lpik.collision.distance.point_jacobian`).
    """
    nx, ny, nz = normal[0], normal[1], normal[2]
    for i in range(joint + 1):
        F = frames[i]
        zx = F[0] * axes[i, 0] + F[1] * axes[i, 1] + F[2] * axes[i, 2]
        zy = F[3] * axes[i, 0] + F[4] * axes[i, 1] + F[5] * axes[i, 2]
        zz = F[6] * axes[i, 0] + F[7] * axes[i, 1] + F[8] * axes[i, 2]
        if revolute[i]:
            rx, ry, rz = p[0] - F[9], p[1] - F[10], p[2] - F[11]
            vx, vy, vz = zy * rz - zz * ry, zz * rx - zx * rz, zx * ry - zy * rx
        else:
            vx, vy, vz = zx, zy, zz
        gradient[i] += sign * (nx * vx + ny * vy + nz * vz)


@njit(cache=True)
def world_axes(frames, axes, out):
    """Each joint's unit axis in the world, ``out (n, 3)``: its frame's rotation times its axis."""
    for i in range(axes.shape[0]):
        F, x, y, z = frames[i], axes[i, 0], axes[i, 1], axes[i, 2]
        for r in range(3):
            out[i, r] = F[3 * r] * x + F[3 * r + 1] * y + F[3 * r + 2] * z


@njit(cache=True)
def distance_rows(capsules, obstacles, pairs, damper, frames, ends, found, scratch, state, q0,
                  q_prev):  # fmt: skip
    """Every watched pair's distance, row and repulsion: ``found``, rows block, ``field``.

    Each pair's distance goes into ``found``, its row into the state's rows block,
    its repulsion into the state's ``field`` block (:func:`pair_share`). A pair
    within ``d_i`` gets the damper's row, one beyond it under acceleration limits
    its stop ahead where it needs one (:func:`compiled_approach_row`); every
    other reserved row is ``0 q <= INACTIVE_RHS``. With the field alone
    (``damper[4]`` 1) only a pair inside ``d_s`` has a row, and none a stop ahead, as
    :meth:`lpik.collision.CollisionAvoidance.rows` has it. With a field gain
    (``damper[3]`` > 0) each pair within ``d_i`` adds its repulsion
    (:func:`lpik.collision.avoidance.field_force`). A pair whose distance is beyond
    ``d_i`` plus its capsules' reach (:func:`compiled_capsule_reach`) for certain (a
    bounding sphere's test) is not measured.
    """
    n, k_capsules = q0.shape[0], capsules.shape[0]
    axes = L.matrix_at(state, L.AXES, n, 3)
    revolute = L.vector(state, L.REVOLUTE)
    G = L.matrix_at(state, L.ROWS_G, pairs.shape[0], n)
    h = L.vector(state, L.ROWS_H)
    limits = L.matrix_at(state, L.LIMITS, 6, n)
    dt, influence = state[L.DT], damper[2]
    force = L.vector(state, L.FIELD)
    for c in range(n):
        force[c] = 0.0
    gradient = scratch[8 : 8 + n]
    reach = scratch[8 + n : 8 + n + 2 * k_capsules]
    world = scratch[8 + n + 2 * k_capsules : 8 + 4 * n + 2 * k_capsules].reshape((n, 3))
    if damper[4] != 0.0:  # no stop ahead of d_i: the field's rows are only those inside d_s
        for c in range(2 * k_capsules):
            reach[c] = 0.0
    else:
        world_axes(frames, axes, world)
        compiled_capsule_reach(capsules[:, 0], capsules[:, 7], ends, frames[:, 9:12], world,
                               revolute, q0, q_prev, limits[4], limits[5], dt, reach)  # fmt: skip
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 1], pairs[k, 2]
        for c in range(n):
            G[k, c] = 0.0
        h[k] = INACTIVE_RHS
        radius = capsules[i, 7]
        ahead = influence + min(reach[i], reach[k_capsules + i])
        if pairs[k, 0] == 0:
            bound = obstacle_bound(ends, i, radius, obstacles, j)
        else:
            ahead = influence + min(
                reach[i] + reach[j], reach[k_capsules + i] + reach[k_capsules + j]
            )
            x1, y1, z1, reach1 = _ball(ends, i, radius)
            x2, y2, z2, reach2 = _ball(ends, j, capsules[j, 7])
            bound = _apart(x1, y1, z1, reach1, x2, y2, z2, reach2)
        if bound > ahead + BOUND_MARGIN:  # beyond d_i and the pair's reach for certain: no row
            found[k, 0] = bound
            for c in range(1, FOUND):
                found[k, c] = math.nan
            continue
        out = found[k]
        a, b = ends[i, 0:3], ends[i, 3:6]
        if pairs[k, 0] == 0:
            d = obstacle_distance(capsules[i], a, b, obstacles[j], out, scratch)
        else:
            d = capsule_capsule(a, b, radius, ends[j, 0:3], ends[j, 3:6], capsules[j, 7], out)
        if d >= ahead:
            continue
        for c in range(n):
            gradient[c] = 0.0
        # d distance / dq = -n^T (J_1(p_1) - J_2(p_2))
        add_velocity(frames, axes, revolute, int(capsules[i, 0]), out[1:4], -1.0, out[7:10],
                     gradient)  # fmt: skip
        if pairs[k, 0] == 1:
            add_velocity(frames, axes, revolute, int(capsules[j, 0]), out[4:7], 1.0, out[7:10],
                         gradient)  # fmt: skip
        pair_share(d, gradient, q0, q_prev, limits, dt, damper, G[k], h, k, force)


@njit(cache=True)
def pair_share(distance, gradient, q0, q_prev, limits, dt, damper, row, h, k, force):
    """One measured pair's share of the step: its row (``row``, ``h[k]``) and its repulsion.

    The row as :func:`distance_rows` gives it (with the field alone, only inside
    ``d_s``); with a field gain, within ``d_i`` the pair's repulsion
    (:func:`lpik.collision.avoidance.repulsion`) along ``gradient`` is added to ``force``.
    """
    safety, influence, gain = damper[1], damper[2], damper[3]
    if gain > 0.0 and distance < influence:
        push = dt * compiled_repulsion(distance, gain, influence)
        for c in range(force.shape[0]):
            force[c] += push * gradient[c]
    if damper[4] != 0.0:  # the field alone: the damper's row inside d_s (no acc. limits)
        if distance >= safety - FEASIBILITY_TOL:
            return
        rhs = compiled_damper_row(distance, gradient, q0, damper[0], safety, row)
    else:
        rhs = compiled_approach_row(distance, gradient, q0, q_prev, limits[4], limits[5], dt,
                                    damper, row)  # fmt: skip
    if not math.isnan(rhs):
        h[k] = rhs


def avoiding_step(capsules, obstacles, pairs, damper, frames, ends, found, scratch,
                  state, q0, q_prev, target):  # type: ignore[no-untyped-def]  # fmt: skip
    """One fused LP2 step keeping the scene's distances: kinematics, distance rows, LP2.

    Call it compiled (:func:`avoiding_kernel`); the first eight arguments are
    those of :func:`pack_bodies`, the last four those of
    :func:`lpik.fast.step.chain_step`.

    Returns:
        The LP2 kernel's outcome code, or :data:`lpik.fast.step.BAD_INPUT`.
    """
    n = int(state[L.N])
    if not _finite_joints(q0, q_prev, n):
        return BAD_INPUT
    origins = L.tensor_at(state, L.ORIGINS, n, 4, 4)
    axes, revolute = L.matrix_at(state, L.AXES, n, 3), L.vector(state, L.REVOLUTE)
    chain_fk_jacobian(
        origins, axes, revolute, L.matrix_at(state, L.TIP, 4, 4), q0,
        L.matrix_at(state, L.FRAME, 4, 4), L.matrix_at(state, L.JACOBIAN6, 6, n),
        L.tensor_at(state, L.JOINTS, 2, n, 3),
    )  # fmt: skip
    joint_frames(origins, axes, revolute, q0, frames)
    place_capsules(capsules, frames, ends)
    distance_rows(capsules, obstacles, pairs, damper, frames, ends, found, scratch, state, q0,
                  q_prev)  # fmt: skip
    previous_kinematics(state, q0, q_prev)
    return task_step(state, q0, q_prev, target)


_F1, _F2 = types.float64[::1], types.float64[:, ::1]
_BODIES = (_F2, _F2, types.int64[:, ::1], _F1)
_SCRATCH = (_F2, _F2, _F2, _F1)
#: The argument types :func:`avoiding_kernel` compiles :func:`avoiding_step` for, by
#: the number of axes of the target (as :data:`lpik.fast.step.STEP_SIGNATURES`).
AVOIDING_SIGNATURES = {
    axes: (*_BODIES, *_SCRATCH, *STEP_SIGNATURES[axes]) for axes in STEP_SIGNATURES
}
# the step's parts inlined into it (lpik.fast.step.fused_task_step)
_avoiding_step = rebound(avoiding_step, task_step=fused_task_step)


def avoiding_kernel(target_axes: tuple[int, ...] = TARGET_AXES) -> Any:
    """The compiled :func:`avoiding_step`, for targets of ``target_axes`` axes only.

    As :func:`lpik.fast.step.step_kernel`: each signature of
    :data:`AVOIDING_SIGNATURES` is compiled (or loaded) when first asked for.
    """
    return typed_kernel("avoiding_step", _avoiding_step,
                        (AVOIDING_SIGNATURES[a] for a in target_axes))  # fmt: skip


def loaded_avoiding_kernel() -> Any:
    """The compiled step if :func:`avoiding_kernel` has readied it in this process, else None."""
    return loaded_kernel("avoiding_step")


def pack_bodies(
    proximities: Any, dt: float, approach_speed: float, field_gain: float = 0.0,
    inside_only: bool = False,
) -> tuple[np.ndarray, ...]:  # fmt: skip
    """The arrays :func:`avoiding_step` takes before the state, for a scene's pairs.

    Args:
        proximities: A :class:`lpik.collision.Proximities` (its bodies, scene and pairs).
        dt: Control period [s].
        approach_speed: ``xi`` of the damper [m/s].
        field_gain: ``eta`` of the potential field [m^3/s] (0: no field).
        inside_only: The field alone: rows only for the pairs inside ``d_s``.

    Returns:
        ``capsules``, ``obstacles``, ``pairs``, ``damper`` and the scratch
        ``frames``, ``ends``, ``found``, ``scratch`` (see the module).
    """
    bodies, scene = proximities.bodies, proximities.scene
    capsules = np.array(
        [[c.joint, *c.a, *c.b, c.radius] for c in bodies.capsules], dtype=np.float64
    ).reshape(-1, 8)
    obstacles = np.zeros((len(scene.obstacles), OBSTACLE_WIDTH))
    for row, obstacle in zip(obstacles, scene.obstacles):
        placed = obstacle.placed()
        numbers = {
            "sphere": ("center", "radius"),
            "capsule": ("a", "b", "radius"),
            "box": ("center", "rotation", "half"),
            "plane": ("normal", "offset"),
        }[obstacle.kind]
        placed["half"] = placed.get("size", np.zeros(3)) / 2
        values = np.concatenate([np.ravel(placed[name]) for name in numbers])
        row[0] = KINDS.index(obstacle.kind)
        row[1 : 1 + values.size] = values
    pairs = np.array(
        [(0, i, o) for i, o in proximities.obstacle_pairs]
        + [(1, i, j) for i, j in bodies.self_pairs],
        dtype=np.int64,
    ).reshape(-1, 3)
    d_s, d_i = scene.safety_distance, scene.influence_distance
    damper = np.array([damper_share(approach_speed, dt, d_s, d_i), d_s, d_i, field_gain,
                       float(inside_only)])  # fmt: skip
    n = bodies.chain.n_joints
    return (
        capsules, obstacles, pairs, damper, np.zeros((n, 12)),
        np.zeros((capsules.shape[0], 6)), np.zeros((pairs.shape[0], FOUND)),
        np.zeros(8 + 4 * n + 2 * capsules.shape[0]),
    )  # fmt: skip
