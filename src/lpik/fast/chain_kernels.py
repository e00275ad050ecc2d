"""Compiled forward kinematics, Jacobian, command and one fused LP2 control step.

The kinematics follow :class:`lpik.robots.chain.SerialChain`: frame
``T_i = T_{i-1} @ origin_i @ motion_i(q_i)`` with ``motion_i`` a rotation about
(revolute) or a translation along (prismatic) the unit joint axis; the task
frame is ``T_n @ tip``. The Jacobian is world-aligned at the task point:
rows ``[v; omega]``. The orientation error is ``log(R_target R^T)`` in the
base frame, as in :mod:`lpik.robots.tasks`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from lpik.fast.kernels import lp2_core, workspace_size


@njit(cache=True)
def _axis_rotation(axis, angle, R):  # noqa: ANN001, ANN201
    """Rodrigues: rotation by ``angle`` about unit ``axis`` into ``R`` (3, 3)."""
    x, y, z = axis[0], axis[1], axis[2]
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    R[0, 0] = c + x * x * t
    R[0, 1] = x * y * t - z * s
    R[0, 2] = x * z * t + y * s
    R[1, 0] = y * x * t + z * s
    R[1, 1] = c + y * y * t
    R[1, 2] = y * z * t - x * s
    R[2, 0] = z * x * t - y * s
    R[2, 1] = z * y * t + x * s
    R[2, 2] = c + z * z * t


@njit(cache=True)
def _top_product(A, B, inner, cols, tmp, out):  # noqa: ANN001, ANN201
    """``out[:3, :cols] = A[:3, :inner] @ B[:inner, :cols]``; ``out`` may be ``A`` (via ``tmp``)."""
    for a in range(3):
        for b in range(cols):
            s = 0.0
            for k in range(inner):
                s += A[a, k] * B[k, b]
            tmp[a, b] = s
    for a in range(3):
        for b in range(cols):
            out[a, b] = tmp[a, b]


@njit(cache=True)
def fk_scratch_size(n):  # noqa: ANN001, ANN201
    """Length of the scratch array :func:`chain_fk_jacobian` needs for ``n`` joints."""
    return 41 + 6 * n


@njit(cache=True)
def chain_fk_jacobian(origins, axes, revolute, tip, q, T, J6, scratch):  # noqa: ANN001, ANN201
    """Task-frame pose ``T`` (4, 4) and world-aligned Jacobian ``J6`` (6, n) at ``q``.

    ``scratch`` is a float array of at least :func:`fk_scratch_size` entries.
    """
    n = q.shape[0]
    cur = scratch[0:16].reshape((4, 4))
    tmp = scratch[16:32].reshape((4, 4))
    R = scratch[32:41].reshape((3, 3))
    joint_pos = scratch[41 : 41 + 3 * n].reshape((n, 3))
    joint_axis = scratch[41 + 3 * n : 41 + 6 * n].reshape((n, 3))
    for a in range(4):
        for b in range(4):
            cur[a, b] = 1.0 if a == b else 0.0
    for i in range(n):
        _top_product(cur, origins[i], 4, 4, tmp, cur)  # cur = cur @ origin_i
        for a in range(3):
            joint_pos[i, a] = cur[a, 3]
            s = 0.0
            for k in range(3):
                s += cur[a, k] * axes[i, k]
            joint_axis[i, a] = s
        if revolute[i]:
            _axis_rotation(axes[i], q[i], R)
            _top_product(cur, R, 3, 3, tmp, cur)  # turn about the joint axis
        else:
            for a in range(3):
                cur[a, 3] += joint_axis[i, a] * q[i]
    _top_product(cur, tip, 4, 4, tmp, T)
    T[3, 0], T[3, 1], T[3, 2], T[3, 3] = 0.0, 0.0, 0.0, 1.0
    for i in range(n):
        zx, zy, zz = joint_axis[i, 0], joint_axis[i, 1], joint_axis[i, 2]
        if revolute[i]:
            rx = T[0, 3] - joint_pos[i, 0]
            ry = T[1, 3] - joint_pos[i, 1]
            rz = T[2, 3] - joint_pos[i, 2]
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
    Rd = scratch[0:9].reshape((3, 3))
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
def limit_and_solve(
    J,
    dw,
    limits,
    H,
    h_diag,
    f_ref,
    Lam,
    lam_bounds,
    G,
    h,
    dt,
    has_prev,  # noqa: ANN001, ANN201, PLR0913
    q0,
    q_prev,
    dq,
    lam,
    ws,
):
    """Bounds on ``dq`` (end-stops, velocity, acceleration), the criterion, rows; then LP2.

    ``limits`` is (6, n): q_min, q_max, qd_min, qd_max, qdd_min, qdd_max (inf when none);
    ``f_ref`` is (2, n): ``f`` and ``q_ref`` (NaN entries mean ``q_ref = q0`` there).
    """
    m, n = J.shape
    r = G.shape[0]
    lower = ws[0:n]
    upper = ws[n : 2 * n]
    for i in range(n):
        lo = max(limits[0, i] - q0[i], limits[2, i] * dt)
        hi = min(limits[1, i] - q0[i], limits[3, i] * dt)
        last = q0[i] - q_prev[i] if has_prev else 0.0
        lower[i] = max(lo, last + limits[4, i] * dt * dt)
        upper[i] = min(hi, last + limits[5, i] * dt * dt)
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


def pack_constants(origins, axes, tip, limits, H, f_ref, Lam, lam_bounds, G, h, scalars):  # noqa: ANN001, ANN201
    """One float buffer of everything a step of a chain keeps constant (see :func:`chain_step`)."""
    return np.concatenate([np.ravel(a) for a in (origins, axes, tip, limits, H, f_ref, Lam,
                                                  lam_bounds, G, h, scalars)])  # fmt: skip


def step_workspace_size(n, m, r):  # noqa: ANN001, ANN201
    """Length of the float workspace :func:`chain_step` / :func:`planar_step` need."""
    return 16 + 6 * n + 6 + m * n + fk_scratch_size(n) + 12 + 3 * n + r + workspace_size(n, m, r)


#: Layout of a step's output buffer (``n`` joints, ``m`` task rows):
#: ``[q (n) | dq (n) | lam (m) | task position (3) | dw (m) | code, p, binding, residual]``.
OUT_TAIL = 4


@njit(cache=True)
def _unpack(fbuf, n, m, r, o):  # noqa: ANN001, ANN201
    """The criterion, limits, rows and scalars from ``fbuf`` starting at offset ``o``."""
    limits = fbuf[o : o + 6 * n].reshape((6, n))
    o += 6 * n
    H = fbuf[o : o + n * n].reshape((n, n))
    o += n * n
    f_ref = fbuf[o : o + 2 * n].reshape((2, n))
    o += 2 * n
    Lam = fbuf[o : o + n * n].reshape((n, n))
    o += n * n
    lam_bounds = fbuf[o : o + 2 * m].reshape((2, m))
    o += 2 * m
    G = fbuf[o : o + r * n].reshape((r, n))
    o += r * n
    h = fbuf[o : o + r]
    o += r
    return limits, H, f_ref, Lam, lam_bounds, G, h, fbuf[o : o + 4]


@njit(cache=True)
def _finish(q0, J, dw, limits, H, h_diag, f_ref, Lam, lam_bounds, G, h, scalars, q_prev, out,  # noqa: ANN001, ANN201, PLR0913
            ws):  # fmt: skip
    """Limits and LP2, then ``q = q0 + dq``, the outcome and the residual into ``out``."""
    n = q0.shape[0]
    m = J.shape[0]
    r = G.shape[0]
    code, p, binding = limit_and_solve(
        J, dw, limits, H, h_diag, f_ref, Lam, lam_bounds, G, h, scalars[0], scalars[3] > 0.5,
        q0, q_prev, out[n : 2 * n], out[2 * n : 2 * n + m], ws,
    )  # fmt: skip
    for i in range(n):
        out[i] = q0[i] + out[n + i]
    k = out.shape[0] - OUT_TAIL
    out[k] = code
    out[k + 1] = p
    out[k + 2] = binding
    out[k + 3] = ws[3 * n + r]  # lp2_core leaves max |J dq - p dw| in its ws[0]


@njit(cache=True)
def chain_step(fbuf, ibuf, q0, q_prev, target, out, ws):  # noqa: ANN001, ANN201
    """One fused LP2 control step of a serial chain: FK, Jacobian, command, limits, LP2.

    Args:
        fbuf: The constants, packed by :func:`pack_constants`: joint origins (n, 4, 4),
            axes (n, 3), tip (4, 4), limits (6, n: q_min, q_max, qd_min, qd_max,
            qdd_min, qdd_max, inf when none), ``H = M + Lambda`` (n, n), ``f`` and
            ``q_ref`` (2, n; NaN: q_ref = q0 there), ``Lambda`` (n, n), multiplier
            bounds (2, m), rows ``G`` (r, n) and ``h`` (r,), ``[dt, v_max, w_max, has_prev]``.
        ibuf: ``[n, m, r, h_diag, revolute (n), task rows (m) among x, y, z, rx, ry, rz]``.
        q0: Joint coordinates now, (n,).
        q_prev: Joint coordinates one period ago, (n,).
        target: Commanded pose (4, 4).
        out: Output buffer, see :data:`OUT_TAIL` for the layout.
        ws: Float workspace of :func:`step_workspace_size` entries.
    """
    n, m, r = ibuf[0], ibuf[1], ibuf[2]
    h_diag = ibuf[3] != 0
    revolute = ibuf[4 : 4 + n]
    rows = ibuf[4 + n : 4 + n + m]
    origins = fbuf[0 : 16 * n].reshape((n, 4, 4))
    axes = fbuf[16 * n : 19 * n].reshape((n, 3))
    tip = fbuf[19 * n : 19 * n + 16].reshape((4, 4))
    limits, H, f_ref, Lam, lam_bounds, G, h, scalars = _unpack(fbuf, n, m, r, 19 * n + 16)
    o = 0
    T = ws[o : o + 16].reshape((4, 4))
    o += 16
    J6 = ws[o : o + 6 * n].reshape((6, n))
    o += 6 * n
    e6 = ws[o : o + 6]
    o += 6
    J = ws[o : o + m * n].reshape((m, n))
    o += m * n
    chain_fk_jacobian(origins, axes, revolute, tip, q0, T, J6, ws[o:])
    o += fk_scratch_size(n)
    pose_error(T, target, e6, ws[o:])
    o += 12
    dw = out[2 * n + m + 3 : 2 * n + 2 * m + 3]
    for k in range(m):
        dw[k] = e6[rows[k]]
        for i in range(n):
            J[k, i] = J6[rows[k], i]
    clamp_command(dw, rows, scalars[1], scalars[2], scalars[0])
    for a in range(3):
        out[2 * n + m + a] = T[a, 3]
    _finish(q0, J, dw, limits, H, h_diag, f_ref, Lam, lam_bounds, G, h, scalars, q_prev, out,
            ws[o:])  # fmt: skip


@njit(cache=True)
def planar_step(fbuf, ibuf, q0, q_prev, target, out, ws):  # noqa: ANN001, ANN201
    """One fused LP2 control step of the planar arm (see :func:`chain_step`).

    ``fbuf`` starts with the link lengths (n,) instead of the chain, then as
    :func:`chain_step`; ``ibuf = [n, m, r, h_diag, task rows (m)]`` with rows
    ``[0, 1]`` or ``[0, 1, 3]`` (the tool angle counts as angular); ``target``
    is (x, y[, angle]).
    """
    n, m, r = ibuf[0], ibuf[1], ibuf[2]
    h_diag = ibuf[3] != 0
    rows = ibuf[4 : 4 + m]
    lengths = fbuf[0:n]
    limits, H, f_ref, Lam, lam_bounds, G, h, scalars = _unpack(fbuf, n, m, r, n)
    o = 0
    w = ws[o : o + m]
    o += m
    J = ws[o : o + m * n].reshape((m, n))
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
    _finish(q0, J, dw, limits, H, h_diag, f_ref, Lam, lam_bounds, G, h, scalars, q_prev, out,
            ws[o:])  # fmt: skip
