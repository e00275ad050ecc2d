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

from lpik.fast.kernels import lp2_core


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
def chain_fk_jacobian(origins, axes, revolute, tip, q, T, J6):  # noqa: ANN001, ANN201
    """Task-frame pose ``T`` (4, 4) and world-aligned Jacobian ``J6`` (6, n) at ``q``."""
    n = q.shape[0]
    cur = np.eye(4)
    tmp = np.empty((4, 4))
    R = np.empty((3, 3))
    joint_pos = np.empty((n, 3))
    joint_axis = np.empty((n, 3))
    for i in range(n):
        # cur = cur @ origin_i
        for a in range(3):
            for b in range(4):
                s = 0.0
                for k in range(4):
                    s += cur[a, k] * origins[i, k, b]
                tmp[a, b] = s
        for a in range(3):
            for b in range(4):
                cur[a, b] = tmp[a, b]
        for a in range(3):
            joint_pos[i, a] = cur[a, 3]
            s = 0.0
            for k in range(3):
                s += cur[a, k] * axes[i, k]
            joint_axis[i, a] = s
        if revolute[i]:
            _axis_rotation(axes[i], q[i], R)
            for a in range(3):
                for b in range(3):
                    s = 0.0
                    for k in range(3):
                        s += cur[a, k] * R[k, b]
                    tmp[a, b] = s
            for a in range(3):
                for b in range(3):
                    cur[a, b] = tmp[a, b]
        else:
            for a in range(3):
                cur[a, 3] += joint_axis[i, a] * q[i]
    for a in range(3):
        for b in range(4):
            s = 0.0
            for k in range(4):
                s += cur[a, k] * tip[k, b]
            T[a, b] = s
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
def pose_error(T, target, e6):  # noqa: ANN001, ANN201
    """``[p_target - p; log(R_target R^T)]`` into ``e6`` (6,)."""
    for a in range(3):
        e6[a] = target[a, 3] - T[a, 3]
    Rd = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            s = 0.0
            for k in range(3):
                s += target[a, k] * T[b, k]
            Rd[a, b] = s
    w = np.empty(3)
    rotation_log(Rd, w)
    e6[3], e6[4], e6[5] = w[0], w[1], w[2]


@njit(cache=True)
def planar_fk_jacobian(lengths, pose_task, q, w, J):  # noqa: ANN001, ANN201
    """The planar arm (relative angles): task value ``w`` (2 or 3,) and Jacobian ``J``."""
    n = q.shape[0]
    s = 0.0
    x, y = 0.0, 0.0
    cx = np.empty(n)
    cy = np.empty(n)
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
    lower = np.empty(n)
    upper = np.empty(n)
    for i in range(n):
        lo = max(limits[0, i] - q0[i], limits[2, i] * dt)
        hi = min(limits[1, i] - q0[i], limits[3, i] * dt)
        last = q0[i] - q_prev[i] if has_prev else 0.0
        lower[i] = max(lo, last + limits[4, i] * dt * dt)
        upper[i] = min(hi, last + limits[5, i] * dt * dt)
    c = np.empty(n)
    for i in range(n):
        s = f_ref[0, i]
        for k in range(n):
            ref = f_ref[1, k]
            if not math.isnan(ref):  # NaN: q_ref defaults to q0 for this joint
                s += Lam[i, k] * (ref - q0[k])
        c[i] = s
    g = np.empty(r)
    for j in range(r):
        s = h[j]
        for i in range(n):
            s -= G[j, i] * q0[i]
        g[j] = s
    return lp2_core(
        J, dw, H, h_diag, c, lower, upper, lam_bounds[0], lam_bounds[1], G, g, dq, lam, ws
    )


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


@njit(cache=True)
def chain_step(
    origins,
    axes,
    revolute,
    tip,
    rows,
    limits,
    H,
    h_diag,
    f_ref,
    Lam,  # noqa: ANN001, ANN201, PLR0913
    lam_bounds,
    G,
    h,
    scalars,
    q0,
    q_prev,
    target,
    out,
    ws,
):
    """One fused LP2 control step of a serial chain: FK, Jacobian, command, limits, LP2.

    ``scalars = [dt, v_max, w_max, has_prev]``; ``target`` is the commanded (4, 4)
    pose; ``rows`` the kept task rows among ``[x, y, z, rx, ry, rz]``. ``out``
    (length ``n + 2 m + 3``) receives ``dq``, ``lam``, the task position and the
    clamped ``dw``. Returns ``(code, p, binding)`` as :func:`lp2_core`.
    """
    n = q0.shape[0]
    m = rows.shape[0]
    T = np.empty((4, 4))
    J6 = np.empty((6, n))
    chain_fk_jacobian(origins, axes, revolute, tip, q0, T, J6)
    e6 = np.empty(6)
    pose_error(T, target, e6)
    J = np.empty((m, n))
    dw = out[n + m + 3 : n + 2 * m + 3]
    for k in range(m):
        dw[k] = e6[rows[k]]
        for i in range(n):
            J[k, i] = J6[rows[k], i]
    clamp_command(dw, rows, scalars[1], scalars[2], scalars[0])
    for a in range(3):
        out[n + m + a] = T[a, 3]
    return limit_and_solve(
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
        scalars[0],
        scalars[3] > 0.5,
        q0,
        q_prev,
        out[:n],
        out[n : n + m],
        ws,
    )


@njit(cache=True)
def planar_step(
    lengths,
    rows,
    limits,
    H,
    h_diag,
    f_ref,
    Lam,
    lam_bounds,
    G,
    h,
    scalars,  # noqa: ANN001, ANN201, PLR0913
    q0,
    q_prev,
    target,
    out,
    ws,
):
    """One fused LP2 control step of the planar arm (see :func:`chain_step`).

    ``target`` is the commanded task value (x, y[, angle]); ``rows`` is
    ``[0, 1]`` or ``[0, 1, 3]`` (the tool angle counts as an angular row).
    """
    n = q0.shape[0]
    m = rows.shape[0]
    pose_task = m == 3
    w = np.empty(m)
    J = np.empty((m, n))
    planar_fk_jacobian(lengths, pose_task, q0, w, J)
    dw = out[n + m + 3 : n + 2 * m + 3]
    for k in range(m):
        dw[k] = target[k] - w[k]
    if pose_task:  # wrap the angle difference to (-pi, pi]
        dw[2] = -((-dw[2] + math.pi) % (2 * math.pi) - math.pi)
    clamp_command(dw, rows, scalars[1], scalars[2], scalars[0])
    out[n + m], out[n + m + 1], out[n + m + 2] = w[0], w[1], 0.0
    return limit_and_solve(
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
        scalars[0],
        scalars[3] > 0.5,
        q0,
        q_prev,
        out[:n],
        out[n : n + m],
        ws,
    )
