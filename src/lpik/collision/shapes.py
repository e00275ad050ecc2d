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

Every rule on an obstacle's values lives here, once (:func:`check_number`,
:func:`check_point`, :func:`check_sizes`, :func:`check_normal`,
:func:`check_name`, :func:`check_kind`): :class:`Obstacle` and :class:`Scene`
apply them when they are built in Python, and the JSON reader
(:mod:`lpik.collision.scene_json`) applies the same functions with the
document's keys. A bad value is an :class:`~lpik.exceptions.InvalidProblemError`
(a ``ValueError``) naming the field.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.exceptions import InvalidProblemError, MissingBackendError
from lpik.robots.rotations import transform
from lpik.tolerances import MAX_MAGNITUDE
from lpik.types import FloatArray

#: Obstacle types a scene may hold.
OBSTACLE_TYPES = ("sphere", "capsule", "box", "plane")
#: Height of the box that stands for a 2-D box, centred on z = 0 [m]: far above any link's radius.
PLANAR_BOX_HEIGHT = 10.0
#: Longest obstacle name (it appears in every binding label and CSV row that names the obstacle).
MAX_NAME = 80
#: The fields each kind of obstacle needs (``rpy``, a box's orientation, is optional).
OBSTACLE_FIELDS = {
    "sphere": ("center", "radius"),
    "capsule": ("a", "b", "radius"),
    "box": ("center", "size"),
    "plane": ("center", "normal"),
}


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def check_number(key: str, value: Any, *, positive: bool = False) -> float:
    """``value`` as a float: finite, at most ``MAX_MAGNITUDE`` in size; ``> 0`` if ``positive``.

    Raises:
        InvalidProblemError: Naming ``key``.
    """
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise InvalidProblemError(key, f"must be a number, got {_shown(value)}")
    x = float(value)
    if not math.isfinite(x) or abs(x) > MAX_MAGNITUDE:
        raise InvalidProblemError(key, f"must be a finite number, got {_shown(value)}")
    if positive and not x > 0:
        raise InvalidProblemError(key, f"must be a number > 0, got {_shown(value)}")
    return x


def check_point(key: str, value: Any, dims: int) -> FloatArray:
    """``value`` (a list, tuple or 1-D array of ``dims`` numbers) as a new float array.

    Raises:
        InvalidProblemError: Naming ``key`` (or ``key[i]``, the number at fault).
    """
    if isinstance(value, np.ndarray):
        value = value.tolist() if value.ndim == 1 else value
    if not isinstance(value, list | tuple) or len(value) != dims:
        raise InvalidProblemError(key, f"must be a list of {dims} numbers, got {_shown(value)}")
    return np.array([check_number(f"{key}[{i}]", v) for i, v in enumerate(value)])


def check_sizes(key: str, value: Any, dims: int) -> FloatArray:
    """A box's edge lengths: :func:`check_point`, every edge ``> 0``."""
    size = check_point(key, value, dims)
    if not (size > 0).all():
        raise InvalidProblemError(key, f"every edge must be > 0, got {_shown(value)}")
    return size


def check_normal(key: str, value: Any, dims: int) -> FloatArray:
    """A plane's normal: :func:`check_point`, not zero; returned as a unit vector."""
    normal = check_point(key, value, dims)
    length = float(np.linalg.norm(normal))
    if not length > 1e-12:
        raise InvalidProblemError(key, "must be a non-zero vector")
    return normal / length


def check_name(key: str, value: Any) -> str:
    """An obstacle's name: a string, not blank, of at most :data:`MAX_NAME` characters."""
    if not isinstance(value, str) or not value.strip() or len(value) > MAX_NAME:
        raise InvalidProblemError(key, f"must be a non-empty name, got {_shown(value)}")
    return value


def check_kind(key: str, value: Any) -> str:
    """One of :data:`OBSTACLE_TYPES`."""
    if value not in OBSTACLE_TYPES:
        raise InvalidProblemError(
            key, f"must be one of {', '.join(OBSTACLE_TYPES)}; got {_shown(value)}"
        )
    return str(value)


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

    def __post_init__(self) -> None:
        """Check every field with the rules of this module; arrays are stored as new float arrays.

        Raises:
            InvalidProblemError: Naming the field, e.g. ``radius: must be a number > 0,
                got -1.0 (obstacle 'ball', a sphere)``.
        """
        check_name("name", self.name)
        kind = check_kind("kind", self.kind)
        try:
            for field, value in self._checked(kind).items():
                object.__setattr__(self, field, value)
        except InvalidProblemError as exc:
            raise InvalidProblemError(
                exc.field, f"{exc.reason} (obstacle {self.name!r}, a {kind})"
            ) from None

    def _checked(self, kind: str) -> dict[str, Any]:
        if self.dims not in (2, 3) or isinstance(self.dims, bool):
            raise InvalidProblemError("dims", f"must be 2 or 3, got {_shown(self.dims)}")
        d, needed = int(self.dims), OBSTACLE_FIELDS[kind]
        optional = ("rpy",) if kind == "box" else ()
        for field in ("center", "a", "b", "size", "rpy", "normal"):
            given = getattr(self, field) is not None
            if field in needed and not given:
                raise InvalidProblemError(field, f"missing (a {kind} needs it)")
            if given and field not in needed and field not in optional:
                raise InvalidProblemError(field, f"a {kind} takes {', '.join(needed)}")
        if "radius" not in needed and self.radius != 0.0:
            raise InvalidProblemError("radius", f"a {kind} takes {', '.join(needed)}")
        checked: dict[str, Any] = {"dims": d}
        if "radius" in needed:
            checked["radius"] = check_number("radius", self.radius, positive=True)
        for field in ("center", "a", "b"):
            if field in needed:
                checked[field] = check_point(field, getattr(self, field), d)
        if kind == "box":
            checked["size"] = check_sizes("size", self.size, d)
            rpy = check_point("rpy", [0.0, 0.0, 0.0] if self.rpy is None else self.rpy, 3)
            if d == 2 and rpy[:2].any():
                raise InvalidProblemError("rpy", f"a 2-D box turns about z only, got {rpy}")
            checked["rpy"] = rpy
        if kind == "plane":
            checked["normal"] = check_normal("normal", self.normal, d)
        return checked

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
        """Check the distances, the obstacles and their dimensions.

        Raises:
            InvalidProblemError: Naming the field.
        """
        d_s = check_number("safety_distance", self.safety_distance)
        d_i = check_number("influence_distance", self.influence_distance)
        if not d_s >= 0:
            raise InvalidProblemError(
                "safety_distance", f"must be a finite number >= 0, got {_shown(d_s)}"
            )
        if not d_i > d_s:
            raise InvalidProblemError(
                "influence_distance", f"must be finite and > safety_distance ({d_s}), got {d_i!r}"
            )
        if self.dims not in (2, 3) or isinstance(self.dims, bool):
            raise InvalidProblemError("dims", f"must be 2 or 3, got {_shown(self.dims)}")
        if not isinstance(self.obstacles, tuple | list):
            raise InvalidProblemError(
                "obstacles", f"must be a tuple of Obstacle, got {_shown(self.obstacles)}"
            )
        for i, o in enumerate(self.obstacles):
            if not isinstance(o, Obstacle):
                raise InvalidProblemError(
                    f"obstacles[{i}]", f"must be an Obstacle, got {_shown(o)}"
                )
            if o.dims != self.dims:
                raise InvalidProblemError(
                    f"obstacles[{i}]", f"a {o.dims}-D obstacle in a {self.dims}-D scene"
                )
        names = [o.name for o in self.obstacles]
        if len(set(names)) != len(names):
            raise InvalidProblemError("obstacles", f"names must be unique, got {names}")
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        object.__setattr__(self, "safety_distance", d_s)
        object.__setattr__(self, "influence_distance", d_i)

    @property
    def names(self) -> tuple[str, ...]:
        """The obstacles' names, in order."""
        return tuple(o.name for o in self.obstacles)
