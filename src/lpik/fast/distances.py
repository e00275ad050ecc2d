"""Signed distances of a capsule to a sphere, capsule, box or half-space, compiled (numba).

Each kernel gives what ``coal.distance`` gives with signed distances for the
same pair (:mod:`lpik.collision.distance`), and tests hold the two equal to
1e-9 on tens of thousands of random pairs, overlapping ones included. The
first shape is always the robot's capsule, a segment ``a``-``b`` with a
radius; ``out`` receives the signed distance, the witness point on the
capsule, the one on the other shape and the unit normal from the first
toward the second (10 floats). Each follows coal's own rule:

* capsule - sphere and capsule - capsule: coal's closed forms
  (``details::sphereCapsuleDistance`` and ``ShapeShapeDistance<Capsule,
  Capsule>``, after Ericson, *Real-Time Collision Detection*, 5.1.9),
  with their thresholds for points and parallel segments;
* capsule - half-space: coal's ``details::halfspaceDistance``: the
  capsule's support point opposite the normal (its centre when the axis is
  within 1e-12 of parallel to the boundary);
* capsule - box: coal runs GJK and EPA on the segment and the box (both
  polytopes, so both end on an exact face) and inflates by the radius. When
  the segment misses the box the answer is the segment's distance to the box
  less the radius, with the closest points; when it meets the box it is the
  minimum translation that separates them (the penetration depth of EPA, not
  the depth of the segment's deepest point), found here as the smallest
  support of the Minkowski difference over its face normals: the box's three
  axes and the cross products of the segment with them, both signs. This
  holds with the tolerance lpik asks of GJK and EPA
  (:data:`lpik.collision.distance.GJK_TOLERANCE`); with coal's default (1e-6)
  GJK may stop up to a micrometre short, and within that tolerance of
  touching it would take the segment as touching the box. EPA's normal
  itself is good to about 1e-9 (it moved by 1.1e-9 for the same pair after
  an unrelated capsule - box call): tests hold it to 2e-9.

Where the closest points are not unique (a segment parallel to a face, or
to the boundary of a half-space), coal's choice and these kernels' may differ
though the distance agrees.
"""

from __future__ import annotations

import math

from numba import njit

from lpik.tolerances import MACHINE_EPSILON

#: coal's threshold for a degenerate segment or parallel segments (capsule - capsule).
SEGMENT_EPSILON = 100.0 * MACHINE_EPSILON
#: coal's threshold below which a direction counts as perpendicular to a capsule's axis.
SUPPORT_PRECISION = 1e-12
#: How many floats a kernel writes: distance, point on the capsule, other point, normal.
FOUND = 10


@njit(cache=True)
def _write(out, d, p1x, p1y, p1z, p2x, p2y, p2z, nx, ny, nz):
    out[0] = d
    out[1], out[2], out[3] = p1x, p1y, p1z
    out[4], out[5], out[6] = p2x, p2y, p2z
    out[7], out[8], out[9] = nx, ny, nz
    return d


@njit(cache=True)
def capsule_sphere(a, b, radius, center, sphere_radius, out):
    """Capsule ``a``-``b`` to a sphere (coal's ``sphereCapsuleDistance``, shapes swapped)."""
    # coal's segment runs from the capsule's +z end (b) to its -z end (a)
    vx, vy, vz = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    wx, wy, wz = center[0] - b[0], center[1] - b[1], center[2] - b[2]
    c1 = wx * vx + wy * vy + wz * vz
    c2 = vx * vx + vy * vy + vz * vz
    if c1 <= 0:
        sx, sy, sz = b[0], b[1], b[2]
    elif c2 <= c1:
        sx, sy, sz = a[0], a[1], a[2]
    else:
        t = c1 / c2
        sx, sy, sz = b[0] + vx * t, b[1] + vy * t, b[2] + vz * t
    # coal's normal runs from the sphere to the capsule; ours the other way
    nx, ny, nz = sx - center[0], sy - center[1], sz - center[2]
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    d = norm - sphere_radius - radius
    if norm > MACHINE_EPSILON:
        nx, ny, nz = nx / norm, ny / norm, nz / norm
    else:
        nx, ny, nz = 1.0, 0.0, 0.0
    return _write(
        out, d, sx - nx * radius, sy - ny * radius, sz - nz * radius,
        center[0] + nx * sphere_radius, center[1] + ny * sphere_radius,
        center[2] + nz * sphere_radius, -nx, -ny, -nz,
    )  # fmt: skip


@njit(cache=True)
def _clamp(num, denom):
    """``num / denom`` clamped to [0, 1] (coal's ``clamp``)."""
    if num <= 0.0:
        return 0.0
    if num >= denom:
        return 1.0
    return num / denom


@njit(cache=True)
def capsule_capsule(a1, b1, r1, a2, b2, r2, out):
    """Two capsules (coal's ``ShapeShapeDistance<Capsule, Capsule>``, Ericson 5.1.9)."""
    d1x, d1y, d1z = b1[0] - a1[0], b1[1] - a1[1], b1[2] - a1[2]
    d2x, d2y, d2z = b2[0] - a2[0], b2[1] - a2[1], b2[2] - a2[2]
    rx, ry, rz = a1[0] - a2[0], a1[1] - a2[1], a1[2] - a2[2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * rx + d1y * ry + d1z * rz
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    s, t = 0.0, 0.0  # w1 = a1 + s d1, w2 = a2 + t d2
    if a <= SEGMENT_EPSILON:
        if e > SEGMENT_EPSILON:
            t = _clamp(f, e)
    elif e <= SEGMENT_EPSILON:
        s = _clamp(-c, a)
    else:
        denom = max(a * e - b * b, 0.0)
        if denom > SEGMENT_EPSILON:
            s = _clamp(b * f - c * e, denom)
            tn = b * s + f
        else:
            tn = f
        if tn <= 0.0:
            s, t = _clamp(-c, a), 0.0
        elif tn >= e:
            s, t = _clamp(b - c, a), 1.0
        else:
            t = tn / e
    w1x, w1y, w1z = a1[0] + s * d1x, a1[1] + s * d1y, a1[2] + s * d1z
    w2x, w2y, w2z = a2[0] + t * d2x, a2[1] + t * d2y, a2[2] + t * d2z
    nx, ny, nz = w2x - w1x, w2y - w1y, w2z - w1z
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm > 0.0:
        nx, ny, nz = nx / norm, ny / norm, nz / norm
    return _write(
        out, norm - (r1 + r2), w1x + r1 * nx, w1y + r1 * ny, w1z + r1 * nz,
        w2x - r2 * nx, w2y - r2 * ny, w2z - r2 * nz, nx, ny, nz,
    )  # fmt: skip


@njit(cache=True)
def capsule_halfspace(a, b, radius, normal, offset, out):
    """Capsule to the half-space ``normal . x <= offset`` (coal's ``halfspaceDistance``)."""
    nx, ny, nz = normal[0], normal[1], normal[2]
    ux, uy, uz = b[0] - a[0], b[1] - a[1], b[2] - a[2]
    length = math.sqrt(ux * ux + uy * uy + uz * uz)
    along = -(ux * nx + uy * ny + uz * nz) / length if length > 0.0 else 0.0
    if along > SUPPORT_PRECISION:
        px, py, pz = b[0], b[1], b[2]
    elif along < -SUPPORT_PRECISION:
        px, py, pz = a[0], a[1], a[2]
    else:
        px, py, pz = 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]), 0.5 * (a[2] + b[2])
    px, py, pz = px - radius * nx, py - radius * ny, pz - radius * nz
    d = nx * px + ny * py + nz * pz - offset
    return _write(out, d, px, py, pz, px - d * nx, py - d * ny, pz - d * nz, -nx, -ny, -nz)


@njit(cache=True)
def _segment_box_distance(a0, a1, a2, u0, u1, u2, h0, h1, h2, breaks):
    """The parameter ``t`` of the point of ``a + t u`` (t in [0, 1]) closest to the box.

    The squared distance to the box is a convex piecewise quadratic in ``t``
    with breaks where the point crosses a face's plane; each piece is minimised
    in closed form. Box frame: the box is ``|x_k| <= h_k``. ``breaks``: scratch
    of 8 floats.
    """
    breaks[0], breaks[1], count = 0.0, 1.0, 2
    for a, u, h in ((a0, u0, h0), (a1, u1, h1), (a2, u2, h2)):
        if u != 0.0:
            for side in (-h, h):
                t = (side - a) / u
                if 0.0 < t < 1.0:  # insertion into the sorted breaks
                    k = count
                    while breaks[k - 1] > t:
                        breaks[k] = breaks[k - 1]
                        k -= 1
                    breaks[k] = t
                    count += 1
    best, best_t = math.inf, 0.0
    for k in range(count - 1):
        lo, hi = breaks[k], breaks[k + 1]
        mid = 0.5 * (lo + hi)
        quad, lin = 0.0, 0.0  # the piece: sum over faces outside of (a + t u - side)^2
        for a, u, h in ((a0, u0, h0), (a1, u1, h1), (a2, u2, h2)):
            x = a + mid * u
            if x > h:
                quad, lin = quad + u * u, lin + u * (a - h)
            elif x < -h:
                quad, lin = quad + u * u, lin + u * (a + h)
        t = min(hi, max(lo, -lin / quad)) if quad > 0.0 else lo
        value = 0.0
        for a, u, h in ((a0, u0, h0), (a1, u1, h1), (a2, u2, h2)):
            x = a + t * u
            gap = x - h if x > h else (-h - x if x < -h else 0.0)
            value += gap * gap
        if value < best:
            best, best_t = value, t
    return best_t


@njit(cache=True)
def _segment_meets_box(a0, a1, a2, u0, u1, u2, h0, h1, h2):
    """Whether the segment ``a + t u`` (t in [0, 1]) meets the box ``|x_k| <= h_k``."""
    lo, hi = 0.0, 1.0
    for a, u, h in ((a0, u0, h0), (a1, u1, h1), (a2, u2, h2)):
        if u == 0.0:
            if a < -h or a > h:
                return False
        else:
            t1, t2 = (-h - a) / u, (h - a) / u
            lo, hi = max(lo, min(t1, t2)), min(hi, max(t1, t2))
            if lo > hi:
                return False
    return True


@njit(cache=True)
def capsule_box(a, b, radius, center, rotation, half, out, scratch):
    """Capsule to a box of half sizes ``half`` (coal: GJK and EPA, see the module).

    ``rotation`` (3, 3): the box's axes as columns; ``scratch``: 8 floats.
    """
    R = rotation  # columns: the box's axes in the world frame
    ax, ay, az = a[0] - center[0], a[1] - center[1], a[2] - center[2]
    bx, by, bz = b[0] - center[0], b[1] - center[1], b[2] - center[2]
    a0 = R[0, 0] * ax + R[1, 0] * ay + R[2, 0] * az
    a1 = R[0, 1] * ax + R[1, 1] * ay + R[2, 1] * az
    a2 = R[0, 2] * ax + R[1, 2] * ay + R[2, 2] * az
    u0 = R[0, 0] * bx + R[1, 0] * by + R[2, 0] * bz - a0
    u1 = R[0, 1] * bx + R[1, 1] * by + R[2, 1] * bz - a1
    u2 = R[0, 2] * bx + R[1, 2] * by + R[2, 2] * bz - a2
    h0, h1, h2 = half[0], half[1], half[2]
    if not _segment_meets_box(a0, a1, a2, u0, u1, u2, h0, h1, h2):
        t = _segment_box_distance(a0, a1, a2, u0, u1, u2, h0, h1, h2, scratch)
        s0, s1, s2 = a0 + t * u0, a1 + t * u1, a2 + t * u2
        c0, c1, c2 = min(h0, max(-h0, s0)), min(h1, max(-h1, s1)), min(h2, max(-h2, s2))
        n0, n1, n2 = c0 - s0, c1 - s1, c2 - s2
        gap = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        n0, n1, n2 = n0 / gap, n1 / gap, n2 / gap
        depth = -gap
    else:
        s0, s1, s2, c0, c1, c2, n0, n1, n2, depth = _penetration(a0, a1, a2, u0, u1, u2, h0, h1, h2)
    # back to the world frame
    nx = R[0, 0] * n0 + R[0, 1] * n1 + R[0, 2] * n2
    ny = R[1, 0] * n0 + R[1, 1] * n1 + R[1, 2] * n2
    nz = R[2, 0] * n0 + R[2, 1] * n1 + R[2, 2] * n2
    sx = center[0] + R[0, 0] * s0 + R[0, 1] * s1 + R[0, 2] * s2
    sy = center[1] + R[1, 0] * s0 + R[1, 1] * s1 + R[1, 2] * s2
    sz = center[2] + R[2, 0] * s0 + R[2, 1] * s1 + R[2, 2] * s2
    cx = center[0] + R[0, 0] * c0 + R[0, 1] * c1 + R[0, 2] * c2
    cy = center[1] + R[1, 0] * c0 + R[1, 1] * c1 + R[1, 2] * c2
    cz = center[2] + R[2, 0] * c0 + R[2, 1] * c1 + R[2, 2] * c2
    return _write(
        out, -depth - radius, sx + radius * nx, sy + radius * ny, sz + radius * nz,
        cx, cy, cz, nx, ny, nz,
    )  # fmt: skip


@njit(cache=True)
def _penetration(a0, a1, a2, u0, u1, u2, h0, h1, h2):
    """EPA's answer for a segment that meets the box: the minimum translation.

    The Minkowski difference ``segment - box`` is a polytope with face normals
    among the box's axes and the segment's cross products with them; its
    support ``h(n) = max(n . a, n . b) + sum_k |n_k| h_k`` is smallest at the
    face nearest the origin. Returns the witness point on the segment, the one
    on the box, the normal (from the segment toward the box's outside) and the depth.
    """
    best, b0, b1, b2 = math.inf, 0.0, 0.0, 0.0
    for k in range(3):
        for sign in (1.0, -1.0):
            n0 = sign if k == 0 else 0.0
            n1 = sign if k == 1 else 0.0
            n2 = sign if k == 2 else 0.0
            along = n0 * a0 + n1 * a1 + n2 * a2
            support = max(along, along + n0 * u0 + n1 * u1 + n2 * u2)
            value = support + abs(n0) * h0 + abs(n1) * h1 + abs(n2) * h2
            if value < best:
                best, b0, b1, b2 = value, n0, n1, n2
    face = True
    for k in range(3):  # cross products u x e_k
        c0 = 0.0 if k == 0 else (u2 if k == 1 else -u1)
        c1 = -u2 if k == 0 else (0.0 if k == 1 else u0)
        c2 = u1 if k == 0 else (-u0 if k == 1 else 0.0)
        norm = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        if norm <= SUPPORT_PRECISION:
            continue
        c0, c1, c2 = c0 / norm, c1 / norm, c2 / norm
        for sign in (1.0, -1.0):
            n0, n1, n2 = sign * c0, sign * c1, sign * c2
            value = n0 * a0 + n1 * a1 + n2 * a2 + abs(n0) * h0 + abs(n1) * h1 + abs(n2) * h2
            if value < best:
                best, b0, b1, b2, face = value, n0, n1, n2, False
    if face:  # the segment's end deepest along the normal
        t = 0.0 if b0 * u0 + b1 * u1 + b2 * u2 < 0.0 else 1.0
    else:  # the segment's point closest to the box's edge along the normal's free axis
        e0 = 0.0 if abs(b0) < SUPPORT_PRECISION else -math.copysign(h0, b0)
        e1 = 0.0 if abs(b1) < SUPPORT_PRECISION else -math.copysign(h1, b1)
        e2 = 0.0 if abs(b2) < SUPPORT_PRECISION else -math.copysign(h2, b2)
        f0 = 1.0 if e0 == 0.0 else 0.0
        f1 = 1.0 if e1 == 0.0 and f0 == 0.0 else 0.0
        f2 = 1.0 if f0 == 0.0 and f1 == 0.0 else 0.0
        w0, w1, w2 = a0 - e0, a1 - e1, a2 - e2
        uu = u0 * u0 + u1 * u1 + u2 * u2
        uf = u0 * f0 + u1 * f1 + u2 * f2
        uw = u0 * w0 + u1 * w1 + u2 * w2
        fw = f0 * w0 + f1 * w1 + f2 * w2
        t = (uf * fw - uw) / (uu - uf * uf)
    s0, s1, s2 = a0 + t * u0, a1 + t * u1, a2 + t * u2
    return s0, s1, s2, s0 - best * b0, s1 - best * b1, s2 - best * b2, b0, b1, b2, best
