"""Collision avoidance in the step's LP: hard distance rows and the paper's potential field.

Two mechanisms, usable alone or together:

* **Hard distance rows** (the velocity damper of Faverjon and Tournassoud,
  "A local based approach for path planning of manipulators with a high
  number of degrees of freedom", ICRA 1987). For every pair closer than the
  influence distance ``d_i``, one labelled row bounds the approach along the
  normal in this step::

          -grad . (q - q0) <= xi dt max(d - d_s, 0) / (d_i - d_s)

  ``grad = d d / d q`` (:mod:`lpik.collision.distance`), ``xi`` the largest
  approach speed [m/s]. To first order the distance after the step is then
  at least ``d - r (d - d_s)`` with ``r = xi dt / (d_i - d_s)``, which is
  ``>= d_s`` as long as ``r <= 1``; lpik caps ``r`` at 1. A pair already
  closer than ``d_s`` (or overlapping) gets the same row, mirrored: the
  right-hand side is negative, so the row demands that the distance grow by
  ``r (d_s - d)`` in this step, back to ``d_s`` smoothly at the damper's rate
  (the step is then ``recovering``: :mod:`lpik.collision.recovery`). The rows go into
  the problem as ``G q <= h`` (:class:`DistanceRows`, a limit of
  :mod:`lpik.limits`), so ``lp1``, ``l1`` and ``lp2`` keep them and name the
  one that stops the arm, e.g. ``"collision panda_link5 - shelf"``. Under
  acceleration limits a pair beyond ``d_i`` that approaches faster than it
  could still brake to ``xi`` by ``d_i`` gets a row too, its stop ahead
  (:func:`braking_row`, the rule the joints keep to their end-stops), so that
  no pair meets its damper row faster than the joints can slow it.
* **Potential field** (the paper, sec. 1 and eq. 3, after Khatib, "Real-time
  obstacle avoidance for manipulators and mobile robots", IJRR 1986): the
  artificial generalized force of the criterion ``Z = 1/2 dq^T M dq - f^T q``
  is Khatib's FIRAS repulsion summed over the pairs within ``d_i``::

      f = dt sum_pairs eta (1/d - 1/d_i) / d^2 grad

  pointing the null-space motion away from the obstacles (``weighted``,
  ``robust``, ``lp2`` take ``f``). ``eta`` is the gain [m^3/s]; ``d`` is
  floored at :data:`DISTANCE_FLOOR` so that the force stays finite.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.bands import ROW_BRAKING_SHARE, braking_room, row_deceleration, stopping_distance
from lpik.collision import recovery
from lpik.collision.distance import Proximities, Proximity
from lpik.continuation import continued
from lpik.limits import Piece, StepContext
from lpik.linalg import back_substitution, forward_substitution, regular_count
from lpik.problem import Problem
from lpik.result import Result
from lpik.tolerances import FEASIBILITY_TOL
from lpik.types import FloatArray

#: Default largest approach speed ``xi`` of the velocity damper [m/s].
DEFAULT_APPROACH_SPEED = 0.5
#: Default gain ``eta`` of the potential field [m^3/s].
DEFAULT_FIELD_GAIN = 0.02
#: Smallest distance the potential field divides by [m].
DISTANCE_FLOOR = 1e-3
#: The field's own step (the step at ``p = 0`` that ``f`` alone drives) may take at
#: most this share of the room between a joint and its limits for the step.
FIELD_SHARE = 0.5
#: The mechanisms ``mechanism=`` accepts.
MECHANISMS = ("rows", "field", "both")
#: Right-hand side of a reserved row whose pair has no row this step: ``0 q <= 1e9`` never binds.
INACTIVE_RHS = 1e9


def damper_share(approach_speed: float, dt: float, safety: float, influence: float) -> float:
    """``r = xi dt / (d_i - d_s)``, capped at 1: the share of ``d - d_s`` one step may close."""
    return min(1.0, approach_speed * dt / (influence - safety))


def damper_row(distance, gradient, q0, share, safety, row):  # type: ignore[no-untyped-def]
    """The velocity damper's row of one pair within ``d_i``: ``row = -grad`` and its ``h``.

    ``row . q <= h`` bounds the approach in this step (the rule of
    :class:`DistanceRows`): ``h - row . q0 = r (d - d_s)``, on both sides of ``d_s``,
    so that inside it the row demands the increase ``r (d_s - d)``; plain loops, so
    that :mod:`lpik.fast.avoiding_step` compiles this very function
    (:func:`lpik.fast.twins.compiled_twin`). Returns NaN, leaving ``row`` as it
    is, for a pair whose distance hardly depends on ``q`` (its witness point on a
    joint's axis): a row that cannot change by the feasibility tolerance
    constrains nothing but would tie the ratio test at ``p = 0``.

    A pair inside ``d_s`` by no more than :data:`~lpik.tolerances.FEASIBILITY_TOL`
    is at ``d_s`` for this row, as for the recovery stage
    (:func:`lpik.collision.recovery.inside_pairs`): its row keeps the distance and
    demands no increase. An increase the check cannot tell from none, demanded of an
    arm whose command moves it along the pair, made every step infeasible: the arm
    stood 21 nm inside ``d_s`` for good, each step the braking safe step.
    """
    n = gradient.shape[0]
    steepest = 0.0
    for i in range(n):
        steepest = max(steepest, abs(gradient[i]))
    if steepest <= FEASIBILITY_TOL:
        return math.nan
    gap = distance - safety
    if -FEASIBILITY_TOL <= gap < 0.0:  # within the check's tolerance: at d_s
        gap = 0.0
    h = share * gap
    for i in range(n):
        row[i] = -gradient[i]
        h += row[i] * q0[i]
    return h


def braking_row(distance, gradient, q0, q_prev, qdd_min, qdd_max, dt, entry_step, influence,
                row):  # type: ignore[no-untyped-def]  # fmt: skip
    """The stop ahead of ``d_i``: a pair beyond it approaches no faster than it can brake.

    Under acceleration limits, a pair that meets ``d_i`` faster than the damper's
    ``xi dt`` (``entry_step``) gets a row there that asks more deceleration than the
    joints have. Beyond ``d_i``, with ``c = ROW_BRAKING_SHARE * sum_i |grad_i| qdd_i dt^2``
    (each joint's acceleration limit against the approach), the row::

        -grad . (q - q0) <= braking_room(d - d_i + stopping_distance(xi dt, c), c)

    lets the pair reach ``d_i`` at ``xi dt`` per step at most, braking by ``c`` a
    step (:func:`lpik.bands.braking_room`, the rule the joints keep to their
    end-stops). At ``d = d_i`` the bound is ``xi dt``, the damper's own. Plain
    loops, compiled as they are (:mod:`lpik.fast.avoiding_step`).

    Returns:
        ``h`` with ``row = -grad``; NaN (``row`` as it is) where no row is needed:
        no step within the acceleration bands approaches faster than the bound
        (``max(-grad . (q0 - q_prev), 0)`` plus full acceleration towards the pair:
        so also for a ``q_prev`` that the bands take at rest), the distance hardly
        depends on ``q`` (as :func:`damper_row`), or a joint that moves the pair has
        no acceleration limit (it can stop at once).
    """
    n = gradient.shape[0]
    steepest = moving = 0.0
    for i in range(n):
        steepest = max(steepest, abs(gradient[i]))
        moving -= gradient[i] * (q0[i] - q_prev[i])
    # the approach -grad . dq: braked by lowering it, sped up by raising it
    against = row_deceleration(gradient, -1.0, qdd_min, qdd_max, dt)
    toward = row_deceleration(gradient, 1.0, qdd_min, qdd_max, dt)
    if steepest <= FEASIBILITY_TOL or not (0.0 < against < math.inf and toward < math.inf):
        return math.nan
    decel = ROW_BRAKING_SHARE * against
    bound = braking_room(distance - influence + stopping_distance(entry_step, decel), decel)
    if max(moving, 0.0) + toward <= bound:
        return math.nan
    h = bound
    for i in range(n):
        row[i] = -gradient[i]
        h += row[i] * q0[i]
    return h


def capsule_reach(joints, radii, ends, origins, axes, revolute, q0, q_prev, qdd_min, qdd_max,
                  dt, reach):  # type: ignore[no-untyped-def]  # fmt: skip
    """How far beyond ``d_i`` a capsule's pairs may need a stop ahead: two bounds, into ``reach``.

    A pair needs :func:`braking_row` only where the most it can approach in one
    step, ``u``, exceeds what it can still brake from: ``u + u^2 / (2 c)`` at most,
    with ``c >= ROW_BRAKING_SHARE sum_i |grad_i| b_i`` the rule's deceleration (``b_i``:
    joint ``i``'s smaller acceleration limit times ``dt^2``, ``a_i`` the larger). With
    ``s_i = |q0_i - q_prev_i| + a_i``, ``u <= sum_i |grad_i| s_i``, and each ``|grad_i|``
    is at most the witness point's lever about joint ``i`` (the capsule's farther end
    plus its radius; 1 for a prismatic joint). Two bounds on the braking distance:

    * ``reach[c]``: by Cauchy-Schwarz, ``u^2 / (2 c) <= sum_i |grad_i| s_i^2 / (2
      ROW_BRAKING_SHARE b_i)``, each joint's own braking;
    * ``reach[k + c]``: ``u <= w + A``, with ``w`` the capsule's speed in the last
      step (its faster end, plus its radius times its turn) and ``A = sum_i lever_i
      a_i``; and ``u^2 / (2 c) <= u K / (2 ROW_BRAKING_SHARE)``, ``K = max_i s_i / b_i``
      over every joint.

    Both add over a pair's two capsules, so a pair farther than ``d_i`` plus the
    lesser sum has no such row, and its gradient is not needed.

    Args:
        joints: Each capsule's joint (-1: the base), (k,).
        radii: Each capsule's radius, (k,).
        ends: Each capsule's ends ``a, b`` in the world, (k, 6).
        origins: Each joint's origin in the world, (n, 3).
        axes: Each joint's unit axis in the world, (n, 3).
        revolute: Whether each joint is revolute, (n,).
        q0: The joints now, (n,).
        q_prev: The joints one period ago, (n,).
        qdd_min: The lower acceleration limits (``-inf``: none), (n,).
        qdd_max: The upper acceleration limits (``inf``: none), (n,).
        dt: The control period [s].
        reach: (2 k,), written: 0 everywhere without acceleration limits (no stop
            ahead), ``inf`` for a capsule that a joint without them moves.
    """
    n, k, dt2 = q0.shape[0], joints.shape[0], dt * dt
    ratio, limited = 0.0, False
    for i in range(n):
        slow = min(-qdd_min[i], qdd_max[i]) * dt2
        if slow < math.inf:
            limited = True
            ratio = max(ratio, (abs(q0[i] - q_prev[i]) + max(-qdd_min[i], qdd_max[i]) * dt2) / slow)
    for c in range(k):
        own = spread = turn = 0.0
        ax = ay = az = bx = by = bz = 0.0  # the ends' motion in the last step
        for i in range(int(joints[c]) + 1):
            slow = min(-qdd_min[i], qdd_max[i]) * dt2
            if not slow < math.inf:
                own = spread = math.inf
                break
            fast, last = max(-qdd_min[i], qdd_max[i]) * dt2, q0[i] - q_prev[i]
            zx, zy, zz = axes[i, 0] * last, axes[i, 1] * last, axes[i, 2] * last
            lever = 1.0
            if revolute[i]:  # z_i x (end - o_i) last_i
                rx, ry, rz = (ends[c, 0] - origins[i, 0], ends[c, 1] - origins[i, 1],
                              ends[c, 2] - origins[i, 2])  # fmt: skip
                sx, sy, sz = (ends[c, 3] - origins[i, 0], ends[c, 4] - origins[i, 1],
                              ends[c, 5] - origins[i, 2])  # fmt: skip
                lever = radii[c] + math.sqrt(max(rx * rx + ry * ry + rz * rz,
                                                 sx * sx + sy * sy + sz * sz))  # fmt: skip
                turn += abs(last)
                ax, ay, az = ax + zy * rz - zz * ry, ay + zz * rx - zx * rz, az + zx * ry - zy * rx
                bx, by, bz = bx + zy * sz - zz * sy, by + zz * sx - zx * sz, bz + zx * sy - zy * sx
            else:
                ax, ay, az, bx, by, bz = ax + zx, ay + zy, az + zz, bx + zx, by + zy, bz + zz
            step = abs(last) + fast
            own += lever * (step + step * step / (2.0 * ROW_BRAKING_SHARE * slow))
            spread += lever * fast
        speed = math.sqrt(max(ax * ax + ay * ay + az * az, bx * bx + by * by + bz * bz))
        speed += radii[c] * turn + spread
        reach[c] = own if limited else 0.0
        reach[k + c] = speed * (1.0 + ratio / (2.0 * ROW_BRAKING_SHARE)) if limited else 0.0


def approach_row(distance, gradient, q0, q_prev, qdd_min, qdd_max, dt, damper,
                 row):  # type: ignore[no-untyped-def]  # fmt: skip
    """One pair's row: the damper's within ``d_i`` (:func:`damper_row`), the stop ahead beyond.

    ``damper``: ``(r, d_s, d_i)``, as :func:`damper_share` and the scene give them.
    Beyond ``d_i`` (:func:`braking_row`) the damper's speed at ``d_i``, ``r (d_i - d_s)``,
    is the speed the stop ahead brakes to. Returns NaN where the pair has no row.
    """
    share, safety, influence = damper[0], damper[1], damper[2]
    if distance < influence:
        return damper_row(distance, gradient, q0, share, safety, row)
    return braking_row(distance, gradient, q0, q_prev, qdd_min, qdd_max, dt,
                       share * (influence - safety), influence, row)  # fmt: skip


@dataclass(frozen=True, eq=False)
class DistanceRows:
    """The velocity damper's rows, one per pair within the influence distance (a limit).

    Under acceleration limits a pair beyond ``d_i`` that approaches faster than it
    could brake to the damper's speed at ``d_i`` has a row too: its stop ahead
    (:func:`braking_row`).

    Args:
        proximities: The robot's bodies and the scene.
        approach_speed: ``xi``, the largest approach speed of a pair [m/s] (> 0).
        inside_only: Rows only for the pairs inside the safety distance (the
            potential field's guarantee: :meth:`CollisionAvoidance.rows`).
        accelerations: The joints' ``(qdd_min, qdd_max)`` [rad/s^2 or m/s^2, ``-inf``
            and ``inf``: none], for the stops ahead of ``d_i``; None: none.
    """

    proximities: Proximities
    approach_speed: float = DEFAULT_APPROACH_SPEED
    inside_only: bool = False
    accelerations: tuple[FloatArray, FloatArray] | None = None

    def __post_init__(self) -> None:
        xi = self.approach_speed
        if not (isinstance(xi, int | float) and np.isfinite(xi) and xi > 0):
            raise ValueError(f"approach_speed: must be a finite number > 0, got {xi!r}")

    def pair_rows(
        self, q0: FloatArray, dt: float, q_prev: FloatArray | None = None
    ) -> tuple[list[int], FloatArray, FloatArray]:
        """The rows at ``q0`` for a step of ``dt`` [s] and which pairs they belong to.

        ``q_prev``: the joints one period ago (None: at rest), for the stops ahead.

        Returns:
            The indices of the pairs with a row in ``proximities.at(q0)``, ``G (r, n)``
            and ``h (r,)`` (:func:`approach_row`).
        """
        scene = self.proximities.scene
        d_s, d_i = scene.safety_distance, scene.influence_distance
        damper = (damper_share(self.approach_speed, dt, d_s, d_i), d_s, d_i)
        n, before = q0.size, q0 if q_prev is None else q_prev
        found = self.proximities.at(q0)
        reach, qdd_min, qdd_max = np.full(len(found), d_i), np.full(n, -np.inf), np.full(n, np.inf)
        if self.inside_only:
            reach[:] = d_s - FEASIBILITY_TOL
        elif self.accelerations is not None:
            qdd_min, qdd_max = self.accelerations
            reach += self._pair_reach(q0, before, qdd_min, qdd_max, dt)
        pairs, G, h = [], [], []
        for k, p in enumerate(found):
            if p.distance >= reach[k]:
                continue
            row = np.zeros(n)
            rhs = approach_row(p.distance, p.gradient, q0, before, qdd_min, qdd_max, dt, damper,
                               row)  # fmt: skip
            if not math.isnan(rhs):
                pairs.append(k)
                G.append(row)
                h.append(rhs)
        return pairs, np.array(G).reshape(-1, n), np.array(h)

    def _pair_reach(
        self, q0: FloatArray, q_prev: FloatArray, qdd_min: FloatArray, qdd_max: FloatArray,
        dt: float,
    ) -> FloatArray:  # fmt: skip
        """How far beyond ``d_i`` each pair of ``proximities.at`` may need its stop ahead."""
        bodies = self.proximities.bodies
        ends_a, ends_b, axes, origins = self.proximities.placed(q0)
        joints = np.array([c.joint for c in bodies.capsules], dtype=np.float64)
        radii = np.array([c.radius for c in bodies.capsules], dtype=np.float64)
        reach = np.zeros(2 * joints.size)
        capsule_reach(joints, radii, np.hstack([ends_a, ends_b]), origins, axes,
                      bodies.revolute, q0, q_prev, qdd_min, qdd_max, dt, reach)  # fmt: skip
        k = joints.size
        own, moving = np.append(reach[:k], 0.0), np.append(reach[k:], 0.0)  # [k]: no capsule
        pairs = [(i, k) for i, _ in self.proximities.obstacle_pairs] + list(bodies.self_pairs)
        first, second = np.array(pairs, dtype=np.int64).reshape(-1, 2).T
        return np.minimum(own[first] + own[second], moving[first] + moving[second])

    def rows(
        self, q0: FloatArray, dt: float, q_prev: FloatArray | None = None
    ) -> tuple[FloatArray, FloatArray, tuple[str, ...]]:
        """``G (r, n)``, ``h (r,)`` and labels of the rows at ``q0`` for a step of ``dt`` [s]."""
        pairs, G, h = self.pair_rows(q0, dt, q_prev)
        found = self.proximities.at(q0)
        return G, h, tuple(found[k].label for k in pairs)

    def apply(self, context: StepContext) -> Piece:
        """Labelled rows ``G q <= h`` for this step (none when no pair is within ``d_i``)."""
        q_prev = None if context.q_prev is None else np.asarray(context.q_prev, dtype=np.float64)
        G, h, names = self.rows(np.asarray(context.q0, dtype=np.float64), context.dt, q_prev)
        if not names:
            return Piece()
        return Piece(G=G, h=h, row_labels=names)


def repulsion(distance: float, gain: float, influence: float) -> float:
    """Khatib's FIRAS magnitude ``eta (1/d - 1/d_i) / d^2`` (0 beyond ``d_i``) [m/s]."""
    if distance >= influence:
        return 0.0
    d = max(distance, DISTANCE_FLOOR)
    return gain * (1.0 / d - 1.0 / influence) / d**2


def field_force(found: Sequence[Proximity], gain: float, influence: float, dt: float) -> FloatArray:
    """The paper's artificial generalized force ``f`` (eq. 3) from Khatib's field, shape (n,)."""
    if not found:
        return np.zeros(0)
    f = np.zeros_like(found[0].gradient)
    for p in found:
        f += dt * repulsion(p.distance, gain, influence) * p.gradient
    return f


def field_scale(
    force: FloatArray, J: FloatArray, M: FloatArray, lo: FloatArray, hi: FloatArray,
    rest: FloatArray | None = None, rows: tuple[FloatArray, FloatArray] | None = None,
) -> float:  # fmt: skip
    """The largest ``s`` in [0, 1] for which the step ``f`` alone drives stays in the limits.

    At ``p = 0`` the paper's criterion (eq. 3) with eq. 12 moves ``dq = rest + s a``,
    ``[[M, J^T], [J, 0]] [a; lam] = [force; 0]`` (the null-space share of the
    force, :func:`null_space_motion`) and ``rest`` the same for the rest of the
    criterion's ``f`` (None: 0); :func:`field_share` bounds ``s``. A field too
    strong for a joint at its limit, or one that pushed a pair of links against
    its own row while it pushed another pair apart, made every step infeasible.
    """
    a = null_space_motion(J, M, force)
    base = np.zeros_like(a) if rest is None else np.asarray(rest, dtype=np.float64)
    G, g = (np.zeros((0, a.size)), np.zeros(0)) if rows is None else rows
    return field_share(a, base, lo, hi, np.asarray(G, dtype=np.float64),
                       np.asarray(g, dtype=np.float64))  # fmt: skip


def field_share(a, base, lo, hi, G, g):  # type: ignore[no-untyped-def]
    """:func:`field_scale`'s ``s``: the field's motion ``s a`` on top of the rest's ``base``.

    ``s a`` may take at most :data:`FIELD_SHARE` of the room between ``base`` and
    ``[lo, hi]`` on each joint, so that the command keeps the rest of it, and may
    not carry ``base`` past any of the rows ``G dq <= g`` (the distance rows, with
    ``mechanism="both"``): LP2 keeps a solution at ``p = 0``. Plain loops: the
    compiled step (:func:`lpik.fast.step.field_in_state`) runs this function itself.
    """
    n = a.shape[0]
    scale = 1.0
    for i in range(n):
        if a[i] > 0:
            scale = min(scale, max(0.0, FIELD_SHARE * (hi[i] - base[i])) / a[i])
        elif a[i] < 0:
            scale = min(scale, min(0.0, FIELD_SHARE * (lo[i] - base[i])) / a[i])
    for k in range(G.shape[0]):
        along, used = 0.0, 0.0
        for i in range(n):
            along += G[k, i] * a[i]
            used += G[k, i] * base[i]
        if along > 0:
            scale = min(scale, max(0.0, g[k] - used) / along)
    return scale


def _svd(A):  # type: ignore[no-untyped-def]  # the compiled twin binds lpik.fast.jacobi's
    return np.linalg.svd(A)


def null_space_motion(J, M, f):  # type: ignore[no-untyped-def]
    """The step at ``p = 0`` that ``f`` drives (eq. 3 with eq. 12): the null-space share of ``f``.

    ``[[M, J^T], [J, 0]] [dq; lam] = [f; 0]``, with ``M`` symmetric positive
    definite, by the decomposition of LP2's singular path
    (:func:`lpik.methods.singular.singular_core`): with ``M = L L^T`` and ``B = J
    L^-T``, ``dq = L^-T (I - P) L^-1 f``, ``P`` the projection onto the row space of
    ``B``, its right singular vectors of the singular values that count as nonzero
    (:func:`lpik.linalg.regular_count`; below them is rounding, whose
    vectors are not orthogonal to the others). So ``J dq = 0`` and ``M dq - f`` lies
    in the row space of ``J``; where ``J`` is rank deficient ``dq`` is still unique
    (``lam`` is not). Plain loops: the compiled step runs this function with the
    Jacobi SVD of :mod:`lpik.fast.jacobi` in place of numpy's.
    """
    m, n = J.shape
    L = np.linalg.cholesky(M)
    y = forward_substitution(L, f.reshape(n, 1))[:, 0]  # L^-1 f
    if m > 0:
        _, sv, Vt = _svd(forward_substitution(L, J.T.copy()).T.copy())  # B = J L^-T
        for j in range(regular_count(sv)):
            along = 0.0
            for i in range(n):
                along += Vt[j, i] * y[i]
            for i in range(n):
                y[i] -= along * Vt[j, i]
    dq = np.empty(n)
    back_substitution(L, y, dq)  # L^-T (I - P) L^-1 f
    return dq


def field_scale_for(force: FloatArray, problem: Problem) -> float:
    """:func:`field_scale` within ``problem``'s own room for the step.

    The room is the step's bounds (end-stops, velocity and, under acceleration
    limits, the band around the arm's motion: :meth:`~lpik.problem.Problem.step_bounds`)
    and its rows (a scene's distance rows with ``mechanism="both"``).
    Where the step is solved around the motion (:mod:`lpik.continuation`), the
    field's share is measured in that frame: the room is the bounds less the motion
    kept, and the rest of the step at ``p = 0`` is the continued criterion's (its
    ``f`` less the decaying pull back to the least motion, :func:`continued`). So
    under acceleration limits the field's motion grows as fast as the joints may
    speed up; a field measured against the velocity room alone asked an arm at rest
    for a step it could not take, and every step within the influence distance was
    infeasible (the arm stopped by the safe step, its status ``infeasible``).
    """
    J, M = np.atleast_2d(problem.J), problem.M
    frame = problem if problem.last is None else continued(problem)
    lower, upper = frame.step_bounds()[:2]
    rows = (frame.G, frame.h - frame.G @ frame.q0)
    return field_scale(force, J, M, lower, upper, null_space_motion(J, M, frame.f), rows)


def with_force(problem: Problem, force: FloatArray) -> Problem:
    """``problem`` with the field's ``force`` added to ``f``, scaled by :func:`field_scale_for`."""
    return problem.replace(f=problem.f + field_scale_for(force, problem) * force)


@dataclass(frozen=True, eq=False)
class CollisionAvoidance:
    """What a closed loop needs for collision avoidance: rows, force, the closest pair.

    Attributes:
        proximities: The robot's bodies and the scene.
        mechanism: ``"rows"`` (velocity damper), ``"field"`` (potential field) or ``"both"``.
        approach_speed: ``xi`` of the damper [m/s].
        field_gain: ``eta`` of the field [m^3/s].
    """

    proximities: Proximities
    mechanism: str = "rows"
    approach_speed: float = DEFAULT_APPROACH_SPEED
    field_gain: float = DEFAULT_FIELD_GAIN

    def __post_init__(self) -> None:
        if self.mechanism not in MECHANISMS:
            raise ValueError(
                f"mechanism: must be one of {', '.join(MECHANISMS)}; got {self.mechanism!r}"
            )
        eta = self.field_gain
        if not (isinstance(eta, int | float) and np.isfinite(eta) and eta >= 0):
            raise ValueError(f"field_gain: must be a finite number >= 0, got {eta!r}")
        DistanceRows(self.proximities, self.approach_speed)  # checks approach_speed

    @property
    def scene(self) -> Any:
        """The scene."""
        return self.proximities.scene

    def rows(self, accelerations: tuple[FloatArray, FloatArray] | None = None) -> DistanceRows:
        """The hard rows: every pair within ``d_i``; with the field alone, the pairs inside ``d_s``.

        The field's own force has no hard guarantee; inside ``d_s`` its rows make the
        distance grow back as the damper's do (:mod:`lpik.collision.recovery`).
        ``accelerations``: the joints' ``(qdd_min, qdd_max)``, for the damper's stops
        ahead of ``d_i`` (:func:`braking_row`); None: none.
        """
        inside_only = self.mechanism == "field"
        return DistanceRows(self.proximities, self.approach_speed, inside_only,
                            None if inside_only else accelerations)  # fmt: skip

    def limits(
        self, accelerations: tuple[FloatArray, FloatArray] | None = None
    ) -> list[DistanceRows]:
        """The hard rows as a limit (:meth:`rows`)."""
        return [self.rows(accelerations)]

    def with_field(self, problem: Problem, dt: float) -> Problem:
        """``problem`` with the field's force added to its ``f`` (unchanged for the rows alone).

        The force (:meth:`field_at` ``problem.q0``) is scaled by
        :func:`field_scale_for`, so that LP2's step at ``p = 0`` stays within the
        step's own room, acceleration bands included.
        """
        force = self.field_at(problem.q0, dt)
        return problem if force is None else with_force(problem, force)

    def field_at(self, q: FloatArray, dt: float) -> FloatArray | None:
        """The field's force at ``q`` (:func:`field_force`), or None where there is none."""
        if self.mechanism == "rows":
            return None
        found = self.proximities.at(q)
        force = field_force(found, self.field_gain, self.scene.influence_distance, dt)
        return force if force.size and force.any() else None

    def inside(self, q: FloatArray) -> dict[str, float]:
        """The pairs closer than ``d_s`` at ``q``: their rows' labels -> signed distance [m]."""
        found = self.proximities.at(q)
        return recovery.inside_pairs([p.label for p in found], [p.distance for p in found],
                            self.scene.safety_distance)  # fmt: skip

    def recovered(
        self, problem: Problem, result: Result, dt: float, least_error: recovery.LeastError,
        inside: Mapping[str, float] | None = None,
        largest_share: recovery.LargestShare | None = None,
    ) -> Result:  # fmt: skip
        """The recovery stage: from inside ``d_s`` the distance grows back.

        The rule of :mod:`lpik.collision.recovery`; ``result`` as it is where no pair
        is inside.

        Args:
            problem: The step's problem (a pair inside without a row, the field's in a
                compiled step, gets its row here).
            result: The method's step on it.
            dt: Control period [s].
            least_error: The least-error LP (:data:`lpik.collision.recovery.LeastError`).
            inside: The pairs inside ``d_s`` at ``problem.q0`` where the caller has them
                (:meth:`inside`, or a compiled step's distances); None: found here.
            largest_share: The largest-share LP
                (:data:`lpik.collision.recovery.LargestShare`; None: HiGHS's).
        """
        if inside is None:
            inside = self.inside(problem.q0)
        if not inside:
            return result
        problem = self.with_rows(problem, inside, dt)
        return recovery.recovered(problem, result, inside, least_error, largest_share)

    def with_rows(self, problem: Problem, inside: Mapping[str, float], dt: float) -> Problem:
        """``problem`` with a damper's row for every pair of ``inside`` without one.

        A pair's row is missing where the problem has no row of its label that demands
        an increase (:func:`lpik.collision.recovery.demanding_rows`): the field's pairs,
        or a controller's reserved rows left inactive (``0 q <= INACTIVE_RHS``). The
        rows of those pairs (one per capsule pair inside ``d_s``) are appended.
        """
        covered = {str(problem.row_labels[k]) for k in recovery.inside_rows(problem, inside)}
        if covered >= set(inside):
            return problem  # every pair inside has its row already (the rows' mechanism)
        pairs, rows, rhs = DistanceRows(self.proximities, self.approach_speed, True).pair_rows(
            problem.q0, dt)  # fmt: skip
        found = self.proximities.at(problem.q0)
        extra = [(found[k].label, row, b) for k, row, b in zip(pairs, rows, rhs)
                 if found[k].label in inside and found[k].label not in covered]  # fmt: skip
        if not extra:
            return problem
        return problem.replace(
            G=np.vstack([problem.G, *(row for _, row, _ in extra)]),
            h=np.concatenate([problem.h, [b for _, _, b in extra]]),
            row_labels=(*problem.row_labels, *(label for label, _, _ in extra)),
        )

    def closest(self, q: FloatArray) -> tuple[float, str]:
        """Smallest signed distance at ``q`` [m] and the pair's name."""
        return self.proximities.closest(q)
