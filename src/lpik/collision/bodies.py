"""The robot's collision model: capsules on the links of a serial chain.

Each link is one or more capsules (a segment with a radius) fixed in the
frame of the last moving joint before it, so that a capsule moves with
:meth:`~lpik.robots.chain.SerialChain.joint_frames`. Where the URDF gives
``<collision>`` primitives for a link, they are used: a cylinder becomes
the capsule on its axis (its end caps rounded), a sphere a capsule of
length 0; boxes and meshes are not read. Every other link is the segment
from its joint's origin to the next joint's origin (the tip for the last
link) with a radius per link.

Self-collision is checked between links that are not neighbours on the
chain (their joints at least :data:`SELF_COLLISION_GAP` apart), less the
pairs that already touch in the robot's home configuration: those touch by
design (a wrist's neighbouring housings), as in MoveIt's setup assistant,
which disables pairs that are "in collision by default".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.robots.chain import SerialChain
from lpik.types import FloatArray

#: Links whose joints are fewer than this many moving joints apart are never checked
#: against each other (a link and its neighbours).
SELF_COLLISION_GAP = 2


@dataclass(frozen=True, eq=False)
class LinkCapsule:
    """One capsule of the robot's collision model.

    Attributes:
        link: Name of the link it belongs to (what labels call it).
        joint: Index of the moving joint whose frame carries it (-1: the base).
        a: First end of the axis in that frame, shape (3,) [m].
        b: Second end, shape (3,) [m].
        radius: Radius [m] (> 0).
    """

    link: str
    joint: int
    a: FloatArray
    b: FloatArray
    radius: float


def chain_of(model: Any) -> SerialChain:
    """The serial chain of ``model`` (a chain, or a task on one); ValueError otherwise."""
    chain = getattr(model, "kinematics", model)
    if not isinstance(chain, SerialChain):
        raise ValueError(
            "collision: the robot model must be a SerialChain or a task on one "
            f"(load_urdf, planar_arm, load_robot); got {type(chain).__name__}"
        )
    return chain


def link_names(chain: SerialChain) -> list[tuple[str, int]]:
    """One name per link of the chain with its joint index: the base, then each joint's child."""
    named: dict[int, str] = {}
    for link in chain.link_names:
        joint, offset = chain.link_anchor(link)
        if joint not in named and np.allclose(offset, np.eye(4)):
            named[joint] = link
    names = [(named.get(-1, chain.base_link), -1)]
    names += [(named.get(i, f"link {i + 1}"), i) for i in range(chain.n_joints)]
    return names


def _radius(link: str, radii: float | Mapping[str, float]) -> float:
    value = radii.get(link) if isinstance(radii, Mapping) else radii
    if value is None:
        raise ValueError(f"radii: no radius for link '{link}'; give one per link or one for all")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"radii: the radius of link '{link}' must be > 0, got {value!r}")
    return float(value)


def frame_capsules(
    model: Any, radii: float | Mapping[str, float], *, base: bool = True
) -> tuple[LinkCapsule, ...]:
    """Capsules along the links of a chain, from each joint's origin to the next one's.

    Args:
        model: A :class:`~lpik.robots.chain.SerialChain` or a task model on one.
        radii: One radius for every link, or link name -> radius [m]; a link
            missing from the mapping gets no capsule (the base link included).
        base: Whether the base link (from the base frame to the first joint) has a capsule.

    Raises:
        ValueError: For a model that is not a chain or a radius that is not > 0.
    """
    chain = chain_of(model)
    capsules = []
    for link, joint in link_names(chain):
        if (joint < 0 and not base) or (isinstance(radii, Mapping) and link not in radii):
            continue
        if joint + 1 < chain.n_joints:
            end = chain.joints[joint + 1].origin[:3, 3]
        else:
            end = chain.tip_offset[:3, 3]
        capsules.append(LinkCapsule(link, joint, np.zeros(3), end.copy(), _radius(link, radii)))
    return tuple(capsules)


def urdf_capsules(model: Any, urdf_robot: Any) -> tuple[LinkCapsule, ...]:
    """Capsules from the ``<collision>`` cylinders and spheres of the chain's links.

    Args:
        model: The chain (or a task on it) read from ``urdf_robot``.
        urdf_robot: The parsed URDF (:func:`lpik.robots.urdf.parse_urdf`).

    Returns:
        The capsules of every link on the chain that has such primitives.
    """
    from lpik.robots.rotations import transform

    chain = chain_of(model)
    capsules = []
    for link in chain.link_names:
        element = urdf_robot.link_map.get(link)
        if element is None:
            continue
        joint, offset = chain.link_anchor(link)
        for collision in getattr(element, "collisions", None) or []:
            geometry, origin = collision.geometry, collision.origin
            pose = offset @ transform(
                (origin.xyz or (0, 0, 0)) if origin else (0, 0, 0),
                (origin.rpy or (0, 0, 0)) if origin else (0, 0, 0),
            )
            kind = type(geometry).__name__
            if kind == "Cylinder":
                half = 0.5 * float(geometry.length)
                a, b = pose @ [0, 0, -half, 1], pose @ [0, 0, half, 1]
            elif kind == "Sphere":
                a = b = pose @ [0, 0, 0, 1]
            else:
                continue
            capsules.append(LinkCapsule(link, joint, a[:3], b[:3], float(geometry.radius)))
    return tuple(capsules)


@dataclass(frozen=True, eq=False)
class RobotBodies:
    """A chain with its capsules and the self-collision pairs that are checked.

    Attributes:
        chain: The kinematic chain.
        capsules: The capsules of its links.
        self_pairs: Index pairs ``(i, j)`` into ``capsules`` checked against each other.
    """

    chain: SerialChain
    capsules: tuple[LinkCapsule, ...]
    self_pairs: tuple[tuple[int, int], ...] = ()

    @cached_property
    def axes(self) -> FloatArray:
        """The joints' unit axes in their own frames, shape (n, 3)."""
        return np.array([j.axis for j in self.chain.joints])

    @cached_property
    def revolute(self) -> NDArray[np.bool_]:
        """Which joints are revolute, shape (n,)."""
        return np.array([j.kind == "revolute" for j in self.chain.joints])

    def world_capsules(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Every capsule's ends in the world frame at ``q``.

        Returns:
            ``a`` (k, 3), ``b`` (k, 3) and the joint frames (n, 4, 4) they were placed with.
        """
        frames = self.chain.joint_frames(q)
        ends_a, ends_b = [], []
        for c in self.capsules:
            pose = np.eye(4) if c.joint < 0 else frames[c.joint]
            ends_a.append(pose[:3, :3] @ c.a + pose[:3, 3])
            ends_b.append(pose[:3, :3] @ c.b + pose[:3, 3])
        return np.array(ends_a).reshape(-1, 3), np.array(ends_b).reshape(-1, 3), frames


def candidate_self_pairs(
    capsules: Sequence[LinkCapsule], gap: int = SELF_COLLISION_GAP
) -> tuple[tuple[int, int], ...]:
    """Pairs of capsules on links whose joints are at least ``gap`` apart."""
    return tuple(
        (i, j)
        for i in range(len(capsules))
        for j in range(i + 1, len(capsules))
        if abs(capsules[i].joint - capsules[j].joint) >= gap
    )
