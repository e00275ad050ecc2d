"""Signed distances between the robot's capsules, the obstacles and each other (coal).

Every distance, witness point and normal comes from ``coal`` (the maintained
successor of hpp-fcl): ``coal.distance`` with signed distances, so that
overlapping shapes give a negative distance (their penetration depth) and a
normal that still says how to separate them. lpik adds the kinematics: the
velocity of each witness point on the robot, hence the rate of change of the
distance, ``d_dot = grad . q_dot`` with ``grad = -n^T (J_1 - J_2)`` (``n``
the unit normal from the robot's body 1 toward body 2; ``J_2 = 0`` for a
fixed obstacle). Tests hold ``grad`` to a finite difference of the distance.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property, partial
from typing import Any

import numpy as np

from lpik.collision.bodies import RobotBodies, candidate_self_pairs
from lpik.collision.shapes import Scene, capsule_geometry, coal_module
from lpik.labels import collision_label, pair_name
from lpik.types import FloatArray


@dataclass(frozen=True, eq=False)
class Proximity:
    """How close one pair is at one configuration.

    Attributes:
        body: The robot's link.
        other: The obstacle, or the other link.
        distance: Signed distance [m]; negative when the two overlap.
        point: Witness point on the robot's body, world frame, shape (3,) [m].
        other_point: Witness point on the other body, shape (3,) [m].
        normal: Unit normal from the robot's body toward the other, shape (3,).
        velocity: ``J_1 - J_2``, the Jacobian (3, n) of the witness points' relative
            velocity, computed when first asked for (most pairs are far away).
    """

    body: str
    other: str
    distance: float
    point: FloatArray
    other_point: FloatArray
    normal: FloatArray
    velocity: Callable[[], FloatArray]

    @cached_property
    def gradient(self) -> FloatArray:
        """``d distance / d q = -n^T (J_1 - J_2)`` at this configuration, shape (n,) [m/rad]."""
        return -self.normal @ self.velocity()

    @property
    def pair(self) -> str:
        """The pair's name, ``"<link> - <other>"``."""
        return pair_name(self.body, self.other)

    @property
    def label(self) -> str:
        """The label of the pair's distance row, ``"collision <link> - <other>"``."""
        return collision_label(self.body, self.other)


def joint_axes(bodies: RobotBodies, frames: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Every joint's unit axis and origin in the world frame, (n, 3) each."""
    axes = np.einsum("kij,kj->ki", frames[:, :3, :3], bodies.axes)
    return axes, frames[:, :3, 3]


def point_jacobian(
    bodies: RobotBodies, axes: FloatArray, origins: FloatArray, joint: int, point: FloatArray
) -> FloatArray:
    """Jacobian (3, n) of the velocity of ``point``, fixed in the frame of ``joint``.

    Column ``k <= joint``: ``z_k x (point - o_k)`` for a revolute joint, ``z_k`` for a
    prismatic one (the geometric Jacobian's linear rows); zero beyond ``joint``.
    """
    jac = np.zeros((3, axes.shape[0]))
    k = joint + 1
    if k > 0:
        lever = np.cross(axes[:k], point - origins[:k])
        jac[:, :k] = np.where(bodies.revolute[:k, None], lever, axes[:k]).T
    return jac


#: GJK's and EPA's tolerance [m]. coal's default (1e-6) lets GJK stop up to a micrometre
#: from the closest points of a capsule and a box; on such polytopes both end on an exact
#: face well before this tighter one (tests: equal to closed forms to 1e-9).
GJK_TOLERANCE = 1e-12


def distance_request() -> Any:
    """A coal request for signed distances with witness points (reusable across calls)."""
    request = coal_module().DistanceRequest()
    request.enable_signed_distance = True
    request.gjk_tolerance = GJK_TOLERANCE
    request.epa_tolerance = GJK_TOLERANCE
    return request


def signed_distance(shape_1: tuple[Any, Any], shape_2: tuple[Any, Any], request: Any = None):
    """The signed distance (by coal) between two placed shapes: distance, witness points, normal.

    ``request``: a :func:`distance_request` to reuse; a new one when None.
    """
    coal = coal_module()
    request = distance_request() if request is None else request
    result = coal.DistanceResult()
    distance = coal.distance(shape_1[0], shape_1[1], shape_2[0], shape_2[1], request, result)
    return (
        float(distance),
        np.array(result.getNearestPoint1()),
        np.array(result.getNearestPoint2()),
        np.array(result.normal),
    )


class Proximities:
    """The distances between a robot's bodies and a scene, self-collision included.

    Obstacle shapes are built once; the robot's are placed at each call.
    """

    def __init__(self, bodies: RobotBodies, scene: Scene) -> None:
        """Keep the bodies and the scene; build the obstacles' coal shapes."""
        self.bodies = bodies
        self.scene = scene
        self._obstacles = [(o.name, o.geometry()) for o in scene.obstacles]
        self._request = distance_request()
        #: The last ``q`` asked for: its key, its proximities and :meth:`placed`'s arrays.
        self._cache: tuple[bytes, list[Proximity], tuple[FloatArray, ...]] | None = None
        #: ``(capsule, obstacle)`` index pairs, in the order of :meth:`at` (the base,
        #: which does not move, keeps its distances to the obstacles: none are checked).
        self.obstacle_pairs = tuple(
            (i, o)
            for i, capsule in enumerate(bodies.capsules)
            if capsule.joint >= 0
            for o in range(len(scene.obstacles))
        )

    def at(self, q: Sequence[float] | FloatArray) -> list[Proximity]:
        """Every checked pair's :class:`Proximity` at ``q`` (robot-obstacle pairs first)."""
        q = np.asarray(q, dtype=np.float64)
        key = q.tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        capsules = self.bodies.capsules
        ends_a, ends_b, frames = self.bodies.world_capsules(q)
        axes, origins = joint_axes(self.bodies, frames)
        placed = [capsule_geometry(ends_a[i], ends_b[i], c.radius) for i, c in enumerate(capsules)]
        found: list[Proximity] = []
        for i, o in self.obstacle_pairs:
            name, shape = self._obstacles[o]
            d, p1, p2, n = signed_distance(placed[i], shape, self._request)
            jac = partial(point_jacobian, self.bodies, axes, origins, capsules[i].joint, p1)
            found.append(Proximity(capsules[i].link, name, d, p1, p2, n, jac))
        for i, j in self.bodies.self_pairs:
            d, p1, p2, n = signed_distance(placed[i], placed[j], self._request)
            rel = partial(
                self._relative, axes, origins, capsules[i].joint, p1, capsules[j].joint, p2
            )
            found.append(Proximity(capsules[i].link, capsules[j].link, d, p1, p2, n, rel))
        self._cache = (key, found, (ends_a, ends_b, axes, origins))
        return found

    def placed(self, q: Sequence[float] | FloatArray) -> tuple[FloatArray, ...]:
        """The bodies as :meth:`at` placed them at ``q``: ``(ends_a, ends_b, axes, origins)``.

        Every capsule's two ends in the world, (k, 3) each, and every joint's unit axis
        and origin, (n, 3) each; computed once per ``q`` with the proximities.
        """
        self.at(q)
        assert self._cache is not None
        return self._cache[2]

    def _relative(
        self, axes: FloatArray, origins: FloatArray, j1: int, p1: FloatArray, j2: int,
        p2: FloatArray,
    ) -> FloatArray:  # fmt: skip
        """``J_1 - J_2`` of two witness points on two links, (3, n)."""
        jac = point_jacobian(self.bodies, axes, origins, j1, p1)
        return jac - point_jacobian(self.bodies, axes, origins, j2, p2)

    def closest(self, q: Sequence[float] | FloatArray) -> tuple[float, str]:
        """The smallest signed distance at ``q`` [m] and its pair (``(inf, "")`` when none)."""
        found = self.at(q)
        if not found:
            return float("inf"), ""
        best = min(found, key=lambda p: p.distance)
        return best.distance, best.pair


#: Configurations drawn (uniformly within the end-stops, fixed seed) to find the capsule
#: pairs that touch by design (:func:`touching_everywhere`).
DESIGN_SAMPLES = 128


def robot_bodies(
    model: Any,
    capsules: Sequence[Any],
    home: Sequence[float] | FloatArray | None,
    *,
    self_collision: bool = True,
    touching: float = 0.0,
) -> RobotBodies:
    """A :class:`RobotBodies` with the documented self-collision pair filter.

    Of the capsule pairs on links at least ``SELF_COLLISION_GAP`` joints apart,
    those closer than ``touching`` at every one of :data:`DESIGN_SAMPLES`
    configurations are dropped: they touch by design (two capsules round one
    joint housing), no step can move them apart, and their rows would keep the
    arm recovering from a contact it is built with (the "always in collision"
    pairs of a motion planner's allowed-collision matrix). With a ``home``,
    the pairs closer than ``touching`` there are dropped too.

    Args:
        model: The chain or a task on it.
        capsules: Its capsules (:func:`~lpik.collision.bodies.frame_capsules`,
            :func:`~lpik.collision.bodies.urdf_capsules`).
        home: The home configuration; pairs closer than ``touching`` there are
            dropped (they touch by design). ``None``: only the pairs that touch
            everywhere are dropped.
        self_collision: Whether to check self-collision at all.
        touching: Distance under which a pair counts as touching [m].
    """
    chain = getattr(model, "kinematics", model)
    bodies = RobotBodies(chain, tuple(capsules))
    if not self_collision:
        return bodies
    pairs = candidate_self_pairs(bodies.capsules)
    dropped = touching_everywhere(bodies, pairs, design_samples(chain), touching)
    if home is not None:
        dropped |= touching_everywhere(bodies, pairs, [np.asarray(home, float)], touching)
    return RobotBodies(chain, bodies.capsules, tuple(p for p in pairs if p not in dropped))


def design_samples(chain: Any) -> list[FloatArray]:
    """:data:`DESIGN_SAMPLES` configurations uniform within the end-stops (a fixed seed)."""
    low = np.clip(np.asarray(chain.q_min, dtype=np.float64), -np.pi, np.pi)
    high = np.clip(np.asarray(chain.q_max, dtype=np.float64), -np.pi, np.pi)
    draws = np.random.default_rng(0).random((DESIGN_SAMPLES, low.size))
    return list(low + (high - low) * draws)


def touching_everywhere(
    bodies: RobotBodies, pairs: Sequence[tuple[int, int]], configurations: Sequence[FloatArray],
    touching: float,
) -> set[tuple[int, int]]:  # fmt: skip
    """The ``pairs`` of ``bodies``' capsules closer than ``touching`` at every configuration."""
    left = set(pairs)
    request = distance_request()
    for q in configurations:
        if not left:
            break
        ends_a, ends_b, _ = bodies.world_capsules(q)
        placed = {}
        for i, j in tuple(left):
            for k in (i, j):
                if k not in placed:
                    placed[k] = capsule_geometry(ends_a[k], ends_b[k], bodies.capsules[k].radius)
            if signed_distance(placed[i], placed[j], request)[0] > touching:
                left.discard((i, j))
    return left
