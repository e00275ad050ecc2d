"""lpik's timed cases: every method, the fused compiled step, batches, FK + Jacobian alone.

A :class:`Case` is one thing to time: ``call(i)`` runs it on item ``i`` of
its workload (modulo the item count). ``per_call`` is the number of steps one
call solves (the batch size), so that times can be reported per step.

``what`` says how much of a control step a case covers:

- ``full step``: forward kinematics, Jacobian, command, end-stops and velocity
  limits, the solve and the :class:`~lpik.result.Result`, from ``(q, target
  pose)``: the same work as a peer's step;
- ``full step +acc``: the same with acceleration limits too;
- ``full step, planar 4-link``: the paper's arm (2-D task, through the same
  compiled chain step) with end-stops, velocity and acceleration limits;
- ``solve``: the method alone on a prepared :class:`~lpik.problem.Problem`;
- ``batch of B``: :func:`lpik.fast.lp2_batch` on prepared arrays, per step;
- ``batch of B full steps +acc``: :meth:`Lp2Controller.step_batch
  <lpik.control.controller.Lp2Controller.step_batch>` over the workload's states, per step;
- ``FK + J``: forward kinematics and Jacobian alone.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from lpik.highs import HighsSolver
from lpik.methods import ALL_METHODS, solve
from lpik.methods.l1 import l1
from lpik.methods.lp1 import lp1
from lpik.methods.lp2 import lp2
from lpik.problem import Problem
from lpik.robots.planar import planar_arm
from lpik.robots.tasks import PositionTask
from lpik_bench.workload import Workload, trajectory_controller

if TYPE_CHECKING:  # numba is optional: the compiled path is imported on use
    from lpik.control.controller import Lp2Controller
    from lpik.fast.arrays import BatchArrays
    from lpik.result import Result
    from lpik_bench.peers import PeerStep

FULL_STEP = "full step"
FULL_STEP_ACC = "full step +acc"
PLANAR_STEP = "full step, planar 4-link"
SOLVE = "solve"
FK_J = "FK + J"
REFERENCE = "machine reference"

#: The paper's 4-link arm and pull-in scenario (sec. 4), with acceleration limits.
PLANAR_LINKS = (1.0, 1.0, 1.0, 1.0)
PLANAR_Q0_DEG = (60.0, -30.0, -30.0, -30.0)
PLANAR_TARGET = (0.2, 0.8660, 0.0)
PLANAR_DT = 0.01

#: How :func:`lpik.methods.solve` runs each method (notes of the ``solve`` records).
SOLVE_NOTES = {
    "lp1": "a new HiGHS model every call",
    "l1": "a new HiGHS model every call",
    "lp2": "numpy ratio test (HiGHS only when K is singular)",
    "nlp": "SLSQP on the nonlinear program (the robot model itself)",
}


@dataclass(eq=False)
class Case:
    """One timed thing.

    Attributes:
        library: ``"lpik"`` or a peer's name.
        method: The method or function timed.
        what: How much of a step it covers (see the module docstring).
        call: Runs item ``i`` (any int; taken modulo the item count).
        per_call: Steps solved by one call (the batch size; 1 otherwise).
        peer: True for the other libraries' full steps (the ratios' reference).
        note: How it is set up.
        extra: Further keys of the case's timing record (e.g. the paths its steps take).
    """

    library: str
    method: str
    what: str
    call: Callable[[int], object]
    per_call: int = 1
    peer: bool = False
    note: str = ""
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def label(self) -> str:
        """``library / method / what``."""
        return f"{self.library} / {self.method} / {self.what}"


def controllers(workload: Workload) -> tuple[Lp2Controller, Lp2Controller]:
    """The fused controllers of the workload: end-stops + velocity, and + acceleration."""
    w = workload
    plain = trajectory_controller(w.model, w.dt, None)
    return plain, trajectory_controller(w.model, w.dt, w.qdd_max)


def workload_problems(workload: Workload) -> list[Problem]:
    """Each step of the workload as a :class:`Problem` (end-stops, velocity limits, M = I)."""
    plain, _ = controllers(workload)
    return [plain.problem(q, t) for q, t in zip(workload.q, workload.targets)]


@dataclass(frozen=True, eq=False)
class PlanarWorkload:
    """Steps of the paper's 4-link arm pulling in (one LP2 trajectory).

    Attributes:
        model: The planar arm (position task).
        q: Configurations, (N, 4) [rad]. q_prev: One period before, (N, 4).
        target: The commanded end-effector position (x, y, 0) [m].
        dt: Control period [s]. qdd_max: Acceleration limit [rad/s^2].
    """

    model: PositionTask
    q: np.ndarray
    q_prev: np.ndarray
    target: np.ndarray
    dt: float
    qdd_max: float

    def controller(self) -> Lp2Controller:
        """The fused controller with end-stops, velocity and acceleration limits."""
        from lpik.control.controller import Lp2Controller

        return Lp2Controller(self.model, dt=self.dt, v_max=0.5, qdd_max=self.qdd_max,
                             saturate=False, on_stall=None)  # fmt: skip


def planar_workload(steps: int = 400, qdd_max: float = 10.0) -> PlanarWorkload:
    """The pull-in scenario's trajectory under LP2 with acceleration limits, ``steps`` long."""
    deg = np.pi / 180.0
    model = planar_arm(
        PLANAR_LINKS,
        q_min=(-np.pi, -np.pi, -np.pi, -np.pi),
        q_max=(95 * deg, np.pi, np.pi, np.pi),
        qd_max=1.0,
    )
    target = np.array(PLANAR_TARGET)
    work = PlanarWorkload(model, np.empty(0), np.empty(0), target, PLANAR_DT, qdd_max)
    controller = work.controller()
    q = np.array(PLANAR_Q0_DEG) * deg
    prev = q.copy()
    qs, prevs = [], []
    for _ in range(steps):
        qs.append(q)
        prevs.append(prev)
        prev, q = q, controller.step(q, target, prev).q
    return PlanarWorkload(model, np.array(qs), np.array(prevs), target, PLANAR_DT, qdd_max)


def outcomes(results: list[Result]) -> str:
    """How often the steps end optimal with ``p = 1``, with ``p < 1``, or infeasible."""
    total = len(results)
    infeasible = sum(r.status == "infeasible" for r in results)
    scaled = sum(r.status == "optimal" and r.binding is not None for r in results)
    pct = 100.0 / max(total, 1)
    return (
        f"p = 1 on {(total - infeasible - scaled) * pct:.0f}% of steps, p < 1 on "
        f"{scaled * pct:.0f}%, infeasible (safe step) on {infeasible * pct:.0f}%"
    )


def fk_cases(workload: Workload) -> list[Case]:
    """Forward kinematics and Jacobian alone: the compiled kernel and the numpy chain."""
    from lpik.control.inputs import chain_arrays
    from lpik.fast.kinematics import chain_fk_jacobian

    q = workload.q
    N = len(workload)
    chain = workload.model.kinematics
    origins, axes, revolute, tip = chain_arrays(workload.model)
    T, J6 = np.empty((4, 4)), np.empty((6, workload.n))
    joints = np.empty((2, workload.n, 3))

    def compiled(i: int) -> None:
        chain_fk_jacobian(origins, axes, revolute, tip, q[i % N], T, J6, joints)

    def numpy_fk(i: int) -> object:
        return chain.fk_jacobian(q[i % N])

    return [
        Case("lpik", "chain_fk_jacobian (compiled)", FK_J, compiled, note="preallocated outputs"),
        Case("lpik", "SerialChain.fk_jacobian (numpy)", FK_J, numpy_fk),
    ]


def step_cases(workload: Workload, planar: PlanarWorkload) -> list[Case]:
    """Full steps: fused (with and without acceleration limits, planar, batched), numpy layers."""
    plain, acc = controllers(workload)
    planar_case = _planar_case(planar)
    return [
        *_fused_cases(workload, plain, acc),
        planar_case,
        *_fused_acc_output_cases(workload, acc),
        _numpy_layers_case(workload, plain),
    ]


def _planar_case(planar: PlanarWorkload) -> Case:
    """The fused step on the paper's planar arm, pulling in."""
    pc = planar.controller()
    pq, pprev, ptarget = planar.q, planar.q_prev, planar.target
    P = len(pq)
    planar_note = f"the paper's pull-in, {P} steps of {planar.dt:g} s; " + outcomes(
        [pc.step(pq[k], ptarget, pprev[k]) for k in range(P)]
    )

    def fused_planar(i: int) -> object:
        k = i % P
        return pc.step(pq[k], ptarget, pprev[k])

    return Case("lpik", "lp2 fused (compiled)", PLANAR_STEP, fused_planar, note=planar_note)


def _fused_cases(workload: Workload, plain: Lp2Controller, acc: Lp2Controller) -> list[Case]:
    """``Lp2Controller.step`` without and with acceleration limits."""
    q, prev, targets = workload.q, workload.q_prev, workload.targets
    N = len(workload)

    def fused(i: int) -> object:
        return plain.step(q[i % N], targets[i % N])

    def fused_acc(i: int) -> object:
        k = i % N
        return acc.step(q[k], targets[k], prev[k])

    plain_note = "Lp2Controller.step; " + outcomes([fused(i) for i in range(N)])
    acc_note = "Lp2Controller.step; " + outcomes([fused_acc(i) for i in range(N)])
    return [
        Case("lpik", "lp2 fused (compiled)", FULL_STEP, fused, note=plain_note),
        Case("lpik", "lp2 fused (compiled)", FULL_STEP_ACC, fused_acc, note=acc_note),
    ]


def _fused_acc_output_cases(workload: Workload, acc: Lp2Controller) -> list[Case]:
    """The fused step with acceleration limits into a preallocated array, and batched."""
    import numba

    q, prev, targets = workload.q, workload.q_prev, workload.targets
    N = len(workload)
    q_next = np.empty(workload.n)

    def fused_into(i: int) -> object:
        k = i % N
        return acc.step_into(q[k], targets[k], prev[k], out=q_next)

    def fused_batch(i: int) -> object:
        return acc.step_batch(q, targets, prev)

    return [
        Case(
            "lpik",
            "lp2 fused step_into (compiled)",
            FULL_STEP_ACC,
            fused_into,
            note="Lp2Controller.step_into: q into a preallocated array, p returned, no Result",
        ),
        Case(
            "lpik",
            "lp2 fused step_batch (compiled)",
            f"batch of {N} full steps +acc",
            fused_batch,
            per_call=N,
            note="Lp2Controller.step_batch over every (q, target, q_prev) of the workload, "
            f"{numba.get_num_threads()} numba threads",
        ),
    ]


def _numpy_layers_case(workload: Workload, plain: Lp2Controller) -> Case:
    """The same step through the numpy layers: the task model, ``build_problem``, ``lp2``."""
    q, targets = workload.q, workload.targets
    N = len(workload)

    def numpy_layers(i: int) -> object:
        k = i % N
        return lp2(plain.problem(q[k], targets[k]))

    return Case(
        "lpik",
        "lp2 (numpy layers)",
        FULL_STEP,
        numpy_layers,
        note="TaskModel + build_problem + lp2",
    )


def solve_cases(workload: Workload, problems: list[Problem]) -> list[Case]:
    """Every method on prepared problems; the LPs also with one HiGHS model reused."""
    model = workload.model
    N = len(problems)
    cases = []
    for name in ALL_METHODS:

        def run(i: int, name: str = name) -> object:
            return solve(problems[i % N], name, model=model)

        cases.append(Case("lpik", name, SOLVE, run, note=SOLVE_NOTES.get(name, "")))

    def compiled(i: int) -> object:
        return lp2(problems[i % N], path="compiled")

    note = 'lp2(problem, path="compiled")'
    cases.append(Case("lpik", "lp2 compiled", SOLVE, compiled, note=note))
    reused = {"lp1": HighsSolver(), "l1": HighsSolver(), "lp2 highs": HighsSolver()}

    def lp1_reused(i: int) -> object:
        return lp1(problems[i % N], solver=reused["lp1"])

    def l1_reused(i: int) -> object:
        return l1(problems[i % N], solver=reused["l1"])

    def lp2_highs(i: int) -> object:
        return lp2(problems[i % N], path="highs")

    def lp2_highs_reused(i: int) -> object:
        return lp2(problems[i % N], path="highs", solver=reused["lp2 highs"])

    note = "one HighsSolver across steps: new coefficients and bounds, warm start"
    cases += [
        Case("lpik", "lp1", "solve, HiGHS reused", lp1_reused, note=note),
        Case("lpik", "l1", "solve, HiGHS reused", l1_reused, note=note),
        Case("lpik", "lp2 highs", SOLVE, lp2_highs, note="a new HiGHS model every call"),
        Case("lpik", "lp2 highs", "solve, HiGHS reused", lp2_highs_reused, note=note),
    ]
    return cases


def batch_arrays(problems: list[Problem], size: int) -> BatchArrays:
    """The problems stacked and repeated to ``size`` items, as :class:`lpik.fast.BatchArrays`."""
    from dataclasses import fields

    from lpik.fast import BatchArrays

    base = BatchArrays.from_problems(problems)
    reps = -(-size // len(problems))
    stacked = {}
    for f in fields(BatchArrays):
        value = getattr(base, f.name)
        if isinstance(value, np.ndarray):
            tiled = np.concatenate([value] * reps)[:size]
            stacked[f.name] = np.ascontiguousarray(tiled)
        else:
            stacked[f.name] = value
    return BatchArrays(**stacked)


def batch_case(problems: list[Problem], size: int) -> Case:
    """:func:`lpik.fast.lp2_batch` on ``size`` prepared problems (per step)."""
    import numba

    from lpik.fast import lp2_batch

    arrays = batch_arrays(problems, size)

    def run(i: int) -> object:
        return lp2_batch(arrays, method="lp2")

    return Case(
        "lpik",
        "lp2_batch (compiled)",
        f"batch of {size}",
        run,
        per_call=size,
        note=f"prepared BatchArrays, {numba.get_num_threads()} numba threads",
    )


def reference_case(seed: int = 0) -> Case:
    """A bare ``numpy.linalg.solve`` of a 13x13 system: a yardstick of the machine's speed.

    The size of LP2's KKT system for the Panda's 6-D task (n + m = 13). Its time
    tells runs on a slow or busy machine apart (the issue measured about 8 us).
    """
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((13, 13)) + 13.0 * np.eye(13)
    b = rng.standard_normal(13)

    def run(i: int) -> object:
        return np.linalg.solve(A, b)

    return Case("numpy", "linalg.solve 13x13", REFERENCE, run, note="the machine's yardstick")


def peer_cases(peers: list[PeerStep], workload: Workload) -> list[Case]:
    """A full-step case for every loaded peer, on the same workload items as lpik's."""
    q, targets = workload.q, workload.targets
    N = len(workload)
    cases = []
    for peer in peers:

        def run(i: int, step: Callable[..., object] = peer.step) -> object:
            return step(q[i % N], targets[i % N])

        cases.append(Case(peer.library, peer.method, FULL_STEP, run, peer=True, note=peer.note))
    return cases
