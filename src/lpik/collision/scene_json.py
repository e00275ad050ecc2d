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
key, e.g. ``obstacles[2].radius: must be a number > 0``; the rules on the
values are those of :mod:`lpik.collision.shapes` (one place for each), applied
here with the document's keys. The caps below keep what a file can ask for small.
"""

from __future__ import annotations

import json
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np

from lpik.collision.shapes import (
    Obstacle,
    Scene,
    check_kind,
    check_name,
    check_normal,
    check_number,
    check_point,
    check_sizes,
)
from lpik.exceptions import InvalidProblemError

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
    kind = check_kind(f"{where}.type", item.get("type"))
    name = check_name(f"{where}.name", item.get("name"))
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
        fields["radius"] = check_number(f"{where}.radius", item["radius"], positive=True)
    if kind in ("sphere", "box"):
        fields["center"] = check_point(f"{where}.center", item["center"], d)
    if kind == "capsule":
        fields["a"] = check_point(f"{where}.a", item["a"], d)
        fields["b"] = check_point(f"{where}.b", item["b"], d)
    if kind == "box":
        fields["size"] = check_sizes(f"{where}.size", item["size"], d)
        if d == 2 and "rpy" in item:
            raise InvalidProblemError(f"{where}.rpy", "a 2-D box takes 'angle' [rad], not 'rpy'")
        if d == 3 and "angle" in item:
            raise InvalidProblemError(f"{where}.angle", "a 3-D box takes 'rpy' [rad], not 'angle'")
        if d == 2:
            angle = check_number(f"{where}.angle", item.get("angle", 0.0))
            fields["rpy"] = np.array([0.0, 0.0, angle])
        else:
            fields["rpy"] = check_point(f"{where}.rpy", item.get("rpy", [0.0, 0.0, 0.0]), 3)
    if kind == "plane":
        fields["center"] = check_point(f"{where}.point", item["point"], d)
        fields["normal"] = check_normal(f"{where}.normal", item["normal"], d)
    try:
        return Obstacle(**fields)
    except InvalidProblemError as exc:  # every rule was applied above; this names the key anyway
        raise InvalidProblemError(f"{where}.{exc.field}", exc.reason) from None


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
    d_s = check_number("safety_distance", data["safety_distance"])
    d_i = check_number("influence_distance", data["influence_distance"])
    return Scene(tuple(obstacles), d_s, d_i, dims or 3)


def bundled_scenes() -> tuple[str, ...]:
    """The names of the scenes that come with lpik (``lpik/data/scenes/NAME.json``)."""
    folder = files("lpik") / "data" / "scenes"
    return tuple(
        sorted(p.name[: -len(".json")] for p in folder.iterdir() if p.name.endswith(".json"))
    )


def scene_file(name: str | Path) -> Path:
    """The file of a scene: ``name`` itself when it exists, else the bundled scene of that name.

    A bundled scene is named without a folder, with or without ``.json``
    (``panda-shelf``); a file of the same name in the working folder comes first.

    Raises:
        InvalidProblemError: For a name without a folder that is neither (the message
            lists the bundled scenes).
    """
    path = Path(name)
    if path.exists() or path.name != str(name):  # a file, or a path with a folder
        return path
    stem = path.name.removesuffix(".json")
    if stem in bundled_scenes():
        return Path(str(files("lpik") / "data" / "scenes" / f"{stem}.json"))
    raise InvalidProblemError(
        "scene",
        f"no file {str(name)!r} and no bundled scene of that name; "
        f"bundled scenes: {', '.join(bundled_scenes())}",
    )


def load_scene(path: str | Path) -> Scene:
    """Read and check a scene file, or a bundled scene by name (:func:`scene_file`).

    Raises:
        InvalidProblemError: For a missing, unreadable or too large file, bad JSON or a bad key.
    """
    path = scene_file(path)
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
