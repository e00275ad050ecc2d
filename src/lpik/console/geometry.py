"""What the page draws, as plain values: poses of the links, obstacles, highlights, instruments.

Nothing here needs a browser or viser: :mod:`lpik.console.view` only hands
these values to the viewer, and tests check them directly.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.collision import LinkCapsule, Scene
from lpik.console.loop import Snapshot
from lpik.robots.rotations import transform
from lpik.types import FloatArray

#: Colours (RGB) of the arm, a highlighted part and the obstacles.
ARM, OBSTACLE = (150, 160, 175), (120, 170, 120)
#: Highlight colour by the kind of the binding limit.
HIGHLIGHT = {
    "end-stop": (220, 40, 40),
    "velocity": (240, 140, 20),
    "acceleration": (200, 90, 200),
    "collision": (220, 40, 40),
    "singularity": (230, 200, 30),
    "multiplier": (60, 120, 230),
    "row": (220, 40, 40),
}
#: Height [m] of a planar scene's obstacles drawn as solids (they extend along z).
PLANAR_HEIGHT = 0.2
#: Half the edge [m] of the square drawn for a plane.
PLANE_HALF = 1.5


def wxyz(rotation: FloatArray) -> tuple[float, float, float, float]:
    """A rotation matrix as a unit quaternion (w, x, y, z), w >= 0."""
    R = np.asarray(rotation, dtype=float)
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return tuple(float(v) for v in q / np.linalg.norm(q))  # type: ignore[return-value]


def rotation(quaternion: Sequence[float]) -> FloatArray:
    """A unit quaternion (w, x, y, z) as a rotation matrix."""
    w, x, y, z = np.asarray(quaternion, dtype=float) / np.linalg.norm(quaternion)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def z_to(direction: FloatArray) -> FloatArray:
    """A rotation taking the z axis to ``direction`` (any one when it is 0)."""
    d = np.asarray(direction, dtype=float)
    length = float(np.linalg.norm(d))
    if length < 1e-12:
        return np.eye(3)
    z = d / length
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


@dataclass(frozen=True)
class Segment:
    """A cylinder between two points: centre, orientation (its z along the axis), length."""

    center: tuple[float, float, float]
    wxyz: tuple[float, float, float, float]
    length: float


def segment(a: FloatArray, b: FloatArray) -> Segment:
    """The cylinder from ``a`` to ``b``."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    center = tuple(float(v) for v in (a + b) / 2)
    return Segment(center, wxyz(z_to(b - a)), float(np.linalg.norm(b - a)))  # type: ignore[arg-type]


@dataclass(frozen=True)
class Shape:
    """One obstacle as the viewer draws it.

    Attributes:
        name: The obstacle's name.
        kind: ``"sphere"``, ``"cylinder"`` (a capsule's or a planar circle's body) or ``"box"``.
        position: Centre [m].
        wxyz: Orientation.
        size: Radius (sphere), (radius, length) (cylinder) or edge lengths (box) [m].
    """

    name: str
    kind: str
    position: tuple[float, float, float]
    wxyz: tuple[float, float, float, float]
    size: tuple[float, ...]


def _xyz(point: Any) -> tuple[float, float, float]:
    p = np.zeros(3)
    values = np.asarray(point, dtype=float)
    p[: values.size] = values
    return (float(p[0]), float(p[1]), float(p[2]))


def obstacle_shapes(scene: Scene | None) -> list[Shape]:
    """The solids that draw ``scene``'s obstacles (a planar scene's extend along z)."""
    shapes: list[Shape] = []
    identity = (1.0, 0.0, 0.0, 0.0)
    for o in () if scene is None else scene.obstacles:
        if o.kind == "sphere" and o.dims == 2:  # a circle in the plane: a short cylinder
            shapes.append(
                Shape(o.name, "cylinder", _xyz(o.center), identity, (o.radius, PLANAR_HEIGHT))
            )
        elif o.kind == "sphere":
            shapes.append(Shape(o.name, "sphere", _xyz(o.center), identity, (o.radius,)))
        elif o.kind == "capsule":
            seg = segment(_xyz(o.a), _xyz(o.b))
            shapes.append(Shape(o.name, "cylinder", seg.center, seg.wxyz, (o.radius, seg.length)))
            for end in (o.a, o.b):
                shapes.append(Shape(o.name, "sphere", _xyz(end), identity, (o.radius,)))
        elif o.kind == "box":
            size = np.asarray(o.size, dtype=float)
            size3 = (
                tuple(float(v) for v in size)
                if size.size == 3
                else (*map(float, size), PLANAR_HEIGHT)
            )
            pose = transform(_xyz(o.center), np.asarray(o.rpy, dtype=float))
            shapes.append(Shape(o.name, "box", _xyz(o.center), wxyz(pose[:3, :3]), size3))
        else:  # a plane: a thin square on its boundary, facing its normal
            normal = np.asarray(_xyz(o.normal), dtype=float)
            shapes.append(
                Shape(
                    o.name,
                    "box",
                    _xyz(o.center),
                    wxyz(z_to(normal)),
                    (2 * PLANE_HALF, 2 * PLANE_HALF, 0.002),
                )
            )
    return shapes


def highlighted(binding: Any, capsules: Sequence[LinkCapsule]) -> tuple[set[int], set[str]]:
    """The capsules (indices) and obstacles (names) the binding limit names.

    A joint's limit lights the links that joint moves first (its child link); a
    collision lights the pair (a link and an obstacle, or two links); the
    singularity lights the whole arm; a multiplier bound, nothing on the arm.
    """
    kind = getattr(binding, "kind", None)
    if binding is None or kind is None:
        return set(), set()
    index = getattr(binding, "index", None)
    if kind in ("end-stop", "velocity", "acceleration") and index is not None:
        return {k for k, c in enumerate(capsules) if c.joint == index}, set()
    if kind == "singularity":
        return set(range(len(capsules))), set()
    if kind in ("collision", "row"):
        pair = str(getattr(binding, "name", "") or "")
        names = [part.strip() for part in pair.split(" - ")]
        links = {k for k, c in enumerate(capsules) if c.link in names}
        return links, {n for n in names if n not in {c.link for c in capsules}}
    return set(), set()


def _bar(fraction: float, colour: str, label: str) -> str:
    width = max(0.0, min(1.0, fraction)) * 100
    return (
        f'<div title="{html.escape(label)}" style="background:#e4e6ea;height:7px;'
        f'border-radius:3px;margin:1px 0"><div style="width:{width:.1f}%;height:7px;'
        f'border-radius:3px;background:{colour}"></div></div>'
    )


def binding_words(binding: Any, status: str) -> str:
    """The binding limit in words for the operator ("none: the command is followed" when none)."""
    if status == "error":
        return "stopped: the step failed"
    if binding is None:
        return "none: the command is followed"
    words = str(binding)
    if getattr(binding, "recovering", False):
        words += " (outside it: recovering)"
    return words


def instruments_html(
    snap: Snapshot,
    names: Sequence[str],
    q_min: FloatArray,
    q_max: FloatArray,
    qd_max: FloatArray | None,
) -> str:
    """The instrument panel: p, the binding limit, the step time and one row per joint.

    Elements carry ids (``lpik-p``, ``lpik-binding``, ``lpik-status``,
    ``lpik-step-time``) so that a browser test can read what is shown.
    """
    colour = "#2f9e44" if snap.p > 0.99 else "#f08c00" if snap.p > 0.2 else "#e03131"
    mode = "replay" if snap.replaying else "paused" if snap.paused else "running"
    rec = "" if snap.recording is None else f" · recording {snap.recording} steps"
    dist = ""
    if snap.closest is not None:
        dist = (
            f"<div>closest: {snap.closest[0] * 1000:.0f} mm ({html.escape(snap.closest[1])})</div>"
        )
    rows = []
    for i, name in enumerate(names):
        lo, hi = float(q_min[i]), float(q_max[i])
        span = hi - lo if math.isfinite(hi - lo) and hi > lo else 2 * math.pi
        base = lo if math.isfinite(lo) else -math.pi
        position = (float(snap.q[i]) - base) / span
        limit = float(qd_max[i]) if qd_max is not None and math.isfinite(qd_max[i]) else 0.0
        speed = abs(float(snap.qd[i])) / limit if limit > 0 else 0.0
        near = position < 0.02 or position > 0.98
        rows.append(
            f'<div style="font-size:11px">{html.escape(str(name))} '
            f"{math.degrees(float(snap.q[i])):.1f}°</div>"
            + _bar(position, "#e03131" if near else "#4c6ef5", "position between end-stops")
            + _bar(speed, "#f08c00" if speed > 0.98 else "#15aabf", "speed against its limit")
        )
    words = binding_words(snap.binding, snap.status)
    error = (
        "" if snap.error is None else f'<div style="color:#e03131">{html.escape(snap.error)}</div>'
    )
    return (
        f'<div style="font-family:sans-serif;font-size:12px">'
        f'<div style="font-size:28px;font-weight:bold;color:{colour}">p = '
        f'<span id="lpik-p">{snap.p:.3f}</span></div>'
        f'<div>binding: <b id="lpik-binding">{html.escape(words)}</b></div>'
        f'<div>status: <span id="lpik-status">{html.escape(snap.status)}</span> · {mode}{rec}</div>'
        f'<div>step time: <span id="lpik-step-time">{snap.step_time * 1e6:.0f}</span> µs · '
        f"real time ×{snap.rate:.2f}</div>{dist}{error}"
        f'<div style="margin-top:6px">{"".join(rows)}</div></div>'
    )
