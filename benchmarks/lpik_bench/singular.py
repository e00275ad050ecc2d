"""The fused step at and near the Panda's singular configurations: workload and timed cases.

The elbow singularity: with joint 5 at 0, the Panda's 6 x 7 Jacobian loses
rank at one angle of joint 4 (the arm stretched, about -0.467 rad), whatever
joints 1, 2, 3, 6 and 7 are. :func:`stretched_angle` finds that angle
numerically for each start (``sigma_min(J)`` about 1e-10, rounding). Starts:

- ``elbow``: joints 1, 2, 3, 6, 7 seeded, joint 5 at 0, joint 4 at the
  stretched angle moved by 0 or +-1e-9 .. 1e-3 rad (:data:`OFFSETS`);
- ``elbow + wrist``: the same with joint 6 at 0 or pi, where the axes of
  joints 5 and 7 are parallel;
- ``wrist``: joint 6 at 0 or pi with every other joint seeded (the axes
  align, but the flange's offset keeps ``J`` of full rank: ill-conditioned,
  not singular).

Each start heads for a target in one of :data:`TARGETS` directions: along the
left singular vector ``u`` of the smallest singular value (the motion ``J``
can hardly produce), ``1e-4 u`` away (inside the command clamp, so that the
command is along ``u``) or 0.5 m and 0.5 rad away along ``u``'s linear and
angular parts (out of reach); a random direction 1 cm / 0.02 rad away; or a
random direction 0.5 m / 0.5 rad away (out of reach). Each (start, target) is
one item of the workload. Its previous configuration (for the acceleration
case) is ``q - dq``, with ``dq`` LP2's step from ``q`` (1 ms, URDF end-stops
and velocity limits): the arm arrives at the speed of the step it is about to
take, as in the middle of a motion.

:func:`path_counts` tells which path the numpy LP2 takes on each item
(``ratio-test``, ``singular`` or ``highs``) and how many fused steps fell back
to HiGHS (``Result.path == "highs"``); the compiled kernel tries the same
paths in the same order.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lpik.methods.lp2 import lp2
from lpik.robots.registry import load_robot
from lpik.robots.rotations import exp_so3
from lpik.robots.tasks import PoseTask
from lpik_bench.cases import Case
from lpik_bench.workload import DT, QDD_MAX, V_MAX, W_MAX

if TYPE_CHECKING:
    from lpik.control.controller import Lp2Controller

FloatArray = NDArray[np.float64]

#: What the singular cases cover (the ``what`` of their records).
SINGULAR_STEP = "full step, singular configurations"
SINGULAR_STEP_ACC = "full step +acc, singular configurations"
#: Distances of joint 4 from the stretched angle [rad] (each with a seeded sign).
OFFSETS = (0.0, 1e-9, 1e-7, 1e-5, 1e-3)
#: Target directions (see the module docstring).
TARGETS = ("singular direction", "singular direction, out of reach", "random, near",
           "random, out of reach")  # fmt: skip
#: Symmetric multiplier bound of the bounded case (sec. 3.2).
LAMBDA_BOUND = 0.1
#: Record keys of every singular case: its robot; no ratio to the peers (another workload).
OWN = {"robot": "panda", "ratio_to_fastest_peer": None}
#: Bracket of joint 4's stretched angle [rad] and its tolerance.
STRETCH_BRACKET = (-0.6, -0.3)
STRETCH_XTOL = 1e-13


@dataclass(frozen=True, eq=False)
class SingularWorkload:
    """Steps of the Panda at and near its singular configurations.

    Attributes:
        model: The 6-D pose task.
        q: Configurations (N, 7) [rad]; q_prev: one period before (N, 7).
        targets: Commanded poses (N, 4, 4).
        kinds: The start's kind of each item (``elbow``, ``elbow + wrist``, ``wrist``).
        sigma_min: Smallest singular value of ``J`` at each item.
        dt: Control period [s].
    """

    model: PoseTask
    q: FloatArray
    q_prev: FloatArray
    targets: FloatArray
    kinds: tuple[str, ...]
    sigma_min: FloatArray
    dt: float = DT

    def __len__(self) -> int:
        return int(self.q.shape[0])

    def controller(self, *, acc: bool = False, bound: float | str | None = None) -> Lp2Controller:
        """The fused controller: URDF end-stops and velocity limits, and what is asked."""
        from lpik.control.controller import Lp2Controller

        return Lp2Controller(self.model, dt=self.dt, v_max=V_MAX, w_max=W_MAX,
                             qdd_max=QDD_MAX if acc else None, lambda_bound=bound,
                             on_stall=None)  # the method's step, checked against LP2  # fmt: skip

    def describe(self) -> str:
        """One line: items, kinds, the spread of ``sigma_min(J)``."""
        s = self.sigma_min
        kinds = ", ".join(f"{k} {v}" for k, v in Counter(self.kinds).items())
        return (
            f"{len(self)} steps ({kinds}); sigma_min(J) from {s.min():.1e} to {s.max():.1e}, "
            f"below 1e-6 on {100 * np.mean(s < 1e-6):.0f}%"
        )


def smallest_singular_value(model: PoseTask, q: FloatArray) -> float:
    """``sigma_min`` of the task Jacobian at ``q``."""
    return float(np.linalg.svd(model.jacobian(q), compute_uv=False)[-1])


def stretched_angle(model: PoseTask, q: FloatArray) -> float:
    """Joint 4's angle in :data:`STRETCH_BRACKET` where ``sigma_min(J)`` is least (others kept)."""
    from scipy.optimize import minimize_scalar

    def sigma(x: float) -> float:
        trial = q.copy()
        trial[3] = x
        return smallest_singular_value(model, trial)

    found = minimize_scalar(sigma, bounds=STRETCH_BRACKET, method="bounded",
                            options={"xatol": STRETCH_XTOL})  # fmt: skip
    return float(found.x)


def _start(model: PoseTask, kind: str, offset: float, rng: np.random.Generator) -> FloatArray:
    lo, hi = model.q_min, model.q_max
    mid, half = 0.5 * (lo + hi), 0.3 * (hi - lo)
    q = rng.uniform(mid - half, mid + half)
    if kind != "elbow":
        q[5] = float(rng.choice([0.0, np.pi]))  # joints 5 and 7 parallel
    if kind == "wrist":
        return q
    q[4] = 0.0
    q[3] = stretched_angle(model, q) + offset * float(rng.choice([-1.0, 1.0]))
    return q


def _target(model: PoseTask, q: FloatArray, kind: str, rng: np.random.Generator) -> FloatArray:
    if kind.startswith("singular direction"):
        u = np.linalg.svd(model.jacobian(q))[0][:, -1] * float(rng.choice([-1.0, 1.0]))
        if kind == "singular direction":  # inside the command clamp: the command is along u
            linear, angular = u[:3] * 1e-4, u[3:] * 1e-4
        else:
            linear, angular = u[:3] * 0.5 / max(np.linalg.norm(u[:3]), 1e-12), u[3:] * 0.5
    else:
        far = kind == "random, out of reach"
        linear = rng.normal(size=3)
        linear *= (0.5 if far else 0.01) / np.linalg.norm(linear)
        angular = rng.normal(size=3)
        angular *= (0.5 if far else 0.02) / np.linalg.norm(angular)
    pose = model.pose(q)
    out = np.eye(4)
    out[:3, :3] = exp_so3(angular) @ pose[:3, :3]
    out[:3, 3] = pose[:3, 3] + linear
    return out


def singular_workload(bases: int = 4, seed: int = 0) -> SingularWorkload:
    """``bases`` seeded starts of each kind x :data:`OFFSETS` x :data:`TARGETS`, one step each
    (``wrist`` starts have no offset: ``bases`` x :data:`TARGETS` steps)."""
    if bases < 1:
        raise ValueError(f"bases: must be >= 1, got {bases}")
    model = load_robot("panda", task="pose")
    rng = np.random.default_rng(seed)
    empty = np.empty(0)
    controller = SingularWorkload(model, empty, empty, empty, (), empty).controller()
    qs, prevs, targets, kinds = [], [], [], []
    for kind in ("elbow", "elbow + wrist", "wrist"):
        for _ in range(bases):
            for offset in (0.0,) if kind == "wrist" else OFFSETS:
                q = _start(model, kind, offset, rng)
                for aim in TARGETS:
                    target = _target(model, q, aim, rng)
                    qs.append(q)
                    # arriving at the speed of the step it is about to take (acceleration case)
                    prevs.append(2.0 * q - controller.step(q, target).q)
                    targets.append(target)
                    kinds.append(kind)
    q = np.array(qs)
    sigma = np.array([smallest_singular_value(model, x) for x in q])
    return SingularWorkload(model, q, np.array(prevs), np.array(targets), tuple(kinds), sigma)


@dataclass
class PathCounts:
    """Which path each item's step takes.

    Attributes:
        numpy: Items per path of the numpy LP2 (``ratio-test``, ``singular``, ``highs``).
        fused_highs: Fused steps that fell back to HiGHS (``Result.path == "highs"``).
        steps: Items counted.
    """

    numpy: dict[str, int] = field(default_factory=dict)
    fused_highs: int = 0
    steps: int = 0

    def text(self) -> str:
        """``ratio test x%, singular path y%, HiGHS z%; fused steps on HiGHS: k of N``."""
        pct = 100.0 / max(self.steps, 1)
        names = {"ratio-test": "ratio test", "singular": "singular path", "highs": "HiGHS"}
        shares = ", ".join(f"{names[k]} {self.numpy.get(k, 0) * pct:.1f}%" for k in names)
        return (
            f"paths (numpy LP2): {shares}; fused steps on HiGHS: {self.fused_highs} of {self.steps}"
        )

    def extra(self) -> dict[str, object]:
        """The counts as record keys."""
        return {
            "paths": dict(self.numpy),
            "fused_highs": self.fused_highs,
            "path_steps": self.steps,
        }


def path_counts(controller: Lp2Controller, work: SingularWorkload) -> PathCounts:
    """The numpy LP2's path and the fused step's HiGHS fallbacks over every item."""
    counts: Counter[str] = Counter()
    highs = 0
    for q, prev, target in zip(work.q, work.q_prev, work.targets):
        counts[lp2(controller.problem(q, target, prev)).path] += 1
        highs += controller.step(q, target, prev).path == "highs"
    return PathCounts(dict(counts), highs, len(work))


def after_collect(controller: Lp2Controller, work: SingularWorkload, reps: int = 30) -> dict:
    """Median time [us] of a step right after ``gc.collect()``: on the singular path, on the
    ratio test; and of the singular-path step back to back.

    The timing rounds collect garbage before each round (:func:`lpik_bench.runner.time_cases`),
    as a Python control loop's collector does now and then; this tells what the first step
    after it costs on each path. Empty when no item takes the singular path.
    """
    import gc
    import time

    def first(path: str) -> int | None:
        return next((k for k in range(len(work))
                     if lp2(controller.problem(work.q[k], work.targets[k])).path == path),
                    None)  # fmt: skip

    def median(k: int, collect: bool) -> float:
        times = []
        for _ in range(reps):
            gc.collect() if collect else controller.step(work.q[k], work.targets[k])
            start = time.perf_counter_ns()
            controller.step(work.q[k], work.targets[k])
            times.append((time.perf_counter_ns() - start) / 1e3)
        return float(np.median(times))

    singular, ratio = first("singular"), first("ratio-test")
    if singular is None:
        return {}
    out = {
        "after_gc_collect_us": median(singular, True),
        "back_to_back_us": median(singular, False),
    }
    if ratio is not None:
        out["ratio_test_after_gc_collect_us"] = median(ratio, True)
    return out


def back_to_back(
    controller: Lp2Controller, work: SingularWorkload, passes: int = 16, with_prev: bool = False
) -> dict:
    """Median, p99, p99.9 and worst [us] of ``passes`` runs over every item, one step after the
    other with the garbage collector off: a loop that does nothing else between steps
    (``with_prev``: each item's last configuration too, for acceleration limits)."""
    import gc
    import time

    times = np.empty(passes * len(work))
    enabled = gc.isenabled()
    gc.disable()
    try:
        for i in range(times.size):
            k = i % len(work)
            start = time.perf_counter_ns()
            controller.step(work.q[k], work.targets[k], work.q_prev[k] if with_prev else None)
            times[i] = (time.perf_counter_ns() - start) / 1e3
    finally:
        if enabled:
            gc.enable()
    median, p99, p999 = np.percentile(times, [50, 99, 99.9])
    return {"loop_median_us": float(median), "loop_p99_us": float(p99),
            "loop_p999_us": float(p999), "loop_max_us": float(times.max()),
            "loop_steps": int(times.size)}  # fmt: skip


def singular_cases(work: SingularWorkload) -> list[Case]:
    """The fused step (plain, ``|lambda| <= LAMBDA_BOUND``, ``lambda_bound="auto"``, +acc) and
    the numpy layers on the singular workload; the paths the steps take in notes and records."""
    from lpik_bench.cases import outcomes

    q, prev, targets = work.q, work.q_prev, work.targets
    N = len(work)
    plain, bounded = work.controller(), work.controller(bound=LAMBDA_BOUND)
    acc = work.controller(acc=True)
    auto = work.controller(bound="auto")
    bound_what = f"{SINGULAR_STEP}, |lambda| <= {LAMBDA_BOUND:g}"
    cases = []
    for controller, what, with_prev in ((plain, SINGULAR_STEP, False), (bounded, bound_what, False),
                                        (auto, f"{SINGULAR_STEP}, lambda_bound='auto'", False),
                                        (acc, SINGULAR_STEP_ACC, True)):  # fmt: skip

        def fused(i: int, c: Lp2Controller = controller, p: bool = with_prev) -> object:
            k = i % N
            return c.step(q[k], targets[k], prev[k] if p else None)

        counts = path_counts(controller, work)  # q_prev matters only with acceleration limits
        note = (f"Lp2Controller.step on {work.describe()}; {counts.text()}; "
                f"{outcomes([fused(i) for i in range(N)])}")  # fmt: skip
        # every fused step back to back too: the worst case without the rounds' restarts
        loop = back_to_back(controller, work, with_prev=with_prev)
        cold = {**after_collect(controller, work), **loop} if controller is plain else {}
        if cold:
            note += (
                f"; a singular-path step right after gc.collect() (as at the start of "
                f"every round): median {cold['after_gc_collect_us']:.1f} us (back to back "
                f"{cold['back_to_back_us']:.1f} us; a ratio-test step right after "
                f"gc.collect(): {cold.get('ratio_test_after_gc_collect_us', 0.0):.1f} us)"
            )
        cases.append(Case("lpik", "lp2 fused (compiled)", what, fused, note=note,
                          extra={**OWN, **counts.extra(), **loop, **cold}))  # fmt: skip
    for controller, what in ((plain, SINGULAR_STEP), (bounded, bound_what)):

        def numpy_layers(i: int, c: Lp2Controller = controller) -> object:
            k = i % N
            return lp2(c.problem(q[k], targets[k]))

        note = "TaskModel + build_problem + lp2 (ratio test, else the singular path, else HiGHS)"
        cases.append(Case("lpik", "lp2 (numpy layers)", what, numpy_layers, note=note,
                          extra=OWN))  # fmt: skip
    return cases
