"""Reading a scene from JSON (``--scene SCENE.json``), checked key by key.

A scene document::

    {"obstacles": [{"name": "table", "type": "box", "center": [x, y, z],
                    "size": [sx, sy, sz], "rpy": [r, p, y]},
                   {"name": "ball", "type": "sphere", "center": [x, y, z], "radius": r},
                   {"name": "pole", "type": "capsule", "a": [x, y, z], "b": [x, y, z],
                    "radius": r},
                   {"name": "floor", "type": "plane", "point": [x, y, z],
                    "normal": [nx, ny, nz]}],
     "safety_distance": d_s, "influence_distance": d_i}

A planar scene (for the paper's planar arm) writes every point with two
coordinates; its boxes take ``"angle"`` [rad] (about z) instead of ``"rpy"``.
``rpy`` is optional (zero). A bad document raises
:class:`~lpik.exceptions.InvalidProblemError` (a ``ValueError``) naming the
key, e.g. ``obstacles[2].radius: must be a number > 0``. The caps below keep
what a file can ask for small.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from lpik.collision.shapes import OBSTACLE_TYPES, Obstacle, Scene
from lpik.exceptions import InvalidProblemError
from lpik.tolerances import MAX_MAGNITUDE

#: Largest scene file read [bytes].
MAX_SCENE_BYTES = 1024 * 1024
#: Most obstacles in one scene.
MAX_OBSTACLES = 256
#: Keys a scene document may have.
SCENE_KEYS = ("obstacles", "safety_distance", "influence_distance")
#: Keys of each obstacle type, besides ``name`` and ``type`` (optional ones: ``rpy``, ``angle``).
OBSTACLE_KEYS = {
    "sphere": ("center", "radius"),
    "capsule": ("a", "b", "radius"),
    "box": ("center", "size"),
    "plane": ("point", "normal"),
}


def _number(key: str, value: Any, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidProblemError(key, f"must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or abs(x) > MAX_MAGNITUDE:
        raise InvalidProblemError(key, f"must be a finite number, got {value!r}")
    if positive and not x > 0:
        raise InvalidProblemError(key, f"must be a number > 0, got {value!r}")
    return x


def _vector(key: str, value: Any, dims: int) -> np.ndarray:
    if not isinstance(value, list) or len(value) != dims:
        raise InvalidProblemError(key, f"must be a list of {dims} numbers, got {value!r}")
    return np.array([_number(f"{key}[{i}]", v) for i, v in enumerate(value)])


def _dims_of(item: dict[str, Any], where: str) -> int:
    point = item.get("center", item.get("a", item.get("point")))
    if isinstance(point, list) and len(point) in (2, 3):
        return len(point)
    key = "center" if "center" in item or item.get("type") in ("sphere", "box") else "point"
    key = "a" if item.get("type") == "capsule" else key
    raise InvalidProblemError(f"{where}.{key}", f"must be a list of 2 or 3 numbers, got {point!r}")


def _obstacle(item: Any, where: str, dims: int | None) -> Obstacle:
    if not isinstance(item, dict):
        raise InvalidProblemError(where, f"must be an object, got {item!r}")
    kind = item.get("type")
    if kind not in OBSTACLE_TYPES:
        raise InvalidProblemError(
            f"{where}.type", f"must be one of {', '.join(OBSTACLE_TYPES)}; got {kind!r}"
        )
    name = item.get("name")
    if not isinstance(name, str) or not name.strip() or len(name) > 80:
        raise InvalidProblemError(f"{where}.name", f"must be a non-empty name, got {name!r}")
    optional = {"box": ("rpy", "angle")}.get(kind, ())
    allowed = ("name", "type", *OBSTACLE_KEYS[kind], *optional)
    for key in item:
        if key not in allowed:
            raise InvalidProblemError(
                f"{where}.{key}", f"unknown key for a {kind}; expected: {', '.join(allowed)}"
            )
    for key in OBSTACLE_KEYS[kind]:
        if key not in item:
            raise InvalidProblemError(f"{where}.{key}", f"missing (a {kind} needs it)")
    d = _dims_of(item, where) if dims is None else dims
    fields: dict[str, Any] = {"name": name, "kind": kind, "dims": d}
    if kind in ("sphere", "capsule"):
        fields["radius"] = _number(f"{where}.radius", item["radius"], positive=True)
    if kind in ("sphere", "box"):
        fields["center"] = _vector(f"{where}.center", item["center"], d)
    if kind == "capsule":
        fields["a"] = _vector(f"{where}.a", item["a"], d)
        fields["b"] = _vector(f"{where}.b", item["b"], d)
    if kind == "box":
        size = _vector(f"{where}.size", item["size"], d)
        if not (size > 0).all():
            raise InvalidProblemError(
                f"{where}.size", f"every edge must be > 0, got {item['size']}"
            )
        fields["size"] = size
        if d == 2 and "rpy" in item:
            raise InvalidProblemError(f"{where}.rpy", "a 2-D box takes 'angle' [rad], not 'rpy'")
        if d == 3 and "angle" in item:
            raise InvalidProblemError(f"{where}.angle", "a 3-D box takes 'rpy' [rad], not 'angle'")
        if d == 2:
            fields["rpy"] = np.array([0.0, 0.0, _number(f"{where}.angle", item.get("angle", 0.0))])
        else:
            fields["rpy"] = _vector(f"{where}.rpy", item.get("rpy", [0.0, 0.0, 0.0]), 3)
    if kind == "plane":
        fields["center"] = _vector(f"{where}.point", item["point"], d)
        normal = _vector(f"{where}.normal", item["normal"], d)
        length = float(np.linalg.norm(normal))
        if not length > 1e-12:
            raise InvalidProblemError(f"{where}.normal", "must be a non-zero vector")
        fields["normal"] = normal / length
    return Obstacle(**fields)


def scene_from_dict(data: Any) -> Scene:
    """Check a scene document and return the :class:`~lpik.collision.shapes.Scene`.

    Raises:
        InvalidProblemError: Naming the key at fault.
    """
    if not isinstance(data, dict):
        raise InvalidProblemError("scene", "must be a JSON object with 'obstacles'")
    for key in data:
        if key not in SCENE_KEYS:
            raise InvalidProblemError(
                str(key)[:40], f"unknown key; expected: {', '.join(SCENE_KEYS)}"
            )
    for key in SCENE_KEYS:
        if key not in data:
            raise InvalidProblemError(key, "missing")
    items = data["obstacles"]
    if not isinstance(items, list):
        raise InvalidProblemError("obstacles", "must be a list of obstacles")
    if len(items) > MAX_OBSTACLES:
        raise InvalidProblemError(
            "obstacles", f"has {len(items)} entries; at most {MAX_OBSTACLES} (MAX_OBSTACLES)"
        )
    obstacles: list[Obstacle] = []
    dims: int | None = None
    for i, item in enumerate(items):
        obstacle = _obstacle(item, f"obstacles[{i}]", dims)
        dims = obstacle.dims
        obstacles.append(obstacle)
    d_s = _number("safety_distance", data["safety_distance"])
    d_i = _number("influence_distance", data["influence_distance"])
    try:
        return Scene(tuple(obstacles), d_s, d_i, dims or 3)
    except ValueError as exc:
        key, _, reason = str(exc).partition(": ")
        raise InvalidProblemError(key, reason) from None


def load_scene(path: str | Path) -> Scene:
    """Read and check a scene file.

    Raises:
        InvalidProblemError: For an unreadable or too large file, bad JSON or a bad key.
    """
    name = repr(str(path))
    try:
        with open(path, "rb") as file:
            raw = file.read(MAX_SCENE_BYTES + 1)
        text = raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise InvalidProblemError("scene", f"cannot read {name}: {reason}") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise InvalidProblemError(
            "scene", f"{name} is larger than {MAX_SCENE_BYTES} bytes (MAX_SCENE_BYTES)"
        )
    try:
        data = json.loads(text, parse_constant=lambda c: float(c))
    except (json.JSONDecodeError, RecursionError) as exc:
        where = f" at line {exc.lineno} column {exc.colno}" if hasattr(exc, "lineno") else ""
        raise InvalidProblemError("scene", f"unreadable JSON{where}") from None
    return scene_from_dict(data)
