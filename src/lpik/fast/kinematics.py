"""Compiled kinematics of a serial chain: forward kinematics, Jacobian, pose error, SO(3).

The kinematics follow :class:`lpik.robots.chain.SerialChain` (its
:meth:`~lpik.robots.chain.SerialChain.arrays`): frame
``T_i = T_{i-1} @ origin_i @ motion_i(q_i)`` with ``motion_i`` a rotation
about (revolute) or a translation along (prismatic) the unit joint axis; the
task frame is ``T_n @ tip``. The Jacobian is world-aligned at the task point:
rows ``[v; omega]``. The orientation error is ``log(R_target R^T)`` in the
base frame, as in :mod:`lpik.robots.tasks`; together with the position error
it is the commanded displacement ``dw`` of eq. 2.

Rotations inside a kernel are held row-major in 9-tuples, so that the running
frame stays in registers.
"""

from __future__ import annotations

import math

from numba import float64, njit

from lpik.fast.views import flat, matrix
from lpik.robots.rotations import rotation_defect as _rotation_defect
from lpik.tolerances import MAX_MAGNITUDE, ROTATION_TOL


@njit(cache=True)
def _mul33(a, b):
    """``a @ b`` for 3x3 matrices held row-major in 9-tuples."""
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
def _mul3(a, x, y, z):
    """``a @ (x, y, z)`` for a 3x3 matrix held row-major in a 9-tuple."""
    return (
        a[0] * x + a[1] * y + a[2] * z,
        a[3] * x + a[4] * y + a[5] * z,
        a[6] * x + a[7] * y + a[8] * z,
    )


@njit(cache=True)
def _axis_rotation(axis, angle):
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
def _rotation(A):
    """The top-left 3x3 block of ``A``, row-major in a 9-tuple."""
    return (A[0, 0], A[0, 1], A[0, 2], A[1, 0], A[1, 1], A[1, 2], A[2, 0], A[2, 1], A[2, 2])


#: The one signature :func:`chain_fk_jacobian` is compiled for (when the module is
#: imported): its callers pass views of a state buffer and C-ordered arrays alike.
_FK_SIGNATURE = (float64[:, :, :], float64[:, :], float64[::1], float64[:, :], float64[::1],
                 float64[:, :], float64[:, :], float64[:, :, :])  # fmt: skip


@njit(_FK_SIGNATURE, cache=True)
def chain_fk_jacobian(origins, axes, revolute, tip, q, T, J6, joints):
    """Task-frame pose ``T`` (4, 4) and world-aligned Jacobian ``J6`` (6, n) at ``q``.

    Args:
        origins: Each joint's fixed transform from the previous frame, (n, 4, 4).
        axes: Unit joint axes in the joint frames, (n, 3).
        revolute: Nonzero for a revolute joint, zero for a prismatic one, (n,).
        tip: The task frame in the last joint's frame, (4, 4).
        q: Joint coordinates, (n,).
        T: Output task-frame pose, (4, 4).
        J6: Output Jacobian ``[v; omega]``, (6, n).
        joints: Scratch, (2, n, 3): each joint's position and world axis.
    """
    n = q.shape[0]
    R = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    px, py, pz = 0.0, 0.0, 0.0
    for i in range(n):
        origin = origins[i]  # frame = frame @ origin_i
        dx, dy, dz = _mul3(R, origin[0, 3], origin[1, 3], origin[2, 3])
        px, py, pz = px + dx, py + dy, pz + dz
        R = _mul33(R, _rotation(origin))
        ax, ay, az = _mul3(R, axes[i, 0], axes[i, 1], axes[i, 2])
        joints[0, i, 0], joints[0, i, 1], joints[0, i, 2] = px, py, pz
        joints[1, i, 0], joints[1, i, 1], joints[1, i, 2] = ax, ay, az
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
        zx, zy, zz = joints[1, i, 0], joints[1, i, 1], joints[1, i, 2]
        if revolute[i]:
            rx, ry, rz = px - joints[0, i, 0], py - joints[0, i, 1], pz - joints[0, i, 2]
            J6[0, i] = zy * rz - zz * ry
            J6[1, i] = zz * rx - zx * rz
            J6[2, i] = zx * ry - zy * rx
            J6[3, i], J6[4, i], J6[5, i] = zx, zy, zz
        else:
            J6[0, i], J6[1, i], J6[2, i] = zx, zy, zz
            J6[3, i], J6[4, i], J6[5, i] = 0.0, 0.0, 0.0


@njit(cache=True)
def rotation_log(R, out):
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


#: Floats of scratch :func:`pose_error` needs.
POSE_ERROR_SCRATCH = 12


@njit(cache=True)
def pose_error(T, target, e6, scratch):
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


#: :func:`lpik.robots.rotations.rotation_defect`, compiled.
rotation_defect = njit(cache=True)(_rotation_defect)


@njit(cache=True)
def target_pose(target, T):
    """The commanded pose ``T`` (4, 4) from xyz (3,), a rotation (3, 3) or a pose (4, 4).

    Returns False for any other shape, a value that is not finite or larger in size
    than :data:`~lpik.tolerances.MAX_MAGNITUDE`, or a rotation part farther from a
    rotation than :data:`~lpik.tolerances.ROTATION_TOL`
    (:func:`lpik.robots.rotations.rotation_defect`, compiled here): the tests of
    :func:`lpik.command.checked_target`, which names what is wrong.
    """
    shape = target.shape
    values = flat(target)
    for k in range(values.size):
        if not (math.isfinite(values[k]) and abs(values[k]) <= MAX_MAGNITUDE):
            return False
    for a in range(4):
        for b in range(4):
            T[a, b] = 1.0 if a == b else 0.0
    if shape == (3,):
        for a in range(3):
            T[a, 3] = values[a]
    elif shape == (3, 3):
        for a in range(3):
            for b in range(3):
                T[a, b] = values[3 * a + b]
    elif shape == (4, 4):
        for a in range(4):
            for b in range(4):
                T[a, b] = values[4 * a + b]
    else:
        return False
    # a rotation part that is no rotation: the caller names it (as the numpy path does)
    return shape == (3,) or rotation_defect(T) <= ROTATION_TOL
