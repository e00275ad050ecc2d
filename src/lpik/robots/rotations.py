"""Rotations and rigid transforms used by the 3-D models.

Conventions: rotation matrices act on column vectors, homogeneous transforms
are 4 x 4 with the rotation top left and the translation [m] in the last
column. Roll-pitch-yaw follows URDF: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
Rotation vectors (the log map of SO(3)) are axis times angle [rad], with the
angle in [0, pi].
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from lpik.tolerances import ROTATION_TOL
from lpik.types import FloatArray

# Below this angle [rad] the log map uses its Taylor series.
_SMALL_ANGLE = 1e-6
# Above this angle [rad] the log map takes the axis from the symmetric part of R,
# where sin(theta) is too small to divide by.
_LARGE_ANGLE = 2.5


def skew(v: ArrayLike) -> FloatArray:
    """Cross-product matrix [v]x with ``skew(v) @ w == cross(v, w)``, shape (3, 3)."""
    x, y, z = np.asarray(v, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rpy_to_matrix(rpy: ArrayLike) -> FloatArray:
    """Rotation matrix of URDF roll-pitch-yaw angles.

    Args:
        rpy: Roll, pitch, yaw about the fixed x, y, z axes [rad].

    Returns:
        ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``, shape (3, 3).
    """
    r, p, y = (float(a) for a in np.asarray(rpy, dtype=float).reshape(3))
    cr, sr = math.cos(r), math.sin(r)
    cp, sp = math.cos(p), math.sin(p)
    cy, sy = math.cos(y), math.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def transform(xyz: ArrayLike = (0.0, 0.0, 0.0), rpy: ArrayLike = (0.0, 0.0, 0.0)) -> FloatArray:
    """Homogeneous transform of a translation and URDF roll-pitch-yaw angles.

    Args:
        xyz: Translation [m].
        rpy: Roll, pitch, yaw [rad].

    Returns:
        The 4 x 4 transform.
    """
    out = np.eye(4)
    out[:3, :3] = rpy_to_matrix(rpy)
    out[:3, 3] = np.asarray(xyz, dtype=float).reshape(3)
    return out


def as_transform(value: ArrayLike | None, what: str = "tool") -> FloatArray:
    """Read a rigid offset given as a transform, a translation, or xyz + rpy.

    Args:
        value: None (identity), a 4 x 4 homogeneous transform, a translation
            (3,) [m], or a translation followed by roll-pitch-yaw (6,) [m, rad].
        what: Name used in error messages.

    Returns:
        The 4 x 4 transform.

    Raises:
        ValueError: If the value has another shape, is not finite, or its
            rotation part is not a rotation.
    """
    if value is None:
        return np.eye(4)
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{what}: values must be finite, got {arr.tolist()}")
    if arr.shape == (3,):
        return transform(arr)
    if arr.shape == (6,):
        return transform(arr[:3], arr[3:])
    if arr.shape == (4, 4):
        rot = arr[:3, :3]
        if (
            not np.allclose(rot.T @ rot, np.eye(3), atol=1e-9)
            or np.linalg.det(rot) <= 0
            or not np.allclose(arr[3], (0.0, 0.0, 0.0, 1.0))
        ):
            raise ValueError(f"{what}: the 4 x 4 matrix is not a rigid transform")
        return arr.copy()
    raise ValueError(
        f"{what}: expected a 4 x 4 transform, xyz (3,) or xyz + rpy (6,), got shape {arr.shape}"
    )


def exp_so3(w: ArrayLike) -> FloatArray:
    """Rotation matrix of a rotation vector (Rodrigues' formula).

    Args:
        w: Rotation vector, axis times angle [rad], shape (3,).

    Returns:
        The rotation matrix, shape (3, 3).
    """
    w = np.asarray(w, dtype=float).reshape(3)
    theta = float(np.linalg.norm(w))
    k = skew(w)
    if theta < _SMALL_ANGLE:
        return np.eye(3) + k + 0.5 * (k @ k)
    return (
        np.eye(3) + (math.sin(theta) / theta) * k + ((1.0 - math.cos(theta)) / theta**2) * (k @ k)
    )


def log_so3(rot: ArrayLike) -> FloatArray:
    """Rotation vector of a rotation matrix (the log map of SO(3)).

    Accurate over the whole range, including angles near 0 and near pi.

    Args:
        rot: Rotation matrix, shape (3, 3).

    Returns:
        Axis times angle [rad], angle in [0, pi], shape (3,).
    """
    r = np.asarray(rot, dtype=float)
    vee = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    cos_theta = min(1.0, max(-1.0, 0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1.0)))
    sin_theta = 0.5 * float(np.linalg.norm(vee))
    theta = math.atan2(sin_theta, cos_theta)  # accurate at both ends, unlike acos
    if theta < _SMALL_ANGLE:
        return (0.5 + theta * theta / 12.0) * vee
    if theta < _LARGE_ANGLE:
        return (theta / (2.0 * sin_theta)) * vee
    # (R + R^T) / 2 = cos(theta) I + (1 - cos(theta)) n n^T: take n from its
    # largest diagonal entry, and the sign of n from the antisymmetric part.
    nnt = (0.5 * (r + r.T) - cos_theta * np.eye(3)) / (1.0 - cos_theta)
    k = int(np.argmax(np.diag(nnt)))
    axis = nnt[:, k] / math.sqrt(nnt[k, k])
    if float(axis @ vee) < 0.0:
        axis = -axis
    return theta * axis / float(np.linalg.norm(axis))


def left_jacobian_inverse(w: ArrayLike) -> FloatArray:
    """Inverse of the left Jacobian of SO(3) at the rotation vector ``w``.

    If ``R(t) = exp(w(t)) R0`` turns with world angular velocity ``omega``,
    then ``dw/dt = left_jacobian_inverse(w) @ omega``.

    Args:
        w: Rotation vector [rad], angle below pi, shape (3,).

    Returns:
        The 3 x 3 matrix ``I - [w]x / 2 + c [w]x^2`` with
        ``c = 1 / theta^2 - (1 + cos theta) / (2 theta sin theta)``.
    """
    w = np.asarray(w, dtype=float).reshape(3)
    theta = float(np.linalg.norm(w))
    k = skew(w)
    if theta < 1e-4:
        c = 1.0 / 12.0 + theta * theta / 720.0
    else:
        c = 1.0 / theta**2 - (1.0 + math.cos(theta)) / (2.0 * theta * math.sin(theta))
    return np.eye(3) - 0.5 * k + c * (k @ k)


def rotation_defect(t: FloatArray) -> float:
    """How far a rotation (3, 3), or a pose's (4, 4) rotation part, is from a rotation.

    Written in plain loops so that the compiled controller compiles this very
    function (:func:`lpik.fast.kinematics.rotation_defect`).

    Args:
        t: A float array of shape (3, 3) or (4, 4), finite.

    Returns:
        The largest of ``|R^T R - I|`` and, for a pose, of its bottom row's
        distance from (0, 0, 0, 1); ``inf`` when ``det(R) <= 0`` (a reflection,
        or no rotation at all) or an entry is NaN.
    """
    worst = 0.0
    for i in range(3):
        for j in range(3):
            s = t[0, i] * t[0, j] + t[1, i] * t[1, j] + t[2, i] * t[2, j]
            if i == j:
                s -= 1.0
            s = abs(s)
            if s != s:
                return math.inf
            worst = max(worst, s)
    det = (
        t[0, 0] * (t[1, 1] * t[2, 2] - t[1, 2] * t[2, 1])
        - t[0, 1] * (t[1, 0] * t[2, 2] - t[1, 2] * t[2, 0])
        + t[0, 2] * (t[1, 0] * t[2, 1] - t[1, 1] * t[2, 0])
    )
    if not det > 0.0:
        return math.inf
    if t.shape[0] == 4:
        for j in range(4):
            d = abs(t[3, j] - (1.0 if j == 3 else 0.0))
            if d != d:
                return math.inf
            worst = max(worst, d)
    return worst


def rotation_problem(t: FloatArray) -> str | None:
    """What keeps a finite (3, 3) or (4, 4) array from being a rotation or a pose, or ``None``.

    Accepted within :data:`lpik.tolerances.ROTATION_TOL` (see :func:`rotation_defect`).
    """
    if rotation_defect(t) <= ROTATION_TOL:
        return None
    r = np.asarray(t, dtype=float)[:3, :3]
    det = float(np.linalg.det(r))
    if not det > 0.0:
        return f"its rotation part has det {det:.3g}, not a rotation (a reflection or singular)"
    gram = float(np.abs(r.T @ r - np.eye(3)).max())
    if gram > ROTATION_TOL:
        return (
            f"its rotation part is not orthonormal: max |R^T R - I| = {gram:.3g} "
            f"> {ROTATION_TOL:g} (ROTATION_TOL)"
        )
    row = np.asarray(t, dtype=float)[3]
    return f"a pose's bottom row must be (0, 0, 0, 1), got {tuple(float(v) for v in row)}"


def check_rotation(name: str, t: FloatArray) -> None:
    """Raise naming ``name`` unless ``t`` (finite, (3, 3) or (4, 4)) is a rotation or a pose.

    Raises:
        ValueError: ``"<name>: <what is wrong>"``, as :func:`rotation_problem` words it.
    """
    problem = rotation_problem(t)
    if problem is not None:
        raise ValueError(f"{name}: {problem}")


def rotation_defects(stack: FloatArray) -> FloatArray:
    """:func:`rotation_defect` of every matrix of a stack (B, 3, 3) or (B, 4, 4), at once."""
    r = stack[:, :3, :3]
    gram = np.abs(np.einsum("bki,bkj->bij", r, r) - np.eye(3)).max(axis=(1, 2))
    if stack.shape[1] == 4:
        bottom = np.abs(stack[:, 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=1)
        gram = np.maximum(gram, bottom)
    det = np.linalg.det(r)
    return np.where((det > 0.0) & ~np.isnan(gram), gram, np.inf)
