"""Compiled forward kinematics, Jacobian, command and one fused LP2 control step.

The kinematics follow :class:`lpik.robots.chain.SerialChain`: frame
``T_i = T_{i-1} @ origin_i @ motion_i(q_i)`` with ``motion_i`` a rotation about
(revolute) or a translation along (prismatic) the unit joint axis; the task
frame is ``T_n @ tip``. The Jacobian is world-aligned at the task point:
rows ``[v; omega]``. The orientation error is ``log(R_target R^T)`` in the
base frame, as in :mod:`lpik.robots.tasks`.

The fused steps (:func:`chain_step`, :func:`planar_step`) are compiled by
:func:`step_kernel` on first use (or loaded from the disk cache) for their
explicit signatures only: a call with other types raises ``TypeError``
instead of compiling a new specialisation in the middle of a control loop.
:func:`step_batch_kernel` runs either over a batch of independent states, in
parallel.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from lpik.fast.kernels import INFEASIBLE, lp2_core, matrix, workspace_size


@njit(cache=True)
def _mul33(a, b):  # noqa: ANN001, ANN201
    """``a @ b`` for 3x3 matrices held row-major in 9-tuples (kept in registers)."""
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


@njit(cache=True)
def _mul3(a, x, y, z):  # noqa: ANN001, ANN201
    """``a @ (x, y, z)`` for a 3x3 matrix held row-major in a 9-tuple."""
    return (
        a[0] * x + a[1] * y + a[2] * z,
        a[3] * x + a[4] * y + a[5] * z,
        a[6] * x + a[7] * y + a[8] * z,
    )


@njit(cache=True)
def _axis_rotation(axis, angle):  # noqa: ANN001, ANN201
    """Rodrigues: the rotation by ``angle`` about unit ``axis``, row-major in a 9-tuple."""
    x, y, z = axis[0], axis[1], axis[2]
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return (
        c + x * x * t, x * y * t - z * s, x * z * t + y * s,
        y * x * t + z * s, c + y * y * t, y * z * t - x * s,
        z * x * t - y * s, z * y * t + x * s, c + z * z * t,
    )  # fmt: skip


@njit(cache=True)
def _rotation(A):  # noqa: ANN001, ANN201
    """The top-left 3x3 block of ``A``, row-major in a 9-tuple."""
    return (A[0, 0], A[0, 1], A[0, 2], A[1, 0], A[1, 1], A[1, 2], A[2, 0], A[2, 1], A[2, 2])


@njit(cache=True)
def fk_scratch_size(n):  # noqa: ANN001, ANN201
    """Length of the scratch array :func:`chain_fk_jacobian` needs for ``n`` joints."""
    return 6 * n


@njit(cache=True)
def chain_fk_jacobian(origins, axes, revolute, tip, q, T, J6, scratch):  # noqa: ANN001, ANN201
    """Task-frame pose ``T`` (4, 4) and world-aligned Jacobian ``J6`` (6, n) at ``q``.

    The running frame lives in registers (a rotation 9-tuple and a position);
    ``scratch`` (at least :func:`fk_scratch_size` floats) keeps each joint's
    position and world axis for the Jacobian.
    """
    n = q.shape[0]
    joint_pos = matrix(scratch, 0, n, 3)
    joint_axis = matrix(scratch, 3 * n, n, 3)
    R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    px, py, pz = 0.0, 0.0, 0.0
    for i in range(n):
        origin = origins[i]  # frame = frame @ origin_i
        dx, dy, dz = _mul3(R, origin[0, 3], origin[1, 3], origin[2, 3])
        px, py, pz = px + dx, py + dy, pz + dz
        R = _mul33(R, _rotation(origin))
        ax, ay, az = _mul3(R, axes[i, 0], axes[i, 1], axes[i, 2])
        joint_pos[i, 0], joint_pos[i, 1], joint_pos[i, 2] = px, py, pz
        joint_axis[i, 0], joint_axis[i, 1], joint_axis[i, 2] = ax, ay, az
        if revolute[i]:  # turn about the joint axis
            R = _mul33(R, _axis_rotation(axes[i], q[i]))
        else:  # slide along it
            px, py, pz = px + ax * q[i], py + ay * q[i], pz + az * q[i]
    dx, dy, dz = _mul3(R, tip[0, 3], tip[1, 3], tip[2, 3])
    px, py, pz = px + dx, py + dy, pz + dz
    R = _mul33(R, _rotation(tip))
    for a in range(3):
        for b in range(3):
            T[a, b] = R[3 * a + b]
    T[0, 3], T[1, 3], T[2, 3] = px, py, pz
    T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0
    for i in range(n):
        zx, zy, zz = joint_axis[i, 0], joint_axis[i, 1], joint_axis[i, 2]
        if revolute[i]:
            rx, ry, rz = px - joint_pos[i, 0], py - joint_pos[i, 1], pz - joint_pos[i, 2]
            J6[0, i] = zy * rz - zz * ry
            J6[1, i] = zz * rx - zx * rz
            J6[2, i] = zx * ry - zy * rx
            J6[3, i], J6[4, i], J6[5, i] = zx, zy, zz
        else:
            J6[0, i], J6[1, i], J6[2, i] = zx, zy, zz
            J6[3, i], J6[4, i], J6[5, i] = 0.0, 0.0, 0.0


@njit(cache=True)
def rotation_log(R, out):  # noqa: ANN001, ANN201
    """Rotation vector of ``R`` (3, 3) into ``out`` (3,), robust near 0 and pi."""
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    cos_t = min(1.0, max(-1.0, 0.5 * (tr - 1.0)))
    theta = math.acos(cos_t)
    vx, vy, vz = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    if theta < 1e-6:
        k = 0.5 + theta * theta / 12.0
        out[0], out[1], out[2] = k * vx, k * vy, k * vz
    elif theta < math.pi - 1e-6:
        k = theta / (2.0 * math.sin(theta))
        out[0], out[1], out[2] = k * vx, k * vy, k * vz
    else:
        # Near pi: the axis from the largest diagonal of (R + I) / 2.
        d0, d1, d2 = R[0, 0], R[1, 1], R[2, 2]
        if d0 >= d1 and d0 >= d2:
            ax = math.sqrt(max(0.0, (d0 + 1.0) / 2.0))
            ay, az = R[0, 1] / (2 * ax), R[0, 2] / (2 * ax)
        elif d1 >= d2:
            ay = math.sqrt(max(0.0, (d1 + 1.0) / 2.0))
            ax, az = R[0, 1] / (2 * ay), R[1, 2] / (2 * ay)
        else:
            az = math.sqrt(max(0.0, (d2 + 1.0) / 2.0))
            ax, ay = R[0, 2] / (2 * az), R[1, 2] / (2 * az)
        if ax * vx + ay * vy + az * vz < 0:
            ax, ay, az = -ax, -ay, -az
        out[0], out[1], out[2] = theta * ax, theta * ay, theta * az


@njit(cache=True)
def pose_error(T, target, e6, scratch):  # noqa: ANN001, ANN201
    """``[p_target - p; log(R_target R^T)]`` into ``e6`` (6,); ``scratch`` >= 12 floats."""
    for a in range(3):
        e6[a] = target[a, 3] - T[a, 3]
    Rd = matrix(scratch, 0, 3, 3)
    for a in range(3):
        for b in range(3):
            s = 0.0
            for k in range(3):
                s += target[a, k] * T[b, k]
            Rd[a, b] = s
    w = scratch[9:12]
    rotation_log(Rd, w)
    e6[3], e6[4], e6[5] = w[0], w[1], w[2]


@njit(cache=True)
def planar_fk_jacobian(lengths, pose_task, q, w, J, scratch):  # noqa: ANN001, ANN201
    """The planar arm (relative angles): task value ``w`` (2 or 3,) and Jacobian ``J``.

    ``scratch`` is a float array of at least ``2 n`` entries.
    """
    n = q.shape[0]
    s = 0.0
    x, y = 0.0, 0.0
    cx = scratch[0:n]
    cy = scratch[n : 2 * n]
    for i in range(n):
        s += q[i]
        cx[i] = lengths[i] * math.cos(s)
        cy[i] = lengths[i] * math.sin(s)
        x += cx[i]
        y += cy[i]
    sx, sy = 0.0, 0.0
    for i in range(n - 1, -1, -1):
        sx += cx[i]
        sy += cy[i]
        J[0, i] = -sy
        J[1, i] = sx
        if pose_task:
            J[2, i] = 1.0
    w[0], w[1] = x, y
    if pose_task:
        w[2] = s


@njit(cache=True)
def limit_and_solve(J, dw, limits, H, h_diag, f_ref, Lam, lam_bounds, G, h, dt, q0, q_prev, dq,  # noqa: ANN001, ANN201, PLR0913
                    lam, ws):  # fmt: skip
    """Bounds on ``dq`` (end-stops, velocity, acceleration), the criterion, rows; then LP2.

    ``limits`` is (6, n): q_min, q_max, qd_min, qd_max, qdd_min, qdd_max (inf when none);
    ``f_ref`` is (2, n): ``f`` and ``q_ref`` (NaN entries mean ``q_ref = q0`` there).
    The last step is ``q0 - q_prev``: pass ``q_prev = q0`` for a robot at rest.
    Returns ``(code, p, binding)`` as :func:`lpik.fast.kernels.lp2_core`, with the
    binding ``-2 - i`` when joint ``i``'s lower bound lies above its upper one.
    """
    m, n = J.shape
    r = G.shape[0]
    lower = ws[0:n]
    upper = ws[n : 2 * n]
    for i in range(n):
        lo = max(limits[0, i] - q0[i], limits[2, i] * dt)
        hi = min(limits[1, i] - q0[i], limits[3, i] * dt)
        last = q0[i] - q_prev[i]
        lower[i] = max(lo, last + limits[4, i] * dt * dt)
        upper[i] = min(hi, last + limits[5, i] * dt * dt)
    for i in range(n):  # a joint's bounds cross: no step is feasible (as lp2's crossed_label)
        if lower[i] > upper[i]:
            ws[3 * n + r] = 0.0
            return INFEASIBLE, 0.0, -2 - i
    c = ws[2 * n : 3 * n]
    for i in range(n):
        s = f_ref[0, i]
        for k in range(n):
            ref = f_ref[1, k]
            if not math.isnan(ref):  # NaN: q_ref defaults to q0 for this joint
                s += Lam[i, k] * (ref - q0[k])
        c[i] = s
    g = ws[3 * n : 3 * n + r]
    for j in range(r):
        s = h[j]
        for i in range(n):
            s -= G[j, i] * q0[i]
        g[j] = s
    return lp2_core(
        J, dw, H, h_diag, c, lower, upper, lam_bounds[0], lam_bounds[1], G, g, dq, lam,
        ws[3 * n + r :],
    )  # fmt: skip


@njit(cache=True)
def _bound_kind(k, upper, q0, q_prev, limits, dt):  # noqa: ANN001, ANN201
    """What sets joint ``k``'s bound on ``dq`` on one side: 0 end-stop, 1 velocity, 2 acceleration.

    The tightest, named as :meth:`lpik.problem.Problem.step_bounds` names it.
    """
    last = q0[k] - q_prev[k]
    if upper:
        stop, vel, acc = limits[1, k] - q0[k], limits[3, k] * dt, last + limits[5, k] * dt * dt
        kind = 2 if acc < vel else 1
        return 0 if stop <= min(vel, acc) else kind
    stop, vel, acc = limits[0, k] - q0[k], limits[2, k] * dt, last + limits[4, k] * dt * dt
    kind = 2 if acc > vel else 1
    return 0 if stop >= max(vel, acc) else kind


@njit(cache=True)
def binding_label_index(code, q0, q_prev, limits, dt, constraints):  # noqa: ANN001, ANN201
    """Where the binding limit ``code`` sits in a controller's table of labels.

    ``code >= 0`` is :mod:`lpik.fast.kernels`' binding code (``2 k + side``) and
    ``code <= -2`` marks joint ``-2 - code`` whose lower step bound lies above its
    upper one. The table holds, for each joint side (``code < 2 n``), three labels
    by what sets the bound: ``3 code`` end-stop, ``+ 1`` velocity limit, ``+ 2``
    acceleration limit; then the multipliers and rows (``code - 2 n`` after the
    ``6 n`` joint labels, ``constraints`` of them in all); then, per joint, the
    nine "lower / upper" pairs of a crossed joint.
    """
    n = q0.shape[0]
    if code <= -2:
        k = -2 - code
        lower = _bound_kind(k, False, q0, q_prev, limits, dt)
        upper = _bound_kind(k, True, q0, q_prev, limits, dt)
        return 6 * n + 2 * constraints + 9 * k + 3 * lower + upper
    if code >= 2 * n:
        return 4 * n + code
    return 3 * code + _bound_kind(code // 2, code % 2 == 1, q0, q_prev, limits, dt)


@njit(cache=True)
def clamp_command(dw, rows, v_max, w_max, dt):  # noqa: ANN001, ANN201
    """Scale ``dw`` down so that its linear part is <= ``v_max dt`` and angular <= ``w_max dt``.

    ``rows[k] < 3`` marks a linear row (x, y, z); others are angular.
    """
    lin, ang = 0.0, 0.0
    for k in range(dw.shape[0]):
        if rows[k] < 3:
            lin += dw[k] * dw[k]
        else:
            ang += dw[k] * dw[k]
    lin, ang = math.sqrt(lin), math.sqrt(ang)
    scale = 1.0
    if lin > v_max * dt:
        scale = min(scale, v_max * dt / lin)
    if ang > w_max * dt:
        scale = min(scale, w_max * dt / ang)
    for k in range(dw.shape[0]):
        dw[k] *= scale


# ---------------------------------------------------------------- the fused step's state buffer
#
# A controller keeps everything of a step in one float array, so that a step is one
# compiled call of four arguments (state, q0, q_prev, target):
#
#   [header (HEADER) | revolute flags (n) | task rows (m) | geometry | constants | out | ws]
#
# header: n, m, r, h_diag and the offsets of the geometry, constants, out and ws.
# geometry: a chain's joint origins (n, 4, 4), axes (n, 3) and tip (4, 4), or the
#   planar arm's link lengths (n,).
# constants: limits (6, n: q_min, q_max, qd_min, qd_max, qdd_min, qdd_max, inf when
#   none), H = M + Lambda (n, n), f and q_ref (2, n; NaN: q_ref = q0 there), Lambda
#   (n, n), multiplier bounds (2, m), rows G (r, n) and h (r,), [dt, v_max, w_max].
# out: [q (n) | dq (n) | lam (m) | task position (3) | dw (m) | p, label index, residual];
#   the label index is -1 when no limit binds (see binding_label_index).

#: Length of the state buffer's header.
HEADER = 8
#: Floats after the task command in ``out``: p, the binding label's index, the residual.
OUT_TAIL = 3
#: A step's outcome when q0, q_prev or the target has the wrong size or is not finite.
BAD_INPUT = 4


def out_size(n: int, m: int) -> int:
    """Length of a step's output block (see the layout above)."""
    return 2 * n + 2 * m + 3 + OUT_TAIL


def step_workspace_size(n: int, m: int, r: int) -> int:
    """Length of the float workspace :func:`chain_step` / :func:`planar_step` need."""
    return (
        16 + 16 + 6 * n + 6 + m * n + fk_scratch_size(n) + 12 + 3 * n + r + workspace_size(n, m, r)
    )


def pack_state(
    revolute: np.ndarray,
    rows: tuple[int, ...],
    h_diag: bool,
    geometry: tuple[np.ndarray, ...],
    constants: tuple[np.ndarray, ...],
) -> tuple[np.ndarray, int]:
    """The state buffer of a fused step (see the layout above) and the offset of ``out``.

    ``r`` is the number of rows of ``G`` (``constants[5]``).
    """
    n, m = len(revolute), len(rows)
    r = constants[5].shape[0]
    geo = np.concatenate([np.ravel(a) for a in geometry])
    const = np.concatenate([np.ravel(a) for a in constants])
    o_geo = HEADER + n + m
    o_const = o_geo + geo.size
    o_out = o_const + const.size
    o_ws = o_out + out_size(n, m)
    state = np.zeros(o_ws + step_workspace_size(n, m, r))
    state[:HEADER] = (n, m, r, float(h_diag), o_geo, o_const, o_out, o_ws)
    state[HEADER : HEADER + n] = revolute
    state[HEADER + n : o_geo] = rows
    state[o_geo:o_const] = geo
    state[o_const:o_out] = const
    return state, o_out


@njit(cache=True)
def _unpack(state, n, m, r, o):  # noqa: ANN001, ANN201
    """The constants (limits, criterion, rows, scalars) from ``state`` at offset ``o``."""
    limits = matrix(state, o, 6, n)
    o += 6 * n
    H = matrix(state, o, n, n)
    o += n * n
    f_ref = matrix(state, o, 2, n)
    o += 2 * n
    Lam = matrix(state, o, n, n)
    o += n * n
    lam_bounds = matrix(state, o, 2, m)
    o += 2 * m
    G = matrix(state, o, r, n)
    o += r * n
    h = state[o : o + r]
    o += r
    return limits, H, f_ref, Lam, lam_bounds, G, h, state[o : o + 3]


@njit(cache=True)
def _finite_joints(q0, q_prev, n):  # noqa: ANN001, ANN201
    """True when ``q0`` and ``q_prev`` both have ``n`` finite entries."""
    if q0.shape[0] != n or q_prev.shape[0] != n:
        return False
    for i in range(n):
        if not (math.isfinite(q0[i]) and math.isfinite(q_prev[i])):
            return False
    return True


@njit(cache=True)
def target_pose(target, T):  # noqa: ANN001, ANN201
    """The commanded pose ``T`` (4, 4) from xyz (3,), a rotation (3, 3) or a pose (4, 4).

    Returns False for any other shape or a value that is not finite.
    """
    shape = target.shape
    flat = np.lib.stride_tricks.as_strided(target, shape=(target.size,), strides=(8,))
    for k in range(flat.size):
        if not math.isfinite(flat[k]):
            return False
    for a in range(4):
        for b in range(4):
            T[a, b] = 1.0 if a == b else 0.0
    if shape == (3,):
        for a in range(3):
            T[a, 3] = flat[a]
    elif shape == (3, 3):
        for a in range(3):
            for b in range(3):
                T[a, b] = flat[3 * a + b]
    elif shape == (4, 4):
        for a in range(4):
            for b in range(4):
                T[a, b] = flat[4 * a + b]
    else:
        return False
    return True


@njit(cache=True)
def _finish(state, q0, q_prev, J, dw, out, ws):  # noqa: ANN001, ANN201
    """Limits and LP2, then ``q = q0 + dq``, ``p``, the binding label and the residual."""
    n, m, r = q0.shape[0], J.shape[0], int(state[2])
    limits, H, f_ref, Lam, lam_bounds, G, h, scalars = _unpack(state, n, m, r, int(state[5]))
    code, p, binding = limit_and_solve(
        J, dw, limits, H, state[3] != 0.0, f_ref, Lam, lam_bounds, G, h, scalars[0], q0, q_prev,
        out[n : 2 * n], out[2 * n : 2 * n + m], ws,
    )  # fmt: skip
    for i in range(n):
        out[i] = q0[i] + out[n + i]
    k = out.shape[0] - OUT_TAIL
    out[k] = p
    out[k + 1] = (
        -1 if binding == -1 else binding_label_index(binding, q0, q_prev, limits, scalars[0], m + r)
    )
    out[k + 2] = ws[3 * n + r]  # lp2_core leaves max |J dq - p dw| in its ws[0]
    return code


def chain_step(state, q0, q_prev, target):  # noqa: ANN001, ANN201
    """One fused LP2 control step of a serial chain: FK, Jacobian, command, limits, LP2.

    Call it compiled, through :func:`step_kernel`: for C-contiguous float64 arrays
    only; other arguments raise a ``TypeError`` (the caller converts them), so a
    step never compiles anew.

    Args:
        state: The controller's buffer (:func:`pack_state`); the step writes its
            ``out`` and workspace blocks.
        q0: Joint coordinates now, (n,).
        q_prev: Joint coordinates one period ago, (n,); ``q0`` for a robot at rest.
        target: Commanded xyz (3,), rotation (3, 3) or pose (4, 4).

    Returns:
        The outcome code of :mod:`lpik.fast.kernels`, or :data:`BAD_INPUT`.
    """
    n, m = int(state[0]), int(state[1])
    revolute = state[HEADER : HEADER + n]
    rows = state[HEADER + n : HEADER + n + m]
    o = int(state[4])
    origins = np.lib.stride_tricks.as_strided(state[o:], shape=(n, 4, 4), strides=(128, 32, 8))
    axes = matrix(state, o + 16 * n, n, 3)
    tip = matrix(state, o + 19 * n, 4, 4)
    scalars = state[int(state[6]) - 3 : int(state[6])]
    out = state[int(state[6]) : int(state[7])]
    ws = state[int(state[7]) :]
    goal = matrix(ws, 0, 4, 4)
    if not (_finite_joints(q0, q_prev, n) and target_pose(target, goal)):
        return BAD_INPUT
    o = 16
    T = matrix(ws, o, 4, 4)
    o += 16
    J6 = matrix(ws, o, 6, n)
    o += 6 * n
    e6 = ws[o : o + 6]
    o += 6
    J = matrix(ws, o, m, n)
    o += m * n
    chain_fk_jacobian(origins, axes, revolute, tip, q0, T, J6, ws[o:])
    o += fk_scratch_size(n)
    pose_error(T, goal, e6, ws[o:])
    o += 12
    dw = out[2 * n + m + 3 : 2 * n + 2 * m + 3]
    for k in range(m):
        row = int(rows[k])
        dw[k] = e6[row]
        for i in range(n):
            J[k, i] = J6[row, i]
    clamp_command(dw, rows, scalars[1], scalars[2], scalars[0])
    for a in range(3):
        out[2 * n + m + a] = T[a, 3]
    return _finish(state, q0, q_prev, J, dw, out, ws[o:])


def planar_step(state, q0, q_prev, target):  # noqa: ANN001, ANN201
    """One fused LP2 control step of the planar arm (see :func:`chain_step`).

    The geometry is the link lengths (n,); the task rows are ``[0, 1]`` or
    ``[0, 1, 3]`` (the tool angle counts as angular); ``target`` is (x, y[, angle]).
    """
    n, m = int(state[0]), int(state[1])
    rows = state[HEADER + n : HEADER + n + m]
    o = int(state[4])
    lengths = state[o : o + n]
    scalars = state[int(state[6]) - 3 : int(state[6])]
    out = state[int(state[6]) : int(state[7])]
    ws = state[int(state[7]) :]
    if not _finite_joints(q0, q_prev, n) or target.shape[0] != m:
        return BAD_INPUT
    for k in range(m):
        if not math.isfinite(target[k]):
            return BAD_INPUT
    w = ws[0:m]
    o = m
    J = matrix(ws, o, m, n)
    o += m * n
    planar_fk_jacobian(lengths, m == 3, q0, w, J, ws[o:])
    o += 2 * n
    dw = out[2 * n + m + 3 : 2 * n + 2 * m + 3]
    for k in range(m):
        dw[k] = target[k] - w[k]
    if m == 3:  # wrap the angle difference to (-pi, pi]
        dw[2] = -((-dw[2] + math.pi) % (2 * math.pi) - math.pi)
    clamp_command(dw, rows, scalars[1], scalars[2], scalars[0])
    out[2 * n + m], out[2 * n + m + 1], out[2 * n + m + 2] = w[0], w[1], 0.0
    return _finish(state, q0, q_prev, J, dw, out, ws[o:])


#: The fused steps and the only argument types they are compiled for.
_STEPS = {
    "chain": (
        chain_step,
        [
            "int64(float64[::1], float64[::1], float64[::1], float64[::1])",
            "int64(float64[::1], float64[::1], float64[::1], float64[:, ::1])",
        ],
    ),
    "planar": (planar_step, ["int64(float64[::1], float64[::1], float64[::1], float64[::1])"]),
}
_compiled_steps: dict = {}


def step_kernel(kind: str):  # noqa: ANN201 - a numba dispatcher
    """The compiled fused step of ``kind`` (``"chain"`` or ``"planar"``).

    Compiled on first use (or loaded from numba's disk cache), for the
    explicit signatures of :data:`_STEPS` only, so that a call with other
    types raises ``TypeError`` instead of compiling in the middle of a loop.
    """
    if kind not in _compiled_steps:
        func, signatures = _STEPS[kind]
        _compiled_steps[kind] = njit(signatures, cache=True)(func)
    return _compiled_steps[kind]


def loaded_step_kernel(kind: str):  # noqa: ANN201 - a numba dispatcher or None
    """The fused step of ``kind`` if :func:`step_kernel` has readied it in this process."""
    return _compiled_steps.get(kind)


# The same steps without explicit signatures, for the batch loops below. They
# compile for the batch's argument types, which are those of _STEPS, so they
# share their disk-cache entries with step_kernel's dispatchers.
_chain_step_any = njit(cache=True)(chain_step)
_planar_step_any = njit(cache=True)(planar_step)


@njit(cache=True)
def _copy_out(state, outs, b):  # noqa: ANN001, ANN201
    """Row ``b`` of ``outs`` = the ``out`` block a step left in ``state``."""
    o_out, o_ws = int(state[6]), int(state[7])
    for k in range(o_ws - o_out):
        outs[b, k] = state[o_out + k]


# chain_step_batch and planar_step_batch differ only in the step they call: one
# loop built by a factory (a closure) would not load from numba's disk cache.
@njit(cache=True, parallel=True)
def chain_step_batch(state, q0, q_prev, targets, outs, codes, chunks):  # noqa: ANN001, ANN201
    """:func:`chain_step` for every row of the batch, in parallel.

    ``q0`` and ``q_prev`` are (B, n), ``targets`` (B, 3), (B, 3, 3) or (B, 4, 4).
    The batch is cut into ``chunks`` parts; each works on its own copy of
    ``state``. Row ``b`` of ``outs`` (B, out_size) receives the step's ``out``
    block and ``codes[b]`` its outcome.
    """
    B = q0.shape[0]
    chunks = max(1, min(B, chunks))
    for chunk in prange(chunks):
        local = state.copy()
        for b in range(chunk * B // chunks, (chunk + 1) * B // chunks):
            codes[b] = _chain_step_any(local, q0[b], q_prev[b], targets[b])
            _copy_out(local, outs, b)


@njit(cache=True, parallel=True)
def planar_step_batch(state, q0, q_prev, targets, outs, codes, chunks):  # noqa: ANN001, ANN201
    """:func:`planar_step` for every row, in parallel (see :func:`chain_step_batch`)."""
    B = q0.shape[0]
    chunks = max(1, min(B, chunks))
    for chunk in prange(chunks):
        local = state.copy()
        for b in range(chunk * B // chunks, (chunk + 1) * B // chunks):
            codes[b] = _planar_step_any(local, q0[b], q_prev[b], targets[b])
            _copy_out(local, outs, b)


def step_batch_kernel(kind: str):  # noqa: ANN201 - a numba dispatcher
    """The parallel batch of fused steps of ``kind`` (``"chain"`` or ``"planar"``)."""
    return {"chain": chain_step_batch, "planar": planar_step_batch}[kind]
