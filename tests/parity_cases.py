"""The states of the parity suite (tests/test_parity.py): generated, seeded, deterministic.

A :class:`Family` is one controller configuration (a robot, its period and
speeds, acceleration limits, weights, a scene); a :class:`Case` is one state of
a family: ``q0``, a target and ``q_prev`` (None: at rest). Every entry point
of the suite takes one step from each case.

The states come from two sources, both seeded: states drawn at random in the
way each family asks for (within the limits, on an end-stop, past one, near a
singular configuration), and states of closed-loop runs (``simulate`` with
``lp2s``, the numpy engine), which give moving states (``q_prev`` implies the
last step's motion), joints saturated on their end-stops, steps near the
workspace's edge under the automatic multiplier bound, and distance rows that
bind beside an obstacle.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np

from lpik.collision import CollisionAvoidance, collision_avoidance, scene_from_dict
from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX, ClampedTarget
from lpik.control.simulate import simulate
from lpik.paper.scenarios import get_scenario
from lpik.robots.registry import home_configuration, load_robot
from lpik.robots.rotations import exp_so3

FloatArray = np.ndarray
#: The one seed every case is drawn from (each family from its own stream, by its name).
SEED = 20260611


@dataclass(frozen=True, eq=False)
class Family:
    """One controller configuration; its cases are states of its model.

    Attributes:
        name: Short name (the first word of each case's id).
        make_model: Builds the task model (called once).
        dt: Control period [s].
        v_max: Largest commanded linear speed [m/s].
        w_max: Largest commanded angular speed [rad/s].
        qdd_max: Acceleration limit of every joint [rad/s^2], or None.
        weights: ``M``, ``f``, ``Lambda``, ``q_ref`` of the criterion (None: the defaults).
        make_scene: Builds the scene of obstacles, or None.
        home: The configuration at which touching self-collision pairs are dropped.
    """

    name: str
    make_model: Callable[[], Any]
    dt: float
    v_max: float = DEFAULT_V_MAX
    w_max: float = DEFAULT_W_MAX
    qdd_max: float | None = None
    weights: dict[str, Any] | None = None
    make_scene: Callable[[], Any] | None = None
    home: FloatArray | None = field(default=None)

    @property
    def model(self) -> Any:
        return _model(self.make_model)

    @property
    def scene(self) -> Any:
        return None if self.make_scene is None else _scene(self.make_scene)

    def avoidance(self) -> Any:
        """The scene's collision avoidance with :attr:`home` (what ``simulate`` takes), or None."""
        if self.scene is None or isinstance(self.scene, CollisionAvoidance):
            return self.scene
        return collision_avoidance(self.model, self.scene, self.home)

    def options(self) -> dict[str, Any]:
        """The keywords of a :class:`~lpik.control.stepper.Stepper` for this family.

        ``on_stall=None``: the suite compares the method's step (the stall stage, which
        problem-level entry points do not have, has its own parity test in
        ``test_progress_compiled.py``).
        """
        return {
            "dt": self.dt, "v_max": self.v_max, "w_max": self.w_max, "qdd_max": self.qdd_max,
            "weights": self.weights, "scene": self.scene, "home": self.home, "on_stall": None,
        }  # fmt: skip


@cache
def _model(make: Callable[[], Any]) -> Any:
    return make()


@cache
def _scene(make: Callable[[], Any]) -> Any:
    return make()


@dataclass(frozen=True, eq=False)
class Case:
    """One state of a family.

    Attributes:
        id: ``family-kind-index``, the case's test id.
        family: The family.
        kind: How the state was made (``random``, ``run``, ``end-stop``, ``outside``, ...).
        q0: Joint coordinates now.
        target: The commanded task value (xyz, or a 4 x 4 pose).
        q_prev: Joint coordinates one period ago, or None (at rest).
    """

    id: str
    family: Family
    kind: str
    q0: FloatArray
    target: FloatArray
    q_prev: FloatArray | None

    @property
    def at_rest(self) -> bool:
        return self.q_prev is None


# ----------------------------------------------------------------------------- families


def _planar(name: str) -> Callable[[], Any]:
    def make() -> Any:
        return get_scenario(name).setup().model

    make.__name__ = f"planar_{name}"
    return make


def _planar_obstacle_scene() -> Any:
    return get_scenario("obstacle").setup().scene


def _planar_field() -> Any:
    """The obstacle scenario's circle kept off by the damper's rows and Khatib's field (eq. 3)."""
    setup = get_scenario("obstacle").setup()
    return collision_avoidance(setup.model, setup.scene, setup.q0, mechanism="both")


def _panda() -> Any:
    return load_robot("panda")


def _ur5e() -> Any:
    return load_robot("ur5e")


#: The ball in the Panda's way: the tool's pull-in passes it (centre [m], radius [m]).
PANDA_BALL = ([0.1, 0.1, 0.45], 0.04)


def _panda_scene() -> Any:
    center, radius = PANDA_BALL
    ball = {"name": "ball", "type": "sphere", "center": center, "radius": radius}
    return scene_from_dict(
        {"obstacles": [ball], "safety_distance": 0.02, "influence_distance": 0.12}
    )


def _panda_field() -> Any:
    """The ball kept off by Khatib's field alone (eq. 3): rows only inside ``d_s``."""
    return collision_avoidance(_panda(), _panda_scene(), home_configuration("panda"),
                               mechanism="field")  # fmt: skip


PULL_IN = get_scenario("pull-in").setup()
PANDA_PULL_IN = get_scenario("pull-in").setup("panda")
OBSTACLE = get_scenario("obstacle").setup()

FAMILIES: dict[str, Family] = {
    f.name: f
    for f in (
        # the paper's planar arm, q1 <= 95 deg (sec. 4, Figs. 3-6)
        Family("planar", _planar("pull-in"), PULL_IN.dt, PULL_IN.v_max),
        # the same with acceleration limits (a motion implied by q_prev)
        Family("planar_acc", _planar("pull-in"), PULL_IN.dt, PULL_IN.v_max, qdd_max=20.0),
        # every joint within +-180 deg: stretched out at the workspace's edge (Figs. 7-9)
        Family("planar_edge", _planar("edge-singularity"), PULL_IN.dt, PULL_IN.v_max),
        # sec. 3.1's smoothing term towards a reference configuration, and a non-unit M
        Family(
            "planar_smooth",
            _planar("pull-in"),
            PULL_IN.dt,
            PULL_IN.v_max,
            weights={
                "M": np.array([1.0, 2.0, 1.5, 1.0]),
                "Lambda": np.full(4, 0.02),
                "q_ref": np.radians([30.0, -60.0, 20.0, -10.0]),
            },
        ),
        # the circle beside the elbow's path (distance rows, the velocity damper)
        Family(
            "planar_obstacle",
            _planar("obstacle"),
            OBSTACLE.dt,
            OBSTACLE.v_max,
            make_scene=_planar_obstacle_scene,
            home=OBSTACLE.q0,
        ),
        # the same circle, with the potential field too (its force per step)
        Family(
            "planar_field",
            _planar("obstacle"),
            OBSTACLE.dt,
            OBSTACLE.v_max,
            make_scene=_planar_field,
            home=OBSTACLE.q0,
        ),
        # a 3-D redundant arm: the Panda's pose task (n = 7, m = 6)
        Family("panda", _panda, PANDA_PULL_IN.dt, PANDA_PULL_IN.v_max),
        Family("panda_acc", _panda, PANDA_PULL_IN.dt, PANDA_PULL_IN.v_max, qdd_max=15.0),
        Family(
            "panda_obstacle",
            _panda,
            PANDA_PULL_IN.dt,
            PANDA_PULL_IN.v_max,
            make_scene=_panda_scene,
            home=home_configuration("panda"),
        ),
        # the same ball with the potential field alone, under acceleration limits (the
        # field's share of the room around the motion; distances inside the compiled step)
        Family(
            "panda_field_acc",
            _panda,
            PANDA_PULL_IN.dt,
            PANDA_PULL_IN.v_max,
            qdd_max=15.0,
            make_scene=_panda_field,
            home=home_configuration("panda"),
        ),
        # no redundancy: the UR5e's pose task (n = m = 6)
        Family("ur5e", _ur5e, PANDA_PULL_IN.dt, PANDA_PULL_IN.v_max),
    )
}


# ------------------------------------------------------------------------------- states


def _inner(model: Any, rng: np.random.Generator, share: float = 0.8) -> FloatArray:
    """A configuration drawn within ``share`` of each joint's range, about its middle."""
    lo, hi = model.q_min, model.q_max
    mid, half = 0.5 * (lo + hi), 0.5 * share * (hi - lo)
    return rng.uniform(mid - half, mid + half)


def _offset_target(model: Any, q: FloatArray, rng: np.random.Generator, reach: float) -> FloatArray:
    """The task value at ``q`` moved ``reach`` [m] (and ``reach`` rad) in a random direction."""
    pose = np.array(model.pose(q), dtype=np.float64)
    linear = rng.normal(size=3)
    if pose.shape == (3,):  # a planar arm's xyz: in the plane
        linear[2] = 0.0
        return pose + reach * linear / np.linalg.norm(linear)
    angular = rng.normal(size=3)
    pose[:3, 3] += reach * linear / np.linalg.norm(linear)
    pose[:3, :3] = exp_so3(reach * angular / np.linalg.norm(angular)) @ pose[:3, :3]
    return pose


def _pushing_target(model: Any, q: FloatArray, joint: int, sign: float, reach: float) -> FloatArray:
    """The task value reached by moving ``joint`` by ``sign * reach`` (into its end-stop)."""
    moved = q.copy()
    moved[joint] += sign * reach
    return np.array(model.pose(moved), dtype=np.float64)


REACHES = (2e-3, 0.05, 0.6)  # inside the command clamp, a few steps away, far away


def _random(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    model = family.model
    out = []
    for k in range(count):
        q = _inner(model, rng)
        target = _offset_target(model, q, rng, REACHES[k % len(REACHES)])
        out.append(Case(f"{family.name}-random-{k}", family, "random", q, target, None))
    return out


def _end_stops(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    """A joint exactly on an end-stop, the command pushing it further in (half of them moving)."""
    model = family.model
    out = []
    for k in range(count):
        q = _inner(model, rng, 0.6)
        joint = int(rng.integers(model.n_joints))
        upper = bool(rng.integers(2))
        q[joint] = model.q_max[joint] if upper else model.q_min[joint]
        sign = 1.0 if upper else -1.0
        target = _pushing_target(model, q, joint, sign, float(rng.choice([0.01, 0.3])))
        prev = None
        if k % 2:  # arriving: the last step moved the joint onto the stop
            prev = q - rng.uniform(0.0, 0.3, model.n_joints) * model.qd_max * family.dt
            prev[joint] = q[joint] - sign * 0.2 * model.qd_max[joint] * family.dt
        out.append(Case(f"{family.name}-end-stop-{k}", family, "end-stop", q, target, prev))
    return out


def _outside(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    """A joint past an end-stop (status ``recovering``)."""
    model = family.model
    out = []
    for k in range(count):
        q = _inner(model, rng, 0.6)
        joint = int(rng.integers(model.n_joints))
        past = float(rng.uniform(1e-4, 0.05))
        q[joint] = model.q_max[joint] + past if k % 2 == 0 else model.q_min[joint] - past
        target = _offset_target(model, q, rng, REACHES[k % len(REACHES)])
        out.append(Case(f"{family.name}-outside-{k}", family, "outside", q, target, None))
    return out


def _run(
    family: Family, q0: FloatArray, target: FloatArray, steps: int, rng: np.random.Generator,
    count: int, *, late: float = 0.0, bound_by: str | None = None,
) -> list[Case]:  # fmt: skip
    """``count`` states of a closed-loop run (lp2s, the numpy engine), drawn after ``late``
    of it: half of them moving (``q_prev`` the state one period before), half at rest (for
    a family with acceleration limits: all moving). ``bound_by``: half of them drawn from
    the steps whose binding limit starts with it."""
    log = simulate(
        family.model, ClampedTarget(target, family.v_max, family.w_max), q0, steps,
        method="lp2s", dt=family.dt, qdd_max=family.qdd_max, weights=family.weights,
        scene=family.avoidance(),
    )  # fmt: skip
    first = max(1, int(late * steps))
    steps_left = np.arange(first, steps)
    chosen: list[int] = []
    if bound_by is not None:
        bound = [i for i in steps_left if str(log.binding[i]).startswith(bound_by)]
        assert len(bound) >= count, f"{family.name}: too few steps bound by {bound_by}"
        chosen = rng.choice(bound, size=count // 2, replace=False).tolist()
    rest = np.array([i for i in steps_left if i not in chosen])
    chosen += rng.choice(rest, size=count - len(chosen), replace=False).tolist()
    picks = np.sort(chosen)
    out = []
    for k, i in enumerate(picks.tolist()):
        prev = None if k % 2 and family.qdd_max is None else log.q[i - 1].copy()
        out.append(Case(f"{family.name}-run-{k}", family, "run", log.q[i].copy(),
                        np.array(target, dtype=np.float64), prev))  # fmt: skip
    return out


def _stretched_planar(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    """The planar arm stretched out (all joints near 0): pushed out, pulled in, sideways."""
    model = family.model
    out = []
    for k in range(count):
        q = rng.normal(0.0, 10.0 ** rng.uniform(-7, -2), model.n_joints)
        if k == 0:
            q[:] = 0.0  # exactly singular
        tip = np.array(model.pose(q), dtype=np.float64)
        aim = [np.array([1.0, 0.3, 0.0]), np.array([-0.5, 0.05, 0.0]), rng.normal(size=3)][k % 3]
        aim[2] = 0.0
        target = tip + float(rng.choice([3e-3, 0.5])) * aim / np.linalg.norm(aim)
        out.append(Case(f"{family.name}-stretched-{k}", family, "stretched", q, target, None))
    return out


def _stretched_angle(model: Any, q: FloatArray) -> float:
    """The Panda's joint 4 angle (joint 5 at 0) where ``sigma_min(J)`` is least (arm stretched)."""
    from scipy.optimize import minimize_scalar

    def sigma(x: float) -> float:
        trial = q.copy()
        trial[3] = x
        return float(np.linalg.svd(model.jacobian(trial), compute_uv=False)[-1])

    return float(minimize_scalar(sigma, bounds=(-0.6, -0.3), method="bounded",
                                 options={"xatol": 1e-13}).x)  # fmt: skip


def _aligned_panda(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    """The Panda with aligned joints: the elbow stretched (joint 5 at 0, joint 4 at the
    stretched angle, moved by 0 .. 1e-4 rad) and the axes of joints 5 and 7 parallel (joint 6
    at 0); commands along the singular direction and random ones."""
    model = family.model
    out = []
    for k in range(count):
        q = _inner(model, rng, 0.5)
        q[5] = 0.0  # joints 5 and 7 parallel
        if k % 3 != 2:
            q[4] = 0.0
            q[3] = _stretched_angle(model, q) + float(rng.choice([0.0, 1e-9, 1e-6, 1e-4]))
        if k % 2 == 0:  # along the left singular vector of the smallest singular value
            u = np.linalg.svd(model.jacobian(q))[0][:, -1] * float(rng.choice([-1.0, 1.0]))
            scale = float(rng.choice([1e-4, 0.5]))
            target = np.array(model.pose(q), dtype=np.float64)
            target[:3, :3] = exp_so3(scale * u[3:]) @ target[:3, :3]
            target[:3, 3] += scale * u[:3]
        else:
            target = _offset_target(model, q, rng, REACHES[k % len(REACHES)])
        out.append(Case(f"{family.name}-aligned-{k}", family, "aligned", q, target, None))
    return out


def _aligned_ur5e(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    """The UR5e with its wrist aligned (joint 5 at 0: the axes of joints 4 and 6 parallel)."""
    model = family.model
    out = []
    for k in range(count):
        q = _inner(model, rng, 0.3)
        q[4] = 0.0 if k % 2 == 0 else float(rng.choice([1e-8, 1e-4]))
        target = _offset_target(model, q, rng, REACHES[k % len(REACHES)])
        out.append(Case(f"{family.name}-aligned-{k}", family, "aligned", q, target, None))
    return out


def _braking(family: Family, rng: np.random.Generator, count: int) -> list[Case]:
    """Moving towards an end-stop too fast to stop before it within the acceleration limits."""
    model = family.model
    out = []
    for k in range(count):
        q = _inner(model, rng, 0.6)
        joint = int(rng.integers(model.n_joints))
        speed = model.qd_max[joint] * family.dt * float(rng.uniform(0.5, 0.95))
        room = float(rng.uniform(0.5, 3.0)) * speed
        q[joint] = model.q_max[joint] - room
        prev = q.copy()
        prev[joint] -= speed
        target = _offset_target(model, q, rng, REACHES[k % len(REACHES)])
        out.append(Case(f"{family.name}-braking-{k}", family, "braking", q, target, prev))
    return out


def _cases_of(name: str, rng: np.random.Generator) -> list[Case]:
    family = FAMILIES[name]
    if name == "planar":
        return [
            *_random(family, rng, 3), *_end_stops(family, rng, 3), *_outside(family, rng, 2),
            *_run(family, PULL_IN.q0, PULL_IN.target, PULL_IN.steps, rng, 4, late=0.3),
            *_stretched_planar(family, rng, 2),
        ]  # fmt: skip
    if name == "planar_acc":
        return [
            *_run(family, PULL_IN.q0, PULL_IN.target, PULL_IN.steps, rng, 4, late=0.3),
            *_braking(family, rng, 2), *_end_stops(family, rng, 2),
        ]  # fmt: skip
    if name == "planar_edge":
        edge = get_scenario("edge-singularity").setup()
        return [
            *_run(family, edge.q0, edge.target, 300, rng, 4, late=0.5),
            *_stretched_planar(family, rng, 4),
        ]
    if name == "planar_smooth":
        return [
            *_random(family, rng, 2),
            *_run(family, PULL_IN.q0, PULL_IN.target, 250, rng, 2, late=0.3),
            *_outside(family, rng, 1),
        ]
    if name == "planar_obstacle":
        return [
            *_run(
                family, OBSTACLE.q0, OBSTACLE.target, 400, rng, 5, late=0.1, bound_by="collision"
            ),
            *_random(family, rng, 1),
        ]
    if name == "planar_field":
        return [
            *_run(family, OBSTACLE.q0, OBSTACLE.target, 300, rng, 3, late=0.1),
            *_random(family, rng, 1),
        ]
    if name == "panda":
        s = PANDA_PULL_IN
        return [
            *_random(family, rng, 3), *_end_stops(family, rng, 2), *_outside(family, rng, 2),
            *_run(family, s.q0, s.target, s.steps, rng, 3, late=0.5),
            *_aligned_panda(family, rng, 4),
        ]  # fmt: skip
    if name == "panda_acc":
        s = PANDA_PULL_IN
        return [
            *_run(family, s.q0, s.target, s.steps, rng, 3, late=0.5),
            *_braking(family, rng, 2), *_end_stops(family, rng, 1),
        ]  # fmt: skip
    if name == "panda_obstacle":
        s = PANDA_PULL_IN
        return [*_run(family, s.q0, s.target, 200, rng, 4, late=0.2, bound_by="collision")]
    if name == "panda_field_acc":
        s = PANDA_PULL_IN
        return [*_run(family, s.q0, s.target, 200, rng, 4, late=0.2)]
    if name == "ur5e":
        return [*_random(family, rng, 2), *_aligned_ur5e(family, rng, 2)]
    raise ValueError(name)


@cache
def all_cases() -> tuple[Case, ...]:
    """Every case, family by family (each family from its own seeded stream)."""
    out: list[Case] = []
    for name in FAMILIES:  # a family's stream depends on its name only
        out.extend(_cases_of(name, np.random.default_rng([SEED, zlib.crc32(name.encode())])))
    ids = [c.id for c in out]
    assert len(set(ids)) == len(ids), "case ids must be unique"
    return tuple(out)
