"""Obstacles and scenes: spheres, capsules, boxes and half-spaces, in 3-D or in the plane.

A scene is the obstacles around one arm, with the two distances of the
velocity damper (Faverjon and Tournassoud 1987): the *safety distance*
``d_s`` that no step may cross, and the *influence distance* ``d_i`` inside
which an obstacle starts to count (rows of the damper, the potential field of
Khatib 1986). Distances are signed: negative when the shapes overlap.

Planar scenes (the paper's arm moves in the x-y plane) use 2-D points; each
2-D shape is the 3-D shape whose cut by the plane z = 0 it is (a circle is a
sphere at z = 0, a 2-D box a box standing on the plane, a line a vertical
half-space), so one distance library serves both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.exceptions import MissingBackendError
from lpik.robots.rotations import transform
from lpik.types import FloatArray

#: Obstacle types a scene may hold.
OBSTACLE_TYPES = ("sphere", "capsule", "box", "plane")
#: Height of the box that stands for a 2-D box, centred on z = 0 [m]: far above any link's radius.
PLANAR_BOX_HEIGHT = 10.0


def coal_module() -> Any:
    """The ``coal`` package (distances between shapes), or the error that says how to install it.

    Raises:
        MissingBackendError: When ``coal`` is not installed.
    """
    try:
        import coal
    except ImportError:
        raise MissingBackendError("collision avoidance (coal)", "collision") from None
    return coal


def _given(value: FloatArray | None) -> FloatArray:
    """A field the scene loader has filled for this kind of obstacle."""
    return np.zeros(3) if value is None else value


def _point3(point: FloatArray) -> FloatArray:
    return np.append(point, 0.0) if point.size == 2 else point


def rotation_taking_z_to(direction: FloatArray) -> FloatArray:
    """A rotation matrix (3, 3) whose third column is the unit vector along ``direction``."""
    z0, z1, z2 = (float(v) for v in direction)
    norm = math.sqrt(z0 * z0 + z1 * z1 + z2 * z2)
    if norm < 1e-15:
        return np.eye(3)
    z0, z1, z2 = z0 / norm, z1 / norm, z2 / norm
    # x: a helper axis made orthogonal to z; y = z x x (plain floats: this runs per capsule)
    h0, h1 = (1.0, 0.0) if abs(z0) < 0.9 else (0.0, 1.0)
    dot = h0 * z0 + h1 * z1
    x0, x1, x2 = h0 - dot * z0, h1 - dot * z1, -dot * z2
    length = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
    x0, x1, x2 = x0 / length, x1 / length, x2 / length
    y0, y1, y2 = z1 * x2 - z2 * x1, z2 * x0 - z0 * x2, z0 * x1 - z1 * x0
    return np.array([[x0, y0, z0], [x1, y1, z1], [x2, y2, z2]])


def capsule_geometry(a: FloatArray, b: FloatArray, radius: float) -> tuple[Any, Any]:
    """A coal capsule from ``a`` to ``b`` (3-D points) and its placement."""
    coal = coal_module()
    axis = b - a
    shape = coal.Capsule(float(radius), float(np.linalg.norm(axis)))
    return shape, coal.Transform3s(rotation_taking_z_to(axis), 0.5 * (a + b))


@dataclass(frozen=True, eq=False)
class Obstacle:
    """One fixed obstacle of a scene.

    Attributes:
        name: What ``binding`` and the CSV's ``closest`` call it.
        kind: One of :data:`OBSTACLE_TYPES`.
        dims: 2 for a planar scene (points in the x-y plane), 3 otherwise.
        center: Centre of a sphere or box [m]; a point on a plane's boundary.
        radius: Radius of a sphere or capsule [m].
        a: First end of a capsule's axis [m].
        b: Second end of a capsule's axis [m].
        size: Edge lengths of a box (sx, sy[, sz]) [m].
        rpy: Orientation of a box (roll, pitch, yaw) [rad]; in 2-D only the yaw counts.
        normal: Outward unit normal of a plane (the free side) [m/m].
    """

    name: str
    kind: str
    dims: int = 3
    center: FloatArray | None = None
    radius: float = 0.0
    a: FloatArray | None = None
    b: FloatArray | None = None
    size: FloatArray | None = None
    rpy: FloatArray | None = None
    normal: FloatArray | None = None

    def placed(self) -> dict[str, Any]:
        """The obstacle in the world frame, in 3-D, as plain numbers.

        A sphere: ``center``, ``radius``; a capsule: ``a``, ``b``, ``radius``; a box:
        ``center``, ``rotation`` (3, 3, its axes as columns), ``size`` (3,); a plane:
        the unit ``normal`` and ``offset`` of the solid ``normal . x <= offset``
        (the free side is ``normal . x > offset``).
        """
        if self.kind == "sphere":
            return {"center": _point3(_given(self.center)), "radius": float(self.radius)}
        if self.kind == "capsule":
            return {
                "a": _point3(_given(self.a)),
                "b": _point3(_given(self.b)),
                "radius": float(self.radius),
            }
        if self.kind == "box":
            size = _given(self.size)
            size = size if size.size == 3 else np.append(size, PLANAR_BOX_HEIGHT)
            pose = transform(_point3(_given(self.center)), _given(self.rpy))
            return {"center": pose[:3, 3], "rotation": pose[:3, :3], "size": size}
        normal = _point3(_given(self.normal))
        normal = normal / np.linalg.norm(normal)
        return {"normal": normal, "offset": float(normal @ _point3(_given(self.center)))}

    def geometry(self) -> tuple[Any, Any]:
        """The coal shape and its placement in the world frame."""
        coal = coal_module()
        placed = self.placed()
        if self.kind == "sphere":
            return coal.Sphere(placed["radius"]), coal.Transform3s(np.eye(3), placed["center"])
        if self.kind == "capsule":
            return capsule_geometry(placed["a"], placed["b"], placed["radius"])
        if self.kind == "box":
            return coal.Box(*map(float, placed["size"])), coal.Transform3s(
                placed["rotation"], placed["center"]
            )
        return coal.Halfspace(placed["normal"], placed["offset"]), coal.Transform3s()


@dataclass(frozen=True, eq=False)
class Scene:
    """Obstacles and the damper's distances (Faverjon and Tournassoud 1987).

    Attributes:
        obstacles: The fixed obstacles.
        safety_distance: ``d_s`` [m]: no step of a hard-row method brings a pair closer.
        influence_distance: ``d_i`` [m] (> ``d_s``): pairs closer than this are considered.
        dims: 2 for a planar scene, 3 otherwise.
    """

    obstacles: tuple[Obstacle, ...]
    safety_distance: float
    influence_distance: float
    dims: int = 3

    def __post_init__(self) -> None:
        d_s, d_i = self.safety_distance, self.influence_distance
        if not (np.isfinite(d_s) and d_s >= 0):
            raise ValueError(f"safety_distance: must be a finite number >= 0, got {d_s!r}")
        if not (np.isfinite(d_i) and d_i > d_s):
            raise ValueError(
                f"influence_distance: must be finite and > safety_distance ({d_s}), got {d_i!r}"
            )
        names = [o.name for o in self.obstacles]
        if len(set(names)) != len(names):
            raise ValueError(f"obstacles: names must be unique, got {names}")

    @property
    def names(self) -> tuple[str, ...]:
        """The obstacles' names, in order."""
        return tuple(o.name for o in self.obstacles)
