"""The motion-quality metrics of one library's runs of one scenario.

Every metric is computed here from the joint coordinates the library produced
(its own integration ``q_next = q + dq``), with lpik's own forward kinematics
(every peer's agrees with it, :func:`lpik_bench.peers.load_peers`), so that
every library is measured by the same code:

- tracking error: position [mm] and orientation [mrad] of the pose after each
  step against the target commanded for that step, RMS and max, over the
  steps whose target is reachable;
- jitter: the total variation of the joint velocities, ``sum_k sum_j
  |qdot(k+1) - qdot(k)|`` [rad/s], from rest (the first step counts);
- the joint-velocity energy above :data:`HIGH_HZ`, ``sum_j integral
  qdot_j,high(t)^2 dt`` [rad^2/s] (FFT of each joint's velocity over each run,
  summed over joints and runs), and its share of all the velocity energy [%];
- the largest joint acceleration [rad/s^2] (from rest);
- limit violations: steps that leave an end-stop (more than ``STOP_TOL``),
  exceed a velocity limit or, where checked, an acceleration limit (more than
  ``STEP_TOL`` per step), with the worst excess;
- frozen steps: the target reachable, the error before the step above
  :data:`TRACK_TOL` and no joint moving more than :data:`FROZEN_DQ`;
- settling (point-to-point legs, the target one pose held from the first
  step): the settle time, after which the error stays within
  :data:`SETTLE_TOL` (the longest over the legs; infinite where a leg never
  settles), and the overshoot, the largest growth of the position error
  after its running minimum [mm];
- braking steps: the steps a library did not answer (lpik: the safe step, a
  status outside :data:`lpik.result.MOVING`; a peer: a failed step);
- recovery (runs with a final hold): whether the error stays within
  :data:`TRACK_TOL` over the last :data:`RECOVERY_WINDOW` steps, how long after
  the target's return it got there, and the jitter while the target was out of reach;
- lpik only: ``p`` (mean, share of ``p = 0``), statuses, binding limits, and
  how many frozen steps have no exact direction (LP1's ``p``, the largest of
  any step within the limits, is at most :data:`NO_DIRECTION_P`: a step that
  keeps the command's direction cannot move there, or by rounding only);
- the time of each step call [us].

A whole run of the suite is a :class:`SuiteResult`: one :class:`ScenarioResult`
(the metrics of every library on one scenario) per scenario.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.result import MOVING
from lpik.robots.tasks import PoseTask
from lpik.tolerances import STALL_P
from lpik.types import FloatArray
from lpik_bench.quality_reach import pose_error, solve_within_limits
from lpik_bench.quality_scenarios import Leg, Scenario, least_time_velocities
from lpik_bench.soak import STEP_TOL, STOP_TOL

#: Frequency above which joint-velocity energy counts as high-frequency [Hz].
HIGH_HZ = 5.0
#: Tracking tolerance: position [m] and orientation [rad].
TRACK_TOL = (1e-3, 5e-3)
#: A step that moves no joint by more than this [rad] is a frozen step (if the error is large).
FROZEN_DQ = 1e-7
#: A frozen step has no exact direction where LP1's ``p`` is at most this: the stall
#: stage's own "p near 0" (:data:`lpik.tolerances.STALL_P`). Counted at ``p = 0`` exactly,
#: the UR5e's frozen steps at its stretched elbow in scenario 11 (LP1's ``p`` about 1e-8
#: there, the task Jacobian near singular) read as steps with a direction to follow.
NO_DIRECTION_P = STALL_P
#: Steps at the end of a final hold over which a recovered run must stay within TRACK_TOL.
RECOVERY_WINDOW = 100
#: A point-to-point move has settled when the error stays within this: position [m],
#: orientation [rad].
SETTLE_TOL = (1e-5, 1e-5)
#: The steps after the target comes back within reach whose tracking error the report
#: gives apart from the rest (:func:`tracking_on_return`) [s].
RETURN_WINDOW = 1.0
#: Kinds of limit violation, in the order of the report.
KINDS = ("end-stop", "velocity", "acceleration")


@dataclass(eq=False)
class LegRun:
    """What one library did on one leg.

    Attributes:
        q: Joint coordinates, (N + 1, n): the start, then after each step.
        step_ns: Time of each step call [ns], (N,).
        p, status, binding: lpik's per-step ``p``, status and binding limit (None for peers).
        first_failure: What the first failed step said (None: none failed).
        failed_at: Which steps raised or returned no finite step (taken as the braking
            step), (N,) (None: none did).
    """

    q: FloatArray
    step_ns: NDArray[np.int64]
    p: FloatArray | None = None
    status: list[str] | None = None
    binding: list[str | None] | None = None
    first_failure: str | None = None
    failed_at: NDArray[np.bool_] | None = None

    @property
    def failed(self) -> int:
        """How many steps failed (:attr:`failed_at`)."""
        return 0 if self.failed_at is None else int(np.count_nonzero(self.failed_at))


def step_changes(q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """A run's joint steps ``dq`` (N, n) and their changes ``ddq`` (N, n), from rest."""
    dq = np.diff(q, axis=0)
    return dq, np.diff(np.vstack([np.zeros(q.shape[1]), dq]), axis=0)


def velocity_changes(ddq: FloatArray, dt: float) -> FloatArray:
    """The jitter's terms from :func:`step_changes`' ``ddq``: per step ``|qdot(k) - qdot(k-1)|``
    summed over the joints [rad/s]."""
    return np.abs(ddq).sum(axis=1) / dt


@dataclass(frozen=True)
class Recovery:
    """One leg's recovery: recovered, in how long [ms], jitter out of reach [rad/s], final error."""

    label: str
    recovered: bool
    after_ms: float | None
    chatter: float
    final_mm: float


@dataclass(frozen=True)
class Settling:
    """One point-to-point leg: settle time [ms] (None: never settled), overshoot [mm],
    braking steps, and the position [mm] and orientation [mrad] error at the end."""

    label: str
    settle_ms: float | None
    overshoot: float
    braking: int
    final: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class SlowSteps:
    """lpik's slowest steps: what the step times above the 99th percentile were.

    Attributes:
        statuses: The statuses of the steps slower than the 99th percentile, by count.
        legs: The legs of those steps, by count.
        share: Each of those statuses' share of all steps [%].
        slowest: The slowest step: its time [us], leg, step and status.
        runner_up: The second slowest step's time [us].
        p999: The 99.9th percentile of the step times [us].
    """

    statuses: Counter[str]
    legs: Counter[str]
    share: dict[str, float]
    slowest: tuple[float, str, int, str]
    runner_up: float
    p999: float


def slow_steps(us: FloatArray, statuses: list[str], where: list[tuple[str, int]]) -> SlowSteps:
    """:class:`SlowSteps` of step times ``us`` [us] with each step's status and (leg, step)."""
    slow = np.flatnonzero(us > np.percentile(us, 99))
    every = Counter(statuses)
    counts = Counter(statuses[k] for k in slow)
    order = np.argsort(us)
    last = int(order[-1])
    return SlowSteps(
        counts, Counter(where[k][0] for k in slow),
        {k: 100.0 * every[k] / len(statuses) for k in counts},
        (float(us[last]), where[last][0], where[last][1], statuses[last]),
        float(us[order[-2]]) if us.size > 1 else float(us[last]),
        float(np.percentile(us, 99.9)),
    )  # fmt: skip


@dataclass(frozen=True)
class FrozenDescent:
    """Where a leg first froze, and where a local descent of the pose error goes from there.

    The error at the frozen step (position [mm], orientation [mrad]), and where a
    bounded least-squares solve of the pose error started from that configuration ends
    (:func:`lpik_bench.quality_reach.solve_within_limits`), with the largest joint turn on
    the way [rad]: a solve that ends about as far off as the arm froze says the arm stands in
    a local minimum of the error within its end-stops, one that ends on the target says a
    local step could still have made progress.
    """

    label: str
    step: int
    frozen: tuple[float, float]
    descent: tuple[float, float]
    turn: float


@dataclass(frozen=True)
class Clearance:
    """One leg among obstacles: the distance to them at the start, its least, the steps
    until it stays at or above ``d_s`` (None: never), the tool's position error at the end.

    Distances and the error in [mm].
    """

    label: str
    start_mm: float
    min_mm: float
    out_after: int | None
    final_mm: float


@dataclass(eq=False)
class Metrics:
    """One library's metrics on one scenario (see the module docstring)."""

    pos_rms: float = 0.0
    pos_max: float = 0.0
    ori_rms: float = 0.0
    ori_max: float = 0.0
    jitter: float = 0.0
    #: Share of the joint-velocity energy above HIGH_HZ [%].
    high: float = 0.0
    #: Joint-velocity energy above HIGH_HZ [rad^2/s], shown beside the share: a share
    #: falls where a larger slow motion is added (a library that wanders off its path),
    #: the energy where the arm is held still (a library whose steps fail).
    high_energy: float = 0.0
    #: Point-to-point legs under acceleration limits: :attr:`high` of the least-time move
    #: between each leg's start and this library's end configuration
    #: (:func:`~lpik_bench.quality_scenarios.least_time_velocities`), None elsewhere.
    least_time_high: float | None = None
    acc_max: float = 0.0
    violations: dict[str, tuple[int, float]] = field(default_factory=dict)
    frozen: int = 0
    frozen_without_direction: int | None = None
    #: The legs with frozen steps, and how many each: ``(label, steps)``.
    frozen_legs: list[tuple[str, int]] = field(default_factory=list)
    #: lpik: the statuses and binding limits of the frozen steps, by count.
    frozen_statuses: Counter[str] = field(default_factory=Counter)
    frozen_bindings: Counter[str] = field(default_factory=Counter)
    #: lpik: per leg with frozen steps, the local descent from its first one.
    frozen_descents: list[FrozenDescent] = field(default_factory=list)
    #: lpik: the slowest steps (:class:`SlowSteps`), None for a peer.
    slow: SlowSteps | None = None
    failed: int = 0
    first_failure: str | None = None
    recoveries: list[Recovery] = field(default_factory=list)
    settlings: list[Settling] = field(default_factory=list)
    clearances: list[Clearance] = field(default_factory=list)
    braking: int = 0
    p_mean: float | None = None
    p_zero: float | None = None
    statuses: dict[str, int] = field(default_factory=dict)
    bindings: list[tuple[str, int]] = field(default_factory=list)
    step_us: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: Per leg: each step's term of the jitter (:func:`velocity_changes`) and whether the
    #: library held the arm there (a failed step, or no joint moving more than
    #: :data:`FROZEN_DQ`): what :func:`jitter_where_both_moved` compares.
    jitter_terms: list[FloatArray] = field(default_factory=list, repr=False)
    held: list[NDArray[np.bool_]] = field(default_factory=list, repr=False)
    #: Per leg: the position error after each step [m], and ``sigma_min / sigma_max`` of
    #: the task Jacobian where the target came back within reach (None: it never left).
    position_errors: list[FloatArray] = field(default_factory=list, repr=False)
    return_ratios: list[float | None] = field(default_factory=list, repr=False)

    @property
    def violation_steps(self) -> int:
        """Steps with a violation, all kinds together (a step may count under several)."""
        return sum(count for count, _ in self.violations.values())

    @property
    def recovered(self) -> int:
        """Legs recovered."""
        return sum(r.recovered for r in self.recoveries)

    @property
    def settle_ms(self) -> float:
        """The longest settle time of the point-to-point legs [ms] (inf: a leg never settled)."""
        times = [math.inf if s.settle_ms is None else s.settle_ms for s in self.settlings]
        return max(times, default=0.0)

    @property
    def overshoot(self) -> float:
        """The largest overshoot of the point-to-point legs [mm]."""
        return max((s.overshoot for s in self.settlings), default=0.0)

    @property
    def out_after(self) -> float:
        """The most steps a leg took to get out of ``d_s`` for good (inf: a leg never did)."""
        steps = [math.inf if c.out_after is None else c.out_after for c in self.clearances]
        return max(steps, default=0)

    @property
    def deeper(self) -> float:
        """How much closer to the obstacles than at its start a leg came, the most [mm]."""
        return max((max(c.start_mm - c.min_mm, 0.0) for c in self.clearances), default=0.0)

    @property
    def final_error(self) -> float:
        """The largest tool position error at the end of a leg among obstacles [mm]."""
        return max((c.final_mm for c in self.clearances), default=0.0)

    @property
    def step_median(self) -> float:
        """Median step time [us]."""
        return self.step_us[0]

    @property
    def step_p99(self) -> float:
        """99th-percentile step time [us]."""
        return self.step_us[1]

    @property
    def step_max(self) -> float:
        """Slowest step [us]."""
        return self.step_us[2]


def errors(
    model: PoseTask, poses: FloatArray, targets: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Position [m] and orientation [rad] error of each of ``poses`` against ``targets``."""
    out = np.array([model.difference(pose, t) for pose, t in zip(poses, targets)])
    return np.linalg.norm(out[:, :3], axis=1), np.linalg.norm(out[:, 3:], axis=1)


def high_energy(qdot: FloatArray, dt: float) -> tuple[float, float]:
    """Joint-velocity energy above :data:`HIGH_HZ` and in all, summed over joints.

    The line through each joint's first and last sample is removed before the
    FFT (so that the jump of the periodic extension leaks no energy upwards);
    the total is the energy of the velocities themselves. Both are sums of squared
    samples [rad^2/s^2] (Parseval); times ``dt`` they are integrals [rad^2/s].
    """
    n = qdot.shape[0]
    ramp = np.linspace(0.0, 1.0, n)[:, None]
    matched = qdot - (qdot[:1] + ramp * (qdot[-1:] - qdot[:1]))
    power = np.abs(np.fft.rfft(matched, axis=0)) ** 2
    power[1:] *= 2.0  # one-sided: every bin but the mean stands for two
    if n % 2 == 0:
        power[-1] /= 2.0  # the Nyquist bin stands for one
    freq = np.fft.rfftfreq(n, dt)
    return float(power[freq > HIGH_HZ].sum()) / n, float((qdot**2).sum())


def _violations(
    q: FloatArray, dq: FloatArray, ddq: FloatArray, model: PoseTask, dt: float, qdd: float | None
) -> dict[str, tuple[int, float]]:
    """Per kind: steps with a violation and the worst excess [rad, rad/s, rad/s^2]."""
    past = np.maximum(np.maximum(q - model.q_max, model.q_min - q), 0.0).max(axis=1)
    speed = (np.abs(dq) - model.qd_max * dt).max(axis=1)
    found = {"end-stop": (past, STOP_TOL, 1.0), "velocity": (speed, STEP_TOL, dt)}
    if qdd is not None:
        found["acceleration"] = ((np.abs(ddq) - qdd * dt * dt).max(axis=1), STEP_TOL, dt * dt)
    out = {}
    for kind, (excess, tol, scale) in found.items():
        bad = excess > tol
        out[kind] = (int(bad.sum()), float(excess[bad].max() / scale) if bad.any() else 0.0)
    return out


def scenario_metrics(
    model: PoseTask,
    legs: tuple[Leg, ...],
    runs: list[LegRun],
    dt: float,
    qdd: float | None,
    direction: Callable[[FloatArray, FloatArray, FloatArray], float] | None = None,
) -> Metrics:
    """The metrics of one library over the legs of a scenario.

    Args:
        model: lpik's pose task of the arm (forward kinematics, limits).
        legs: The scenario's legs. runs: The library's run of each.
        dt: Control period [s].
        qdd: Acceleration limit to check [rad/s^2], or None.
        direction: ``direction(q, q_prev, target)``, the largest ``p`` of any step
            within the limits (lpik's rows); the frozen steps where it is 0 are
            counted in :attr:`Metrics.frozen_without_direction`.
    """
    m = Metrics(frozen_without_direction=None if direction is None else 0)
    pos_all, ori_all, times, ps = [], [], [], []
    high = total = least_high = least_total = 0.0
    bindings: Counter[str] = Counter()
    each_status: list[str] = []
    where: list[tuple[str, int]] = []
    for leg, run in zip(legs, runs):
        q = run.q
        dq, ddq = step_changes(q)
        poses = np.array([model.pose(qk) for qk in q])
        before = errors(model, poses[:-1], leg.targets)  # q(k) against target k
        after = errors(model, poses[1:], leg.targets)  # q(k + 1) against target k
        ok = leg.reachable
        pos_all.append(after[0][ok])
        ori_all.append(after[1][ok])
        change = velocity_changes(ddq, dt)
        m.jitter += float(change.sum())
        m.acc_max = max(m.acc_max, float(np.abs(ddq).max()) / (dt * dt))
        h, t = high_energy(dq / dt, dt)
        high, total = high + h, total + t
        for kind, (count, worst) in _violations(q[1:], dq, ddq, model, dt, qdd).items():
            old = m.violations.get(kind, (0, 0.0))
            m.violations[kind] = (old[0] + count, max(old[1], worst))
        moving = np.abs(dq).max(axis=1) > FROZEN_DQ
        _keep_steps(m, model, leg, run, change, after[0], moving)
        _keep_frozen(m, model, leg, run, before, moving, direction)
        m.failed += run.failed
        m.first_failure = m.first_failure or run.first_failure
        if leg.settle_from is not None:
            m.recoveries.append(_recovery(leg, after, change, dt))
        if leg.held:
            m.settlings.append(_settling(leg, after, _braking(run), dt))
            h, t = _least_time_energy(model, q, qdd, dt)
            least_high, least_total = least_high + h, least_total + t
        if leg.scene is not None:
            m.clearances.append(_clearance(model, leg, q, after[0][-1]))
        m.braking += _braking(run)
        times.append(run.step_ns)
        if run.p is not None:
            ps.append(run.p)
            bindings.update(b for b in run.binding or [] if b is not None)
            each_status += list(run.status or [])
            where += [(leg.label, k) for k in range(len(run.step_ns))]
    pos, ori = np.concatenate(pos_all), np.concatenate(ori_all)
    if pos.size:
        m.pos_rms, m.pos_max = 1e3 * float(np.sqrt(np.mean(pos**2))), 1e3 * float(pos.max())
        m.ori_rms, m.ori_max = 1e3 * float(np.sqrt(np.mean(ori**2))), 1e3 * float(ori.max())
    m.high = 100.0 * high / total if total > 0 else 0.0
    m.high_energy = high * dt
    if least_total > 0:
        m.least_time_high = 100.0 * least_high / least_total
    _keep_times(m, np.concatenate(times) / 1e3, each_status, where)
    if ps:
        p = np.concatenate(ps)
        m.p_mean, m.p_zero = float(p.mean()), 100.0 * float(np.mean(p <= 0.0))
        m.statuses = dict(Counter(each_status).most_common())
        m.bindings = bindings.most_common(3)
    return m


def _keep_times(
    m: Metrics, us: FloatArray, statuses: list[str], where: list[tuple[str, int]]
) -> None:
    """The step times [us]: median, p99 and max, and (lpik: ``statuses``) the slowest steps."""
    m.step_us = (float(np.median(us)), float(np.percentile(us, 99)), float(us.max()))
    if len(statuses) == us.size and us.size:
        m.slow = slow_steps(us, statuses, where)


def jitter_where_both_moved(a: Metrics, b: Metrics) -> tuple[float, float, int]:
    """The jitter of ``a`` and of ``b`` over the steps on which neither held the arm.

    A library that fails a step (held still, or braked) or holds the arm still
    adds nothing to its jitter there, however far its target is: this sums both
    libraries' jitter terms over the steps on which both moved, so that a
    library that moves where the other gives up is compared on common ground.

    Returns:
        ``(jitter of a, jitter of b, steps on which b held the arm and a moved)``.
    """
    ja = jb = 0.0
    only_a = 0
    for ta, ha, tb, hb in zip(a.jitter_terms, a.held, b.jitter_terms, b.held):
        both = ~ha & ~hb
        ja += float(ta[both].sum())
        jb += float(tb[both].sum())
        only_a += int(np.count_nonzero(~ha & hb))
    return ja, jb, only_a


def _least_time_energy(
    model: PoseTask, q: FloatArray, qdd: float | None, dt: float
) -> tuple[float, float]:
    """:func:`high_energy` of the least-time move from ``q[0]`` to ``q[-1]`` over the run's
    steps (:func:`~lpik_bench.quality_scenarios.least_time_velocities`); 0, 0 without ``qdd``."""
    if qdd is None:
        return 0.0, 0.0
    least = least_time_velocities(q[-1] - q[0], model.qd_max, qdd, dt, q.shape[0] - 1)
    return high_energy(least, dt)


def _keep_frozen(
    m: Metrics, model: PoseTask, leg: Leg, run: LegRun, before: tuple[FloatArray, FloatArray],
    moving: NDArray[np.bool_], direction: Callable[..., float] | None,
) -> None:  # fmt: skip
    """Count a leg's frozen steps (the error ``before`` each step beyond :data:`TRACK_TOL`,
    the target reachable, no joint ``moving``), those without an exact ``direction``, where
    they are, and (lpik) their statuses, binding limits and the local descent from the
    first (:class:`FrozenDescent`)."""
    far = (before[0] > TRACK_TOL[0]) | (before[1] > TRACK_TOL[1])
    frozen = np.flatnonzero(leg.reachable & far & ~moving)
    if not frozen.size:
        return
    m.frozen += int(frozen.size)
    if direction is not None:  # the run starts at rest: q_prev of step 0 is q(0)
        q = run.q
        m.frozen_without_direction = (m.frozen_without_direction or 0) + sum(
            direction(q[k], q[max(k - 1, 0)], leg.targets[k]) <= NO_DIRECTION_P for k in frozen
        )
    m.frozen_legs.append((leg.label, int(frozen.size)))
    if run.status is not None and run.binding is not None:
        m.frozen_statuses.update(run.status[k] for k in frozen)
        m.frozen_bindings.update(run.binding[k] or "none" for k in frozen)
        m.frozen_descents.append(frozen_descent(model, leg, run.q, int(frozen[0]), before))


def frozen_descent(
    model: PoseTask, leg: Leg, q: FloatArray, k: int, before: tuple[FloatArray, FloatArray]
) -> FrozenDescent:
    """:class:`FrozenDescent` of ``leg`` frozen at step ``k`` (configurations ``q``)."""
    end, _ = solve_within_limits(model, leg.targets[k], [q[k]])
    pos, ori = pose_error(model, model.pose(end), leg.targets[k])
    return FrozenDescent(
        leg.label, k, (1e3 * float(before[0][k]), 1e3 * float(before[1][k])),
        (1e3 * pos, 1e3 * ori), float(np.abs(end - q[k]).max()),
    )  # fmt: skip


def _keep_steps(
    m: Metrics, model: PoseTask, leg: Leg, run: LegRun, change: FloatArray,
    position_error: FloatArray, moving: NDArray[np.bool_],
) -> None:  # fmt: skip
    """Keep one leg's per-step values that the report compares between two libraries."""
    m.jitter_terms.append(change)
    m.position_errors.append(position_error)
    m.held.append(~moving if run.failed_at is None else ~moving | run.failed_at)
    back = np.flatnonzero(return_steps(leg.reachable, 1))
    m.return_ratios.append(singular_ratio(model, run.q[back[0]]) if back.size else None)


def return_steps(reachable: NDArray[np.bool_], window: int) -> NDArray[np.bool_]:
    """The reachable steps within ``window`` steps after the target came back within reach."""
    out = np.zeros(reachable.size, dtype=bool)
    for k in np.flatnonzero(reachable[1:] & ~reachable[:-1]) + 1:
        out[k : k + window] = True
    return out & reachable


def singular_ratio(model: PoseTask, q: FloatArray) -> float:
    """``sigma_min / sigma_max`` of the task Jacobian at ``q``: how near a singular pose."""
    s = np.linalg.svd(model.jacobian(q), compute_uv=False)
    return float(s[-1] / s[0])


def tracking_on_return(
    a: Metrics, b: Metrics, legs: tuple[Leg, ...], dt: float
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """Position error RMS [mm] of ``a`` and ``b`` on the return and on the other steps.

    The return: the reachable steps within :data:`RETURN_WINDOW` after the target
    came back within reach (:func:`return_steps`), where a library that waited
    near a singular configuration (:func:`singular_ratio`) while the target was
    out of reach has further to come back. None where no target leaves the reach.

    Returns:
        ``((a, b) on the return, (a, b) on the other reachable steps)``.
    """
    window = max(1, round(RETURN_WINDOW / dt))
    back = [return_steps(leg.reachable, window) for leg in legs]
    if not any(x.any() for x in back):
        return None

    def rms(m: Metrics, pick: Callable[[int], NDArray[np.bool_]]) -> float:
        e = np.concatenate([err[pick(i)] for i, err in enumerate(m.position_errors)])
        return 1e3 * float(np.sqrt(np.mean(e**2))) if e.size else 0.0

    def rest(i: int) -> NDArray[np.bool_]:
        return legs[i].reachable & ~back[i]

    return (rms(a, back.__getitem__), rms(b, back.__getitem__)), (rms(a, rest), rms(b, rest))


def _recovery(
    leg: Leg, after: tuple[FloatArray, FloatArray], change: FloatArray, dt: float
) -> Recovery:
    """Whether and when the run tracks again after the target's return (see the module doc)."""
    start = leg.settle_from or 0
    good = (after[0] <= TRACK_TOL[0]) & (after[1] <= TRACK_TOL[1])
    recovered = bool(good[-RECOVERY_WINDOW:].all())
    bad_after = np.nonzero(~good[start:])[0]
    first_good = start + (int(bad_after[-1]) + 1 if bad_after.size else 0)
    after_ms = 1e3 * (first_good - start) * dt if recovered else None
    out = ~leg.reachable
    chatter = float(change[1:][out[1:] & out[:-1]].sum())
    return Recovery(leg.label, recovered, after_ms, chatter, 1e3 * float(after[0][-1]))


def _clearance(model: PoseTask, leg: Leg, q: FloatArray, final: float) -> Clearance:
    """The clearance of a run among the leg's obstacles (see :class:`Clearance`)."""
    from lpik_bench.quality_obstacle import ball_distances

    distance = ball_distances(model, leg.scene, leg.q0)
    d = np.array([distance(qk) for qk in q])
    inside = np.flatnonzero(d < leg.scene.safety_distance)
    out_after = 0 if not inside.size else int(inside[-1]) + 1
    never = out_after >= d.size
    return Clearance(leg.label, 1e3 * float(d[0]), 1e3 * float(d.min()),
                     None if never else out_after, 1e3 * float(final))  # fmt: skip


def _braking(run: LegRun) -> int:
    """Steps the library did not answer: lpik's safe steps, a peer's failed steps."""
    if run.status is None:
        return run.failed
    return sum(status not in MOVING for status in run.status)


def settle_and_overshoot(
    position: FloatArray, orientation: FloatArray, dt: float
) -> tuple[float | None, float]:
    """A point-to-point move's settle time [ms] (None: never) and overshoot [mm].

    From the position [m] and orientation [rad] error after each step: the time
    from which both stay within :data:`SETTLE_TOL`, and the largest growth of the
    position error after its running minimum (see the module docstring).
    """
    good = (position <= SETTLE_TOL[0]) & (orientation <= SETTLE_TOL[1])
    bad = np.flatnonzero(~good)
    first = int(bad[-1]) + 1 if bad.size else 0  # the step from which it stays settled
    settle_ms = 1e3 * (first + 1) * dt if first < good.size else None
    return settle_ms, 1e3 * float(np.max(position - np.minimum.accumulate(position)))


def _settling(leg: Leg, after: tuple[FloatArray, FloatArray], braking: int, dt: float) -> Settling:
    """Settle time and overshoot of a point-to-point leg (:func:`settle_and_overshoot`)."""
    position, orientation = after
    settle_ms, overshoot = settle_and_overshoot(position, orientation, dt)
    final = (1e3 * float(position[-1]), 1e3 * float(orientation[-1]))
    return Settling(leg.label, settle_ms, overshoot, braking, final)


@dataclass(eq=False)
class ScenarioResult:
    """One scenario's rows: contender name -> metrics, in the order run.

    ``lpik``: the rows of lpik's variants; ``limited``: the rows of the libraries
    that hold the acceleration limit (lpik's +acc variants, Drake's +acc step);
    ``progress``: lpik's variants in the progress mode; ``not_applicable``: the
    libraries that did not run for want of obstacle support.
    """

    scenario: Scenario
    rows: dict[str, Metrics] = field(default_factory=dict)
    lpik: set[str] = field(default_factory=set)
    wall_s: float = 0.0
    limited: set[str] = field(default_factory=set)
    progress: set[str] = field(default_factory=set)
    not_applicable: list[str] = field(default_factory=list)


@dataclass(eq=False)
class SuiteResult:
    """The whole run: scenario results, contenders' notes, skipped ones, the environment."""

    scenarios: list[ScenarioResult]
    notes: dict[str, str]
    skipped: list[str]
    environment: dict[str, Any]
    wall_s: float = 0.0
