"""Collision models for the arms lpik knows, and the one call that sets avoidance up.

Radii of the bundled arms' links (link-frame capsules,
:func:`lpik.collision.bodies.frame_capsules`):

* ``panda``: the radii of the self-collision capsules of Franka Emika's own
  description (``franka_ros``, ``franka_description/robots/common/franka_arm.xacro``,
  ``collision_capsule`` radius without its ``safety_distance``): 0.06 m for
  links 0-5, 0.05 m for link 6, 0.04 m for link 7 (which here also carries the hand).

``ur5e`` and ``iiwa14`` ship capsules placed per link rather than radii
(:data:`lpik.collision.bundled.BUNDLED_CAPSULES`, from MuJoCo Menagerie's
collision geoms): the UR5e's upper arm runs 0.138 m off the segment between
its joints. ``radii=`` replaces them by link-frame capsules. The paper's
planar arm gets :data:`PLANAR_LINK_RADIUS` per link.
A URDF's ``<collision>`` cylinders and spheres are used where a chain's URDF
has them (:func:`lpik.collision.bodies.urdf_capsules`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lpik.collision.avoidance import (
    DEFAULT_APPROACH_SPEED,
    DEFAULT_FIELD_GAIN,
    CollisionAvoidance,
)
from lpik.collision.bodies import LinkCapsule, chain_of, frame_capsules, link_names
from lpik.collision.bundled import BUNDLED_CAPSULES
from lpik.collision.distance import Proximities, robot_bodies
from lpik.collision.shapes import Scene

#: Link radii of the bundled arms [m] (sources in the module's docstring).
BUNDLED_RADII: dict[str, dict[str, float]] = {
    "panda": {
        "panda_link0": 0.06,
        "panda_link1": 0.06,
        "panda_link2": 0.06,
        "panda_link3": 0.06,
        "panda_link4": 0.06,
        "panda_link5": 0.06,
        "panda_link6": 0.05,
        "panda_link7": 0.04,
    },
}
#: Radius of every link of a planar arm (the paper's arm has no thickness) [m].
PLANAR_LINK_RADIUS = 0.05


def default_capsules(
    model: Any, radii: float | Mapping[str, float] | None = None
) -> tuple[LinkCapsule, ...]:
    """The capsules of ``model``: from ``radii`` when given, else the bundled or planar ones.

    Raises:
        ValueError: When no radii are known for the model (names it and says what to pass).
    """
    chain = chain_of(model)
    if radii is None and chain.name in BUNDLED_CAPSULES:
        names = dict((joint, link) for link, joint in link_names(chain))
        return tuple(
            LinkCapsule(names[joint], joint, np.array(a), np.array(b), radius)
            for joint, a, b, radius in BUNDLED_CAPSULES[chain.name]
        )
    if radii is None:
        if chain.name in BUNDLED_RADII:
            radii = BUNDLED_RADII[chain.name]
        elif chain.planar:
            return frame_capsules(chain, PLANAR_LINK_RADIUS, base=False)
        else:
            raise ValueError(
                f"radii: no collision radii are known for '{chain.name}' (known: "
                + ", ".join([*BUNDLED_RADII, *BUNDLED_CAPSULES])
                + "); pass radii= (one per link or one for all)"
            )
    return frame_capsules(chain, radii, base=not chain.planar)


def collision_avoidance(
    model: Any,
    scene: Scene,
    home: Sequence[float] | None,
    *,
    mechanism: str = "rows",
    radii: float | Mapping[str, float] | None = None,
    capsules: Sequence[LinkCapsule] | None = None,
    self_collision: bool = True,
    approach_speed: float = DEFAULT_APPROACH_SPEED,
    field_gain: float = DEFAULT_FIELD_GAIN,
) -> CollisionAvoidance:
    """Collision avoidance for ``model`` in ``scene``.

    Args:
        model: A chain or a task on one (planar or 3-D).
        scene: The obstacles, ``d_s`` and ``d_i``.
        home: Configuration at which touching self-collision pairs are dropped
            (:func:`lpik.collision.distance.robot_bodies`); None: only the pairs
            that touch everywhere are.
        mechanism: ``"rows"`` (Faverjon and Tournassoud), ``"field"`` (Khatib, the paper) or both.
        radii: Link radii (see :func:`default_capsules`).
        capsules: The capsules themselves (e.g. from the URDF); overrides ``radii``.
        self_collision: Whether links are checked against each other.
        approach_speed: ``xi`` of the damper [m/s].
        field_gain: ``eta`` of the field [m^3/s].

    Raises:
        ValueError: For a model or scene that do not fit, or a bad parameter.
    """
    chain = chain_of(model)
    if scene.dims == 2 and not chain.planar:
        raise ValueError("scene: a 2-D scene needs a planar arm; this one moves in 3-D")
    bodies = robot_bodies(
        chain,
        default_capsules(chain, radii) if capsules is None else capsules,
        None if home is None else np.asarray(home, dtype=np.float64),
        self_collision=self_collision,
        touching=scene.safety_distance,
    )
    return CollisionAvoidance(Proximities(bodies, scene), mechanism, approach_speed, field_gain)


def as_avoidance(model: Any, scene: Any, home: Sequence[float] | None) -> CollisionAvoidance | None:
    """``scene`` as collision avoidance for ``model``.

    None stays None, a :class:`~lpik.collision.shapes.Scene` gets the velocity damper's
    rows (self-collision pairs dropped where they touch everywhere or at ``home``), a
    :class:`CollisionAvoidance` stays as it is.

    Raises:
        ValueError: For anything else, or a scene that does not fit the model.
    """
    if scene is None or isinstance(scene, CollisionAvoidance):
        return scene
    if isinstance(scene, Scene):
        return collision_avoidance(model, scene, home)
    raise ValueError(f"scene: expected a Scene or a CollisionAvoidance, got {type(scene).__name__}")
