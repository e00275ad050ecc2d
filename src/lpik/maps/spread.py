"""Evenly spread tool orientations and unit motions (twists) of a map.

A map asks, for each cell, tool orientation and direction, what share ``p`` of
one commanded step the arm can follow (eq. 10). The orientations and
directions are fixed point sets, the same for every cell:

- **orientations** of a task with all three rotation rows: ``N`` rotations
  spread evenly over SO(3) by a super-Fibonacci spiral (Alexa, *Super-Fibonacci
  spirals*, CVPR 2022); with ``N = 1`` the tool orientation of the arm's home
  configuration. A planar task with the tool angle (rows ``x y rz``): ``N``
  angles ``2 pi k / N`` about z. A task without rotation rows has one
  orientation, the identity (it is not commanded).
- **directions**: unit twists ``(vx, vy, vz, wx, wy, wz)`` in the base frame at
  the tool point, over the task's rows only. A task with translation and
  rotation rows gets ``ceil(K / 2)`` translations and ``floor(K / 2)``
  rotations, each set spread evenly over the unit sphere of its rows (three
  rows: a Fibonacci sphere; two: ``K`` angles around the circle; one: ``+``
  and ``-`` in turn). Translation and rotation are never mixed in one
  direction: a metre and a radian have no common unit.
"""

from __future__ import annotations

import math

import numpy as np

from lpik.types import FloatArray

#: The six rows of a twist, in the order of ``direction_twist``'s last axis.
TWIST_ROWS = ("x", "y", "z", "rx", "ry", "rz")
#: Their names as the map's coordinate labels: (vx, vy, vz, wx, wy, wz).
TWIST_LABELS = ("vx", "vy", "vz", "wx", "wy", "wz")
#: The quaternion's components, in the order of ``orientation_wxyz``'s last axis.
QUATERNION_LABELS = ("w", "x", "y", "z")
#: The second constant of the super-Fibonacci spiral: the real root of psi^4 = psi + 4.
_PSI = 1.533751168755204288118041


def sphere_points(count: int, dims: int) -> FloatArray:
    """``count`` unit vectors spread evenly over the unit sphere in ``dims`` (1, 2 or 3) dims.

    One dimension: ``+1, -1, +1, ...``; two: angles ``2 pi k / count``; three: a
    Fibonacci sphere (golden-angle spiral of equal-area bands).
    """
    k = np.arange(count, dtype=np.float64)
    if dims == 1:
        return np.where(k % 2 == 0, 1.0, -1.0)[:, None]
    if dims == 2:
        angle = 2.0 * math.pi * k / count
        return np.stack([np.cos(angle), np.sin(angle)], axis=1)
    z = 1.0 - (2.0 * k + 1.0) / count
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    angle = math.pi * (3.0 - math.sqrt(5.0)) * k
    return np.stack([r * np.cos(angle), r * np.sin(angle), z], axis=1)


def spread_twists(count: int, rows: tuple[str, ...]) -> FloatArray:
    """``count`` unit twists over the task's ``rows`` (names of :data:`TWIST_ROWS`), (count, 6).

    Raises:
        ValueError: For a count below 1, or below 2 for a task with translation
            and rotation rows (each kind needs one direction at least).
    """
    moves = [TWIST_ROWS.index(r) for r in rows if r in TWIST_ROWS[:3]]
    turns = [TWIST_ROWS.index(r) for r in rows if r in TWIST_ROWS[3:]]
    least = 2 if moves and turns else 1
    if not (isinstance(count, int) and count >= least):
        raise ValueError(f"directions: must be a whole number >= {least}, got {count!r}")
    n_moves = math.ceil(count / 2) if turns and moves else (count if moves else 0)
    twists = np.zeros((count, 6))
    if moves:
        twists[:n_moves, moves] = sphere_points(n_moves, len(moves))
    if turns:
        twists[n_moves:, turns] = sphere_points(count - n_moves, len(turns))
    return twists


def super_fibonacci(count: int) -> FloatArray:
    """``count`` unit quaternions (w, x, y, z) spread evenly over SO(3), w >= 0 (Alexa 2022)."""
    s = np.arange(count, dtype=np.float64) + 0.5
    t = s / count
    r, big = np.sqrt(t), np.sqrt(1.0 - t)
    alpha, beta = 2.0 * math.pi * s / math.sqrt(2.0), 2.0 * math.pi * s / _PSI
    quats = np.stack([r * np.sin(alpha), r * np.cos(alpha), big * np.sin(beta),
                      big * np.cos(beta)], axis=1)  # fmt: skip
    quats = quats[:, [3, 0, 1, 2]]
    return np.where(quats[:, :1] < 0.0, -quats, quats)


def quaternion_matrix(quat: FloatArray) -> FloatArray:
    """The rotation matrix (3, 3) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def matrix_quaternion(rot: FloatArray) -> FloatArray:
    """The unit quaternion (w, x, y, z), w >= 0, of a rotation matrix (3, 3)."""
    m = np.asarray(rot, dtype=np.float64)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    candidates = np.array([
        [1 + trace, m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]],
        [m[2, 1] - m[1, 2], 1 + m[0, 0] - m[1, 1] - m[2, 2], m[0, 1] + m[1, 0], m[0, 2] + m[2, 0]],
        [m[0, 2] - m[2, 0], m[0, 1] + m[1, 0], 1 - m[0, 0] + m[1, 1] - m[2, 2], m[1, 2] + m[2, 1]],
        [m[1, 0] - m[0, 1], m[0, 2] + m[2, 0], m[1, 2] + m[2, 1], 1 - m[0, 0] - m[1, 1] + m[2, 2]],
    ])  # fmt: skip
    best = candidates[int(np.argmax(np.diag(candidates)))]
    quat = best / np.linalg.norm(best)
    return -quat if quat[0] < 0 else quat


def spread_orientations(count: int, rows: tuple[str, ...], home: FloatArray) -> FloatArray:
    """``count`` tool orientations as unit quaternions (w, x, y, z), (count, 4).

    See the module docstring; ``home`` is the tool's rotation (3, 3) at the
    arm's home configuration, the one orientation of a map with ``count = 1``.

    Raises:
        ValueError: For a count below 1, or above 1 for a task that commands
            no rotation; for a task that commands some rotation rows but not
            all three (other than the planar ``rz``).
    """
    if not (isinstance(count, int) and count >= 1):
        raise ValueError(f"orientations: must be a whole number >= 1, got {count!r}")
    turns = tuple(r for r in rows if r in TWIST_ROWS[3:])
    if not turns:
        if count != 1:
            raise ValueError(
                f"orientations: the task ({' '.join(rows)}) commands no rotation: use 1, "
                f"got {count}"
            )
        return np.array([[1.0, 0.0, 0.0, 0.0]])
    if turns == ("rz",):
        half = np.pi * np.arange(count) / count  # half the angle about z
        return np.stack([np.cos(half), 0 * half, 0 * half, np.sin(half)], axis=1)
    if len(turns) != 3:
        raise ValueError(
            f"orientations: a map takes a task with all rotation rows, none, or rz alone; "
            f"got rows {' '.join(rows)}"
        )
    if count == 1:
        return matrix_quaternion(home)[None, :]
    return super_fibonacci(count)
