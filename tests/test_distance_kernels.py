"""The compiled distance kernels against coal: tens of thousands of random pairs, to 1e-9."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")
pytest.importorskip("coal")

from hypothesis import assume, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from lpik.collision import Obstacle  # noqa: E402
from lpik.collision.distance import distance_request, signed_distance  # noqa: E402
from lpik.collision.shapes import capsule_geometry  # noqa: E402
from lpik.fast.avoiding_step import obstacle_distance, pack_bodies  # noqa: E402
from lpik.fast.distances import capsule_capsule  # noqa: E402

#: How far the kernels may be from coal: distance [m], witness points [m], normal.
TOL = 1e-9
#: ... but for the normal of a capsule through a box, which coal's EPA gives to about
#: 1e-9 only, and not the same for the same pair after other calls: one capsule - box
#: call before moved it by 1.1e-9 (while the distance moved by 2e-11), measured.
EPA_NORMAL_TOL = 2e-9
#: Random pairs per obstacle kind (four kinds, and capsule - capsule for self-collision).
PAIRS = 8000
KINDS = ("sphere", "capsule", "box", "plane")


def random_capsule(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """A capsule's ends and radius; one in twenty of length 0 (a URDF's sphere)."""
    a = rng.uniform(-0.5, 0.5, 3)
    b = a.copy() if rng.random() < 0.05 else a + rng.normal(size=3) * 0.25
    return a, b, float(rng.uniform(0.01, 0.12))


def random_obstacle(kind: str, rng: np.random.Generator) -> Obstacle:
    """An obstacle of ``kind`` overlapping the capsules' region often."""
    if kind == "sphere":
        return Obstacle("o", kind, center=rng.uniform(-0.5, 0.5, 3), radius=rng.uniform(0.01, 0.3))
    if kind == "capsule":
        a, b, r = random_capsule(rng)
        return Obstacle("o", kind, a=a, b=b, radius=r)
    if kind == "box":
        size, rpy = rng.uniform(0.02, 0.6, 3), rng.uniform(-np.pi, np.pi, 3)
        return Obstacle("o", kind, center=rng.uniform(-0.3, 0.3, 3), size=size, rpy=rpy)
    normal = rng.normal(size=3)
    normal /= np.linalg.norm(normal)
    return Obstacle("o", kind, center=rng.uniform(-0.3, 0.3, 3), normal=normal)


class _Scene:
    """Just what :func:`pack_bodies` reads of a Proximities, for one obstacle."""

    def __init__(self, obstacle: Obstacle) -> None:
        from lpik.collision import Scene

        self.scene = Scene((obstacle,), 0.0, 1.0)
        self.obstacle_pairs = ()
        self.bodies = type("B", (), {"capsules": (), "self_pairs": (), "chain": _Chain})()


class _Chain:
    n_joints = 1


def kernel_distance(a, b, r, obstacle: Obstacle) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The kernel's 10 numbers for a capsule and an obstacle."""
    row = pack_bodies(_Scene(obstacle), 0.01, 0.5)[1][0]
    out = np.zeros(10)
    capsule = np.array([0.0, *a, *b, r])
    obstacle_distance(capsule, a, b, row, out, np.zeros(9))
    return out


def coal_distance(a, b, r, other) -> np.ndarray:  # type: ignore[no-untyped-def]
    """coal's 10 numbers for a capsule and a placed coal shape."""
    d, p1, p2, n = signed_distance(capsule_geometry(a, b, r), other, distance_request())
    return np.concatenate([[d], p1, p2, n])


def gap(mine: np.ndarray, theirs: np.ndarray, epa: bool = False) -> float:
    """The largest difference, the normal's scaled to :data:`TOL` for an EPA normal."""
    scale = TOL / EPA_NORMAL_TOL if epa and theirs[0] < 0 else 1.0
    return max(float(np.abs(mine[:7] - theirs[:7]).max()),
               scale * float(np.abs(mine[7:] - theirs[7:]).max()))  # fmt: skip


@pytest.mark.parametrize("kind", KINDS)
def test_each_obstacle_kind_agrees_with_coal_on_random_pairs(kind) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(13 + KINDS.index(kind))
    worst, overlapping = 0.0, 0
    for _ in range(PAIRS):
        a, b, r = random_capsule(rng)
        obstacle = random_obstacle(kind, rng)
        theirs = coal_distance(a, b, r, obstacle.geometry())
        worst = max(worst, gap(kernel_distance(a, b, r, obstacle), theirs, kind == "box"))
        overlapping += theirs[0] < 0
    assert worst <= TOL
    assert overlapping > PAIRS // 40  # penetrating pairs are well represented


def test_capsule_pairs_agree_with_coal() -> None:
    rng = np.random.default_rng(7)
    worst, overlapping, out = 0.0, 0, np.zeros(10)
    for _ in range(PAIRS):
        (a1, b1, r1), (a2, b2, r2) = random_capsule(rng), random_capsule(rng)
        theirs = coal_distance(a1, b1, r1, capsule_geometry(a2, b2, r2))
        capsule_capsule(a1, b1, r1, a2, b2, r2, out)
        worst = max(worst, gap(out, theirs))
        overlapping += theirs[0] < 0
    assert worst <= TOL and overlapping > PAIRS // 40


def test_a_segment_through_a_box_is_pushed_out_the_shortest_way() -> None:
    """coal's depth of a capsule through a box is the minimum translation (EPA), not the
    depth of the segment's deepest point: a segment cutting a corner of a tall box."""
    box = Obstacle("o", "box", center=np.zeros(3), size=np.array([0.4, 0.4, 1.0]), rpy=np.zeros(3))
    a, b, r = np.array([0.19, -0.3, 0.0]), np.array([-0.3, 0.19, 0.0]), 0.05
    mine = kernel_distance(a, b, r, box)
    assert gap(mine, coal_distance(a, b, r, box.geometry())) <= TOL
    # out past the edge at (-0.2, -0.2): 0.29 / sqrt(2) = 0.205 m; the deepest point, at
    # (-0.055, -0.055), is only 0.145 m from the nearest face
    assert mine[0] == pytest.approx(-0.29 / np.sqrt(2) - r)
    np.testing.assert_allclose(mine[4:7], [-0.2, -0.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(mine[7:], [np.sqrt(0.5), np.sqrt(0.5), 0.0], atol=1e-12)


coordinate = st.floats(-0.6, 0.6, allow_nan=False)
point = st.tuples(coordinate, coordinate, coordinate).map(np.array)
radius = st.floats(0.005, 0.2)


@st.composite
def obstacles(draw) -> Obstacle:  # type: ignore[no-untyped-def]
    kind = draw(st.sampled_from(KINDS))
    if kind == "sphere":
        return Obstacle("o", kind, center=draw(point), radius=draw(radius))
    if kind == "capsule":
        return Obstacle("o", kind, a=draw(point), b=draw(point), radius=draw(radius))
    if kind == "box":
        size = st.tuples(*[st.floats(0.01, 0.8)] * 3).map(np.array)
        angles = st.tuples(*[st.floats(-np.pi, np.pi)] * 3).map(np.array)
        return Obstacle("o", kind, center=draw(point), size=draw(size), rpy=draw(angles))
    normal = draw(point)
    if np.linalg.norm(normal) < 1e-3:
        normal = np.array([0.0, 0.0, 1.0])
    return Obstacle("o", kind, center=draw(point), normal=normal / np.linalg.norm(normal))


def _to_segment(x, a, b) -> float:  # type: ignore[no-untyped-def]
    """Distance from the point ``x`` to the segment from ``a`` to ``b``."""
    ab = b - a
    length_squared = float(np.dot(ab, ab))  # 0 also where a tiny axis underflows
    if length_squared == 0.0:
        return float(np.linalg.norm(a - x))
    t = float(np.clip(np.dot(x - a, ab) / length_squared, 0.0, 1.0))
    return float(np.linalg.norm(a + t * ab - x))


def test_a_box_centre_on_the_axis() -> None:
    """A capsule whose axis passes exactly through a box's centre: coal 3.0 answers the depth
    of the surface only (-r), one part in 1e9 off the centre the full depth, which the kernel
    gives there too: the nearest face's distance plus r (a find of hypothesis)."""
    size, rpy = np.array([0.03125, 0.03125, 0.5]), np.array([0.0, 0.0, 1.0])
    box = Obstacle("o", "box", center=np.array([0.5, 0.0, 0.0]), size=size, rpy=rpy)
    a = b = np.array([0.5, 0.0, 0.0])
    assert kernel_distance(a, b, 0.125, box)[0] == pytest.approx(-0.015625 - 0.125, abs=1e-12)
    near = a + [1e-9, 0.0, 0.0]
    mine, theirs = (
        kernel_distance(near, near, 0.125, box),
        coal_distance(near, near, 0.125, box.geometry()),
    )
    assert abs(mine[0] - theirs[0]) <= TOL and mine[0] == pytest.approx(-0.140625, abs=1e-8)


#: Generic pairs are held equal in full by the seeded tests above; here, where the closest
#: points may not be unique, the distance is, and each side's witnesses must be consistent.
@settings(max_examples=1500, deadline=None)
@given(a=point, b=point, r=radius, obstacle=obstacles())
def test_any_capsule_and_obstacle_agree_with_coal(a, b, r, obstacle) -> None:  # type: ignore[no-untyped-def]
    theirs = coal_distance(a, b, r, obstacle.geometry())
    if obstacle.kind in ("sphere", "capsule"):  # where the axes meet, no normal is defined
        assume(theirs[0] + r + obstacle.radius > 1e-9)
    if obstacle.kind == "box":  # coal's one wrong answer: test_a_box_centre_on_the_axis, which
        # reaches 1e-12 off the centre too (an axis 1.1e-12 from it: coal -r, the kernel the
        # full depth); at 1e-9 coal answers the full depth
        assume(_to_segment(obstacle.center, a, b) > 1e-9)
    mine = kernel_distance(a, b, r, obstacle)
    assert abs(mine[0] - theirs[0]) <= TOL
    if (
        gap(mine, theirs, obstacle.kind == "box") > TOL
    ):  # a tie (hypothesis finds them: a point at a box's centre)
        for answer in (mine, theirs):  # each a valid answer: p2 - p1 = d n, n a unit vector
            d, p1, p2, n = answer[0], answer[1:4], answer[4:7], answer[7:]
            assert abs(np.linalg.norm(n) - 1) <= TOL
            assert np.abs(p2 - p1 - d * n).max() <= TOL
