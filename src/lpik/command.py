"""The command law: how a target becomes one step's commanded displacement ``dw`` (eq. 2).

One law serves every path: :func:`simulate`, the compiled
:class:`~lpik.control.controller.Lp2Controller` (whose kernel compiles
:func:`command_rows` itself), the operator console,
the command line and the benchmarks. Toward a target, the step's displacement
is ``dw = difference(pose(q), target)``, scaled down (as a whole, so that its
direction is kept) until its linear part is at most ``v_max dt`` [m] and its
angular part at most ``w_max dt`` [rad].

On a pose task that keeps position and rotation rows, the step goes to that
clamped pose (the chord and the turn scaled alike) along its own screw
(:func:`along_screw`): the linear part is the task point's displacement under
the constant twist that reaches it, not the chord, which is off by half the
turn times the chord (second order in the step). The next step would have to
correct that, and near a singular configuration the correction takes large
joint velocities (benchmarks/quality.py, scenario 5). A target that one joint's
turn (or any motion of constant twist) reaches within a step is thus commanded
exactly, ``dw = J dq``, while a far target is still approached along the
straight line (the chord, and the rotation vector) as the clamp leaves it.

The compiled controller (``Lp2Controller(second_order=True)``, its default)
also takes off each step's command what the Jacobian's linear prediction of
the last step missed (:func:`second_order_term`): the motion's second-order
term, which the next step would otherwise miss the same way, so that on a
curved path or a turning frame the error left after each step is third order
instead of second (benchmarks/quality.py: scenario 4's orientation error falls
from 1.4e-5 to 2.6e-7 rad RMS). :func:`~lpik.control.simulate.simulate` and the
console do the same; the paper's runs command the law above alone.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from lpik.bands import MET, braking_room, plausible_step
from lpik.problem import check_magnitude
from lpik.robots.base import TaskModel
from lpik.robots.rotations import check_rotation
from lpik.robots.tasks import pose_difference
from lpik.tolerances import REST_STEP
from lpik.types import FloatArray, numbers_of

#: Default largest commanded linear speed of the task point [m/s].
DEFAULT_V_MAX = 0.5
#: Default largest commanded angular speed of the task frame [rad/s].
DEFAULT_W_MAX = 1.0
#: The rows a task may keep, in order; rows 0-2 are linear [m], 3-5 angular [rad].
TASK_ROWS = ("x", "y", "z", "rx", "ry", "rz")


def task_rows(model: TaskModel) -> FloatArray:
    """Index in :data:`TASK_ROWS` of each of the model's task rows, as floats (kernel input)."""
    names = getattr(model, "row_names", None)
    if names is None:  # a model without row names: every row is linear
        return np.zeros(model.task_dim)
    return np.array([TASK_ROWS.index(name) for name in names], dtype=np.float64)


def clamp_command(
    dw: FloatArray, rows: FloatArray, v_max: float, w_max: float, dt: float, brake: float
) -> float:
    """Scale ``dw`` in place: linear part at most ``v_max dt``, angular part at most ``w_max dt``.

    The whole displacement is scaled by one factor, so that its direction is kept;
    the factor is at most ``brake`` (:func:`braking_scale`; ``inf``: no braking).
    Written in plain loops so that :mod:`lpik.fast` compiles this very function.

    Args:
        dw: Commanded displacement, (m,), changed in place.
        rows: Index of each row in :data:`TASK_ROWS` (``< 3``: linear), (m,).
        v_max: Largest linear speed [m/s].
        w_max: Largest angular speed [rad/s].
        dt: Control period [s].
        brake: Largest share of ``dw`` the step may take to stop in time.

    Returns:
        The factor, in (0, 1].
    """
    lin, ang = 0.0, 0.0
    for k in range(dw.shape[0]):
        if rows[k] < 3:
            lin += dw[k] * dw[k]
        else:
            ang += dw[k] * dw[k]
    lin, ang = math.sqrt(lin), math.sqrt(ang)
    scale = min(1.0, brake)
    if lin > v_max * dt:
        scale = min(scale, v_max * dt / lin)
    if ang > w_max * dt:
        scale = min(scale, w_max * dt / ang)
    for k in range(dw.shape[0]):
        dw[k] *= scale
    return scale


#: Share of the joints' acceleration limits that the command law plans its stop
#: with; the rest is left for what the plan does not see (the motion's
#: curvature, the second-order term, the redundancy's own motion). Measured with
#: ``benchmarks/braking.py`` (its rows "turning": moves to the tool poses of nearby
#: configurations, the tool turning as it goes, the command unclamped): at 0.8 the
#: arms passed such goals by up to 62 mm (9 of its 12 unclamped rows beyond 1 mm, and a
#: UR5e move unsettled after 109 safe steps), the plan's deceleration along the least
#: joint motion outrunning what the step could hold while turning (an iiwa14 move at
#: 5 rad/s^2 decelerated at 85 % of the plan from 330 mm out and passed its goal by
#: 13 mm); at 0.6 one row is beyond 1 mm (8.1 mm, the iiwa14 with 20 (base) to 1
#: (wrist) rad/s^2), every move settles, the slowest translation of a row settles 3 to
#: 14 % later, and beyond reach (``benchmarks/excursions.py``) 209 of 210 excursions come
#: back against 208.
BRAKING_SHARE = 0.6
#: At most this share of a joint's planned brake (``BRAKING_SHARE`` of its limit) is counted
#: as taken by keeping the task's motion (:func:`braking_scale`'s hold): the hold is one step's
#: estimate, it grows with the square of the speed and falls as the arm slows down, and a
#: joint that has all of it taken would command no motion at all. Measured (with
#: ``BRAKING_SHARE`` at 0.8) with the
#: point-to-point moves of ``benchmarks/braking.py`` (overshoot) and the acceleration
#: reversals over ``benchmarks/random_goals.py`` with ``qdd_max=10`` (Panda, UR5e, iiwa14;
#: without the hold 1,967, 1,321 and 892): all of it counted, 2,673, 2,306 and 1,016
#: reversals; at most 0.75, 2,095, 1,562, 865; at 0.65, 2,003, 1,333 and 860, no move
#: passing its goal; at 0.5, 1,977, 1,284, 843, but the Panda with 2 rad/s^2 and the
#: command unclamped passed the goal of a 22 cm move by 5 mm.
HOLD_SHARE = 0.65
# Measured and not kept: a cap on the command's speed where keeping the task's motion on its
# line (the hold, which grows with the square of the speed) would alone need more than a
# joint's acceleration limit. At 2 rad/s^2 and 500 Hz, on the UR5e's ten goals of
# benchmarks/random_goals.py's draw with seed 1, it took goal 1 from 10.2 to 5.0 s and the
# acceleration reversals from 1,235 to 639; at 10 rad/s^2 it added a tenth to the Panda's and
# the UR5e's reversals, and the Panda pushed a metre beyond reach along (-1, 1, 1) no longer
# came home (tests/test_fading_motion.py).

#: The largest finite double: :func:`braking_scale` divides a limit by a joint's need only
#: where the quotient stays below it.
_LARGEST = sys.float_info.max


#: Damping of :func:`least_motion`, relative to the largest entry of ``J J^T``.
MOTION_DAMPING = 1e-4


def least_motion(J: FloatArray, e: FloatArray, x: FloatArray, scratch: FloatArray) -> None:
    """``x_j = J^T (J J^T + d I)^-1 e_j``: the least joint motion that moves the task by ``e_j``.

    The damped least-squares solution of ``J x = e`` (as eq. 19's robust inverse),
    with a damping ``d`` of :data:`MOTION_DAMPING` times the largest diagonal
    entry of ``J J^T``: directions the arm can hardly move in (near a singular
    configuration) count for little instead of making ``x`` blow up. Gaussian
    elimination with partial pivoting, one for every row of ``e``, in plain loops,
    so that :mod:`lpik.fast` compiles this very function.

    Args:
        J: Task Jacobian, (m, n).
        e: Task motions, (k, m).
        x: Receives their joint motions, (k, n).
        scratch: Work space, (m, m + k).
    """
    m, n, k = J.shape[0], J.shape[1], e.shape[0]
    width = m + k
    big = 0.0
    for a in range(m):
        for b in range(m):
            s = 0.0
            for i in range(n):
                s += J[a, i] * J[b, i]
            scratch[a, b] = s
        for j in range(k):
            scratch[a, m + j] = e[j, a]
        big = max(big, scratch[a, a])
    for a in range(m):
        scratch[a, a] += MOTION_DAMPING * max(big, 1e-300)
    for col in range(m):
        pivot = col
        for a in range(col + 1, m):
            if abs(scratch[a, col]) > abs(scratch[pivot, col]):
                pivot = a
        for b in range(width):
            scratch[col, b], scratch[pivot, b] = scratch[pivot, b], scratch[col, b]
        for a in range(col + 1, m):
            factor = scratch[a, col] / scratch[col, col]
            for b in range(col, width):
                scratch[a, b] -= factor * scratch[col, b]
    for j in range(m, width):
        for a in range(m - 1, -1, -1):
            s = scratch[a, j]
            for b in range(a + 1, m):
                s -= scratch[a, b] * scratch[b, j]
            scratch[a, j] = s / scratch[a, a]
    for j in range(k):
        for i in range(n):
            s = 0.0
            for a in range(m):
                s += J[a, i] * scratch[a, m + j]
            x[j, i] = s


def braking_scale(
    motion: FloatArray, hold: FloatArray, qdd_max: FloatArray, qd_max: FloatArray, dt: float
) -> float:
    """The largest share of the error a step may command and still stop on the target.

    The command moves the task along the remaining error ``e`` toward the
    target; ``motion`` is the joint motion per unit of it (:func:`least_motion`
    of ``e``). Slowing down along ``e`` at a rate ``a`` (shares of ``e`` per
    s^2) takes joint accelerations ``a |motion_i|``; within
    :data:`BRAKING_SHARE` of each joint's limit, ``a`` is at most
    ``BRAKING_SHARE min_i qdd_max_i / |motion_i|``, less what the task's own motion
    already takes: ``hold`` is the change of the joints' step that keeps the task
    moving as it does, the least joint motion (:func:`least_motion`) of the *turn*
    ``J(q_prev) last - J(q0) last`` (``last = q0 - q_prev``: what the same joint step
    moves the task less at ``q0`` than it did at ``q_prev``, as the Jacobian turns
    along the motion), and where it slows a
    joint down as a brake along ``e`` would (its sign against ``motion_i``'s), that
    joint has that much less to brake with (up to :data:`HOLD_SHARE` of it). At
    speed, a joint with a low limit can spend all of it on keeping the tool on its
    line: the Panda with limits from 1 to 20 rad/s^2 (base to wrist), a 21 cm move
    with the command unclamped, passed its goal by 29 mm.
    The step's share is then the largest after which the motion can still stop
    within the rest of ``e`` (:func:`lpik.bands.braking_room`, the same discrete rule
    that keeps a joint clear of its end-stop, here with room 1: the whole error), and
    at most what the joints' velocity limits allow along ``motion`` in one step: a
    command the joints cannot follow would only build up a motion that the
    acceleration limits cannot turn. A step that can stop at once takes the
    whole error: the command ends on the target.

    Args:
        motion: Joint motion per unit of the error, (n,).
        hold: The change of the joints' step [rad] that keeps the task's motion, (n,): the
            least motion of the turn.
        qdd_max: Each joint's acceleration limit (the smaller side) [rad/s^2]; inf: none.
        qd_max: Each joint's velocity limit (the smaller side) [rad/s]; inf: none.
        dt: Control period [s].

    Returns:
        The share, > 0; ``inf`` without acceleration or velocity limits.
    """
    rate, speed = math.inf, math.inf
    for i in range(motion.shape[0]):
        need = abs(motion[i])
        # a need so small that the quotient would overflow bounds nothing (no overflow warning)
        if need > 0.0:
            if qdd_max[i] < math.inf:
                brake = BRAKING_SHARE * qdd_max[i]
                taken = max(0.0, -math.copysign(1.0, motion[i]) * hold[i]) / (dt * dt)
                room = brake - min(taken, HOLD_SHARE * brake)
                if need > room / _LARGEST:
                    rate = min(rate, room / need)
            if qd_max[i] < math.inf and need > qd_max[i] / _LARGEST:
                speed = min(speed, qd_max[i] / need)
    share = speed * dt
    if rate < math.inf:
        share = min(share, braking_room(1.0, rate * dt * dt))
    return share


def add_target_motion(
    dw: FloatArray, motion: FloatArray, rows: FloatArray, v_max: float, w_max: float, dt: float
) -> None:
    """``dw += motion``: the target's own motion over the last period, fed forward; clamped again.

    Under acceleration limits the command brakes to stop on the target
    (:func:`braking_scale`). A target that moves on is not where the arm
    stops: braked toward each new position, the arm would lag behind a moving
    target by its braking distance. The target's own displacement over the
    last period (the task rows of ``[p_t - p_t,prev; log(R_t R_t,prev^T)]``)
    is added to the braked command, so that the braking acts on the error
    relative to the target's motion: a target moving at a constant speed is
    tracked without lag, and one that stops is braked for as before. The sum
    is clamped as a whole (:func:`clamp_command`, ``v_max``, ``w_max``).
    Only consecutive steps of one loop have a target motion
    (:class:`TargetMotion`). Plain loops: :mod:`lpik.fast` compiles this very
    function.

    Args:
        dw: The braked, clamped command, (m,), changed in place.
        motion: The target's motion over the last period in the task's rows, (m,).
        rows: Index of each kept row in :data:`TASK_ROWS`, (m,).
        v_max: Largest linear speed [m/s].
        w_max: Largest angular speed [rad/s].
        dt: Control period [s].
    """
    for k in range(rows.shape[0]):
        dw[k] += motion[k]
    clamp_command(dw, rows, v_max, w_max, dt, math.inf)


class TargetMotion:
    """The target's motion over the last period, where the step follows the last one in a loop.

    A step follows the last one when the arm moved (some joint by more than rounding:
    :func:`moved_beyond_rounding`) and its
    ``q_prev`` is the last step's ``q0``; the same step asked again (the same
    ``q0`` and target) gets the same motion; any other step (a first step, a
    step at rest or without ``q_prev``: an independent query, a jump of the
    state, a row of a batch) has none. The fused step keeps the same memory in
    its state (:func:`lpik.fast.command_law.target_motion`).
    """

    def __init__(self) -> None:
        self._q: FloatArray | None = None
        self._target: FloatArray | None = None
        self._motion: FloatArray | None = None

    def motion(
        self, model: TaskModel, q0: FloatArray, q_prev: FloatArray | None, target: Any
    ) -> FloatArray | None:
        """The rows of ``[p_t - p_t,prev; log(R_t R_t,prev^T)]``, or None (remembers the step)."""
        value = np.asarray(target, dtype=np.float64)
        seen = self._q is not None
        if seen and np.array_equal(q0, self._q) and np.array_equal(value, self._target):
            return self._motion  # the same step again
        motion = None
        moved = q_prev is not None and moved_beyond_rounding(q0, q_prev)
        if seen and moved and np.array_equal(q_prev, self._q):
            motion = _target_difference(model, self._target, value)
        self._q, self._target, self._motion = np.array(q0, dtype=np.float64), value.copy(), motion
        return motion

    def follow(self, q0: FloatArray, q_prev: FloatArray, taken: FloatArray) -> None:
        """A measured loop's check took ``taken`` in place of ``q_prev`` (:func:`continues_with`).

        Where ``q_prev`` is the last step's ``q0``, the step still follows the last one,
        and is asked with ``taken``: remembered as the key of that continuity.
        """
        if self._q is not None and continues_with(self._q, q0, q_prev, taken):
            self._q = np.array(taken, dtype=np.float64)


def moved_beyond_rounding(q0, q_prev):  # type: ignore[no-untyped-def]
    """Whether some joint moved from ``q_prev`` to ``q0`` by more than :data:`REST_STEP`.

    Only then does a loop's next step get the target's motion fed forward
    (:class:`TargetMotion`): a step that moved the joints by rounding alone left the
    arm at rest, alike on both engines. A plain loop, compiled as it is by the fused step.
    """
    for i in range(q0.shape[0]):
        if abs(q0[i] - q_prev[i]) > REST_STEP:
            return True
    return False


def continues_with(seen, q0, q_prev, taken):  # type: ignore[no-untyped-def]
    """Whether a loop's memory of the last step's ``q0`` (``seen``) is to be keyed by ``taken``.

    A loop closed on measured joints has ``q_prev`` taken at the nearest motion
    the drives could have made (:mod:`lpik.control.commanded`); the step still
    follows the last one where the caller's ``q_prev`` is ``seen``. The memory
    that feeds the target's motion forward (:class:`TargetMotion`, and the fused
    step's ``memory_q`` block) then holds ``taken``, so that the step asked with it
    follows too: without that, every corrected step lost the feed-forward and the
    tool lagged a moving target (3.3 mm on the quality suite's circle at
    ``qdd_max=10``, at any noise from 1e-5 rad up, against 0.15 mm fed its
    commands). A ``taken`` within rounding of ``q0`` (no motion:
    :func:`moved_beyond_rounding`) keeps nothing. Plain loops: the fused step compiles this
    very function (:mod:`lpik.fast.command_law`).
    """
    same = True
    for i in range(seen.shape[0]):
        same = same and q_prev[i] == seen[i]
    return same and moved_beyond_rounding(q0, taken)


def _target_difference(model: TaskModel, before: Any, after: Any) -> FloatArray:
    """``after - before`` in the task's rows (a pose task: the rows of its pose difference)."""
    if getattr(model, "KIND", None) == "pose":
        return pose_difference(before, after)[task_rows(model).astype(int)]
    return np.asarray(model.difference(before, after), dtype=np.float64)


def along_screw(e6: FloatArray, rows: FloatArray, scale: float) -> bool:
    """The step ``scale [dp; phi]`` of a pose difference, along its own screw, in place.

    ``e6`` is scaled by ``scale`` (the command's clamp, :func:`clamp_command`),
    and then ``dp`` becomes ``G(phi)^-1 dp``: the task point's displacement
    under the constant twist that turns the frame by ``phi`` and carries the
    task point by ``dp`` in unit time (the SE(3) logarithm taken at the task
    point: Lynch and Park, *Modern Robotics*, 2017, sec. 3.3.3.2),
    ``G^-1 = I - [phi]/2 + (1 - (t/2) cot(t/2)) / t^2 [phi]^2``, ``t = |phi|``.
    Only the rotation rows the task keeps count in ``phi``. Written in plain
    loops so that :mod:`lpik.fast` compiles this very function.

    Args:
        e6: ``[p_target - p; log(R_target R^T)]``, (6,), changed in place.
        rows: Index of each kept row in :data:`TASK_ROWS`, (m,).
        scale: The command's clamp factor.

    Returns:
        False, and ``e6`` unchanged, when the task keeps no position row or the
        kept rows do not turn the frame: then the step's screw is its chord.
    """
    wx, wy, wz, linear = 0.0, 0.0, 0.0, False
    for k in range(rows.shape[0]):
        row = int(rows[k])
        if row < 3:
            linear = True
        elif row == 3:
            wx = e6[3]
        elif row == 4:
            wy = e6[4]
        else:
            wz = e6[5]
    t2 = wx * wx + wy * wy + wz * wz
    if not linear or t2 == 0.0:
        return False
    for a in range(6):
        e6[a] *= scale
    wx, wy, wz, t2 = scale * wx, scale * wy, scale * wz, scale * scale * t2
    t = math.sqrt(t2)
    if t < 1e-3:
        c = 1.0 / 12.0 + t2 / 720.0
    else:
        half = 0.5 * t
        c = (1.0 - half * math.cos(half) / math.sin(half)) / t2
    dx, dy, dz = e6[0], e6[1], e6[2]
    ax, ay, az = wy * dz - wz * dy, wz * dx - wx * dz, wx * dy - wy * dx  # phi x dp
    bx, by, bz = wy * az - wz * ay, wz * ax - wx * az, wx * ay - wy * ax  # phi x (phi x dp)
    e6[0] = dx - 0.5 * ax + c * bx
    e6[1] = dy - 0.5 * ay + c * by
    e6[2] = dz - 0.5 * az + c * bz
    return True


def command_rows(
    e6: FloatArray,
    rows: FloatArray,
    dw: FloatArray,
    v_max: float,
    w_max: float,
    dt: float,
    brake: float,
) -> None:
    """``dw``: the kept rows of the pose difference ``e6``, clamped, along the step's own screw.

    The whole law on a pose difference, in plain loops: the fused step
    compiles this very function (with :func:`clamp_command` and
    :func:`along_screw` compiled), and :func:`commanded_displacement` runs it.

    Args:
        e6: ``[p_target - p; log(R_target R^T)]``, (6,); changed in place.
        rows: Index of each kept row in :data:`TASK_ROWS`, (m,).
        dw: Receives the commanded displacement, (m,).
        v_max: Largest linear speed [m/s].
        w_max: Largest angular speed [rad/s].
        dt: Control period [s].
        brake: Largest share of the difference the step may take (:func:`braking_scale`).
    """
    for k in range(rows.shape[0]):
        dw[k] = e6[int(rows[k])]
    if along_screw(e6, rows, clamp_command(dw, rows, v_max, w_max, dt, brake)):
        for k in range(rows.shape[0]):
            dw[k] = e6[int(rows[k])]
        # the screw may lengthen dp by O(t^2); the braking share is already in e6
        clamp_command(dw, rows, v_max, w_max, dt, math.inf)


def second_order_rows(e6: FloatArray, rows: FloatArray, jdq: FloatArray, rho: FloatArray) -> None:
    """``rho``: the part of the last step's task motion that its linear prediction missed.

    The last step moved the joints by ``dq = q0 - q_prev`` and the task frame
    by the pose difference ``e6``; the Jacobian predicted ``jdq = J(q_prev) dq``.
    Taken in the command's coordinates (the task's rows, along the motion's own
    screw, unclamped: :func:`command_rows`), the difference is the second-order
    term of the forward kinematics, ``rho = 1/2 dq^T (d^2 x / dq^2) dq + O(dq^3)``,
    that is ``1/2 Jdot qdot dt^2``, with ``Jdot qdot`` the drift term of the
    second-order differential kinematics ``xdd = J qdd + Jdot qdot`` (Siciliano
    et al., *Robotics: Modelling, Planning and Control*, 2009, ch. 3). It is even
    in ``dq`` and changes at the rate of the motion, so it predicts what the next
    step misses the same way.
    Written in plain loops so that :mod:`lpik.fast` compiles this very function.

    Args:
        e6: ``[p - p_prev; log(R R_prev^T)]``, (6,); changed in place.
        rows: Index of each kept row in :data:`TASK_ROWS`, (m,).
        jdq: ``J(q_prev) dq`` in the task's rows, (m,).
        rho: Receives the second-order term, (m,).
    """
    command_rows(e6, rows, rho, math.inf, math.inf, 1.0, math.inf)
    for k in range(rows.shape[0]):
        rho[k] -= jdq[k]


def made_by_drives(q0, q_prev, qd_min, qd_max, dt):  # type: ignore[no-untyped-def]
    """Whether the last step ``q0 - q_prev`` is one the drives could have made.

    Every joint's step within its velocity band ``[qd_min dt, qd_max dt]``, to the
    ratio test's tolerance (:func:`lpik.bands.plausible_step`; ``qd_min`` and
    ``qd_max`` per second, infinite where a joint has no velocity limit). A step
    beyond it is a fault of the state (a bad ``q_prev`` sample, a push from
    outside), not a motion whose second-order term (:func:`second_order_rows`)
    the next command can correct: that term then describes a motion the arm did
    not make, and taken off the command it would steer the tool off the
    commanded direction with the step's status ``optimal``. Measured on the
    Panda without acceleration limits, one ``q_prev`` 0.05 rad off (an implied
    50 rad/s) made a 0.5 mm step along x move the tool 1.1 mm along y and turn
    it by 3.0 mrad; so the command law takes the term off only after a step
    the drives could have made (under acceleration limits the controller has
    already taken such a ``q_prev`` at the step the drives could have made:
    :mod:`lpik.control.commanded`). A plain loop, compiled as it is by the fused step.
    """
    for i in range(q0.shape[0]):
        if plausible_step(q0[i] - q_prev[i], qd_min[i] * dt, qd_max[i] * dt)[1] != MET:
            return False
    return True


def target_fits(has_translation: bool, has_rotation: bool, rows: FloatArray) -> bool:
    """Whether a target with these parts commands every row of the task.

    A task row x, y or z needs the target's translation (an xyz or a pose), a
    row rx, ry or rz its rotation (a rotation or a pose): a target never leaves
    a part the task controls to be filled in. ``rows`` holds each task row's
    index in x, y, z, rx, ry, rz (:func:`task_rows`). A plain loop, compiled
    as it is by the fused step.
    """
    for k in range(rows.shape[0]):
        if rows[k] < 3 and not has_translation:
            return False
        if rows[k] >= 3 and not has_rotation:
            return False
    return True


def second_order_term(
    model: TaskModel, q_prev: Any, q0: Any, jdq: FloatArray | None = None
) -> FloatArray:
    """The second-order term of the task motion from ``q_prev`` to ``q0`` (see the function above).

    Zero for a robot at rest (``q_prev == q0``). On a task that is not a pose
    task, the motion is the task's own difference of the two task values.
    ``jdq``: ``J(q_prev) (q0 - q_prev)`` where the caller has it (None: computed).
    """
    q_prev, q0 = np.asarray(q_prev, dtype=np.float64), np.asarray(q0, dtype=np.float64)
    dq = q0 - q_prev
    rows = task_rows(model)
    if not dq.any():
        return np.zeros(rows.size)
    if jdq is None:
        jdq = model.jacobian(q_prev) @ dq
    if getattr(model, "KIND", None) != "pose":
        return np.asarray(model.difference(model.pose(q_prev), model.pose(q0)), float) - jdq
    rho = np.empty(rows.size)
    second_order_rows(pose_difference(model.pose(q_prev), model.pose(q0)), rows, jdq, rho)
    return rho


def commanded_displacement(
    model: TaskModel,
    pose: Any,
    target: Any,
    v_max: float,
    w_max: float,
    dt: float,
    stop: tuple[FloatArray, ...] | None = None,
    target_motion: FloatArray | None = None,
) -> FloatArray:
    """The step's ``dw`` from the task value ``pose`` at ``q`` towards ``target`` (the law above).

    Args:
        model: The task model.
        pose: ``model.pose(q)``.
        target: The commanded task value (what ``model.pose`` returns, of its shape).
        v_max: Largest linear speed [m/s].
        w_max: Largest angular speed [rad/s].
        dt: Control period [s].
        stop: ``(J, qdd_max, qd_max, turn)``, the Jacobian at ``q``, the joints'
            acceleration and velocity limits (the smaller side, inf: none) and the
            last motion's turn (:func:`braking_scale`; zeros at rest): the command
            then slows down in time to stop on the target (:func:`braking_scale`);
            None: it does not.
        target_motion: The target's motion over the last period (:class:`TargetMotion`),
            fed forward (:func:`add_target_motion`); None: none.
    """
    if np.shape(target) != np.shape(pose):
        raise ValueError(
            f"target: must be the task's value, shape {np.shape(pose)} (what model.pose "
            f"returns), got shape {np.shape(target)}"
        )
    rows = task_rows(model)
    if getattr(model, "KIND", None) != "pose":
        dw = np.array(model.difference(pose, target), dtype=np.float64)
        clamp_command(dw, rows, v_max, w_max, dt, _brake(stop, dw, dt))
    else:
        e6 = pose_difference(pose, target)
        dw = np.empty(rows.size)
        error = np.array([e6[int(row)] for row in rows])
        command_rows(e6, rows, dw, v_max, w_max, dt, _brake(stop, error, dt))
    if target_motion is not None:
        add_target_motion(dw, target_motion, rows, v_max, w_max, dt)
    return dw


def _brake(stop: tuple[FloatArray, ...] | None, error: FloatArray, dt: float) -> float:
    """:func:`braking_scale` of ``error`` under ``stop = (J, qdd_max, qd_max, turn)``; inf without.

    ``turn``: ``J(q_prev) last - J(q0) last`` (zeros at rest), whose least motion is the hold.
    """
    if stop is None:
        return math.inf
    J, qdd, qd, turn = stop
    m, n = J.shape
    motions = np.empty((2, n))  # along the error, and the hold
    least_motion(J, np.array([error, turn], dtype=np.float64), motions, np.empty((m, m + 2)))
    return braking_scale(motions[0], motions[1], qdd, qd, dt)


class CommandLaw(Protocol):
    """Turns the state of the robot into one step's commanded task displacement ``dw``."""

    def __call__(self, model: TaskModel, q: FloatArray, dt: float) -> FloatArray:
        """The displacement ``dw`` (shape (m,)) commanded for the step from ``q``."""
        ...


def _speed(name: str, value: float) -> float:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
    return float(value)


def checked_target(target: Any) -> FloatArray:
    """``target`` as the numbers of a command, or a ValueError naming ``target``.

    Real numbers (no booleans or complex numbers: :func:`lpik.types.numbers_of`),
    finite, none larger in size than :data:`~lpik.tolerances.MAX_MAGNITUDE` (a target
    1e200 m away overflowed the law's norm of the difference: the arm stood still and
    the step said ``p = 1``), and the rotation part of a rotation (3, 3) or a pose
    (4, 4) a rotation. The one check of a target's values on every path; the compiled
    step makes the same tests (:func:`lpik.fast.kinematics.target_pose`).
    """
    t = numbers_of("target", target)
    if not np.isfinite(t).all():
        raise ValueError("target: contains NaN or inf")
    check_magnitude("target", t)
    if t.shape in ((3, 3), (4, 4)):
        check_rotation("target", t)
    return t


@dataclass(frozen=True, eq=False)
class ClampedTarget:
    """Straight toward a target, at most ``v_max`` [m/s] and ``w_max`` [rad/s] fast.

    Args:
        target: Task-space value to move to (what ``model.pose`` returns): an
            xyz point [m], a rotation (3, 3) or a pose (4, 4).
        v_max: Largest commanded linear speed of the task point [m/s].
        w_max: Largest commanded angular speed of the task frame [rad/s].

    Raises:
        ValueError: Naming ``target`` when it is not finite numbers, or a
            rotation or pose whose rotation part is not a rotation (within
            :data:`lpik.tolerances.ROTATION_TOL`) or whose bottom row is not
            (0, 0, 0, 1); naming ``v_max`` or ``w_max`` when not > 0.
    """

    target: Any
    v_max: float = DEFAULT_V_MAX
    w_max: float = DEFAULT_W_MAX

    def __post_init__(self) -> None:
        checked_target(self.target)
        object.__setattr__(self, "v_max", _speed("v_max", self.v_max))
        object.__setattr__(self, "w_max", _speed("w_max", self.w_max))

    def __call__(self, model: TaskModel, q: FloatArray, dt: float) -> FloatArray:
        """The clamped displacement toward the target for one step of ``dt`` [s]."""
        return commanded_displacement(model, model.pose(q), self.target, self.v_max,
                                      self.w_max, dt)  # fmt: skip
