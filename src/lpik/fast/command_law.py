"""The command law, compiled: the clamped step along its screw, and the second-order term.

:func:`command_rows` and :func:`second_order_rows` are the plain-loop
functions of :mod:`lpik.command`, compiled as they are. The
second-order term needs the task frame and Jacobian at ``q_prev``: the state
keeps those of the last step's ``q0`` (blocks ``prev_*`` of
:mod:`lpik.fast.layout`), which in a control loop is the next step's
``q_prev``, so that a loop computes the kinematics once per step;
:func:`previous_kinematics` computes them where the state does not hold them.
"""

from __future__ import annotations

import math

from numba import njit

from lpik import bands, command
from lpik.bands import braking_room
from lpik.fast import layout as L
from lpik.fast.kinematics import chain_fk_jacobian, pose_error
from lpik.fast.twins import compiled_twin

#: The one command law (:func:`lpik.command.command_rows`), compiled as it is.
command_rows = compiled_twin(
    command.command_rows,
    clamp_command=njit(cache=True)(command.clamp_command),
    along_screw=njit(cache=True)(command.along_screw),
)
#: The least joint motion along a task motion (:func:`lpik.command.least_motion`).
least_motion = njit(cache=True)(command.least_motion)
#: The braking share of the command (:func:`lpik.command.braking_scale`).
braking_scale = compiled_twin(command.braking_scale, braking_room=njit(cache=True)(braking_room))
#: The target's motion fed forward (:func:`lpik.command.add_target_motion`).
add_target_motion = compiled_twin(
    command.add_target_motion, clamp_command=njit(cache=True)(command.clamp_command)
)
#: Whether a target commands every row of the task (:func:`lpik.command.target_fits`).
target_fits = njit(cache=True)(command.target_fits)
#: Whether a joint moved by more than rounding (:func:`lpik.command.moved_beyond_rounding`).
moved_beyond_rounding = njit(cache=True)(command.moved_beyond_rounding)
#: Whether the drives could have made the last step (:func:`lpik.command.made_by_drives`).
made_by_drives = compiled_twin(command.made_by_drives,
                               plausible_step=njit(cache=True)(bands.plausible_step))  # fmt: skip
#: The last step's second-order term (:func:`lpik.command.second_order_rows`).
second_order_rows = compiled_twin(command.second_order_rows, command_rows=command_rows)


@njit(cache=True)
def needs_previous(state, q0, q_prev):
    """Whether the step needs the kinematics at ``q_prev`` and the state does not hold them.

    Only where the command takes off the second-order term or the step is solved
    around the motion (the fading motion's stop needs ``J(q_prev) last``), and
    the robot moved (``q_prev != q0``); the state holds the kinematics of the
    last step's ``q0`` (blocks ``prev_*``), which is the next step's ``q_prev``
    in a loop.
    """
    flags = L.vector(state, L.SECOND_ORDER)
    wanted = flags[0] != 0.0 or L.vector(state, L.CONTINUATION)[0] != 0.0
    if not wanted or not _moved(q0, q_prev):
        return False
    if flags[1] == 0.0:
        return True
    prev_q = L.vector(state, L.PREV_Q)
    for i in range(q_prev.shape[0]):
        if prev_q[i] != q_prev[i]:
            return True
    return False


@njit(cache=True)
def previous_kinematics(state, q0, q_prev):
    """The chain's frame and Jacobian at ``q_prev`` into the ``prev_*`` blocks, where needed."""
    if not needs_previous(state, q0, q_prev):
        return
    n = int(state[L.N])
    chain_fk_jacobian(
        L.tensor_at(state, L.ORIGINS, n, 4, 4), L.matrix_at(state, L.AXES, n, 3),
        L.vector(state, L.REVOLUTE), L.matrix_at(state, L.TIP, 4, 4), q_prev,
        L.matrix_at(state, L.PREV_FRAME, 4, 4), L.matrix_at(state, L.PREV_JACOBIAN6, 6, n),
        L.tensor_at(state, L.JOINTS, 2, n, 3),
    )  # fmt: skip
    held_at(state, q_prev)


@njit(cache=True)
def held_at(state, q):
    """Record that the ``prev_*`` blocks hold the kinematics at ``q`` (``sigma_min`` not known)."""
    prev_q = L.vector(state, L.PREV_Q)
    for i in range(q.shape[0]):
        prev_q[i] = q[i]
    L.vector(state, L.SECOND_ORDER)[1] = 1.0
    L.vector(state, L.SIGMA)[2] = math.nan


@njit(cache=True)
def _moved(q0, q_prev):
    for i in range(q0.shape[0]):
        if q0[i] != q_prev[i]:
            return True
    return False


@njit(cache=True)
def last_task_motion(state, q0, q_prev, rows):
    """``J(q_prev) (q0 - q_prev)`` in the task rows into the ``rho`` block's row 0 (0 at rest).

    From ``prev_jacobian6``, which holds the Jacobian at ``q_prev`` where the
    robot moved (:func:`needs_previous`). Returns that row.
    """
    n, m = q0.shape[0], rows.shape[0]
    before = L.matrix_at(state, L.RHO, 2, m)[0]
    moved = _moved(q0, q_prev)
    J6_prev = L.matrix_at(state, L.PREV_JACOBIAN6, 6, n)
    for k in range(m):
        row, s = int(rows[k]), 0.0
        if moved:
            for i in range(n):
                s += J6_prev[row, i] * (q0[i] - q_prev[i])
        before[k] = s
    return before


@njit(cache=True)
def take_off_second_order(state, q0, q_prev, rows, dw):
    """``dw -= rho``, the last step's second-order term (0 at rest).

    The term is :func:`lpik.command.second_order_rows` of the motion from the
    frame at ``q_prev`` (``prev_frame``) to the frame at ``q0``, with
    ``J(q_prev) (q0 - q_prev)`` from :func:`last_task_motion` (the ``rho``
    block's row 0); none after a step the drives could not have made
    (:func:`made_by_drives`, the velocity limits of the ``limits`` block).
    """
    m, n = dw.shape[0], q0.shape[0]
    if not _moved(q0, q_prev):
        return
    limits = L.matrix_at(state, L.LIMITS, 6, n)
    if not made_by_drives(q0, q_prev, limits[2], limits[3], state[L.DT]):
        return
    jdq_rho = L.matrix_at(state, L.RHO, 2, m)
    e6 = L.vector(state, L.ERROR6)
    T = L.matrix_at(state, L.FRAME, 4, 4)
    pose_error(L.matrix_at(state, L.PREV_FRAME, 4, 4), T, e6, L.vector(state, L.LOG_SCRATCH))
    second_order_rows(e6, rows, jdq_rho[0], jdq_rho[1])
    for k in range(m):
        dw[k] -= jdq_rho[1, k]


@njit(cache=True)
def hold_kinematics(state, q0, J6):
    """Keep ``q0``'s frame and Jacobian in the ``prev_*`` blocks: the next step's ``q_prev``'s.

    With them ``sigma_min`` of the task rows where the step decomposed them (the
    ``sigma`` block, :func:`lpik.methods.autobound.singular_memo`).
    """
    n = q0.shape[0]
    T = L.matrix_at(state, L.FRAME, 4, 4)
    frame, jac = L.matrix_at(state, L.PREV_FRAME, 4, 4), L.matrix_at(state, L.PREV_JACOBIAN6, 6, n)
    for a in range(4):
        for b in range(4):
            frame[a, b] = T[a, b]
    for a in range(6):
        for i in range(n):
            jac[a, i] = J6[a, i]
    held_at(state, q0)
    sigma = L.vector(state, L.SIGMA)
    if math.isfinite(sigma[0]):  # (inf: J was clearly regular, no decomposition)
        sigma[2] = sigma[0]


@njit(cache=True)
def braking_share(state, J, e6, rows, q0, q_prev):
    """:func:`lpik.command.braking_scale` of the pose error ``e6``'s task rows: the command's brake.

    The stop accelerations and speeds are each joint's smaller acceleration and
    velocity limit (the ``limits`` block). The least motions along the error and
    of the turn ``J(q_prev) last - J(q0) last`` (the hold; ``J(q_prev) last`` is the
    ``rho`` block's row 0, :func:`last_task_motion`, 0 at rest) go to the ``stop``
    block, from one factorisation: their task motions are the ``brake`` block, the
    ``stop_scratch`` block its work space.
    """
    n, m = J.shape[1], J.shape[0]
    stop, limits = L.matrix_at(state, L.STOP, 4, n), L.matrix_at(state, L.LIMITS, 6, n)
    motions = L.matrix_at(state, L.BRAKE, 2, m)  # the error, the turn
    before = L.matrix_at(state, L.RHO, 2, m)[0]
    for k in range(m):
        motions[0, k] = e6[int(rows[k])]
        s = 0.0
        for i in range(n):
            s += J[k, i] * (q0[i] - q_prev[i])
        motions[1, k] = before[k] - s
    for i in range(n):
        stop[2, i] = min(limits[5, i], -limits[4, i])
        stop[3, i] = min(limits[3, i], -limits[2, i])
    least_motion(J, motions, stop[:2], L.matrix_at(state, L.STOP_SCRATCH, m, m + 2))
    return braking_scale(stop[0], stop[1], stop[2], stop[3], state[L.DT])


@njit(cache=True)
def target_motion(state, q0, q_prev, goal):
    """The target's motion over the last period, where the step follows the last one.

    :class:`lpik.command.TargetMotion`'s rule on the state's ``memory*``
    blocks: a step of an arm that moved (beyond rounding) whose ``q_prev`` is the last
    step's ``q0`` gets the pose error from the last goal to ``goal``; the same step asked
    again (the same ``q0`` and goal) gets the same; any other step none. Returns the
    ``target_motion`` block (entry 0: 1 where the target moved, then
    ``[dp; log]`` and its task rows from entry 7); remembers this step.
    """
    n = q0.shape[0]
    memory, seen_q = L.vector(state, L.MEMORY), L.vector(state, L.MEMORY_Q)
    seen_goal, motion = L.matrix_at(state, L.MEMORY_GOAL, 4, 4), L.vector(state, L.TARGET_MOTION)
    if memory[0] != 0.0 and _equal(q0, seen_q, n) and _equal(goal.ravel(), seen_goal.ravel(), 16):
        return motion  # the same step again
    motion[0] = 0.0
    if memory[0] != 0.0 and moved_beyond_rounding(q0, q_prev) and _equal(q_prev, seen_q, n):
        pose_error(seen_goal, goal, motion[1:7], L.vector(state, L.LOG_SCRATCH))
        rows = L.vector(state, L.ROW_INDEX)
        for k in range(rows.shape[0]):
            motion[7 + k] = motion[1 + int(rows[k])]
        motion[0] = 1.0
    for i in range(n):
        seen_q[i] = q0[i]
    for a in range(4):
        for b in range(4):
            seen_goal[a, b] = goal[a, b]
    memory[0] = 1.0
    return motion


#: Whether the target's memory is keyed by a measured loop's q_prev
#: (:func:`lpik.command.continues_with`).
continues_with = compiled_twin(command.continues_with, moved_beyond_rounding=moved_beyond_rounding)


def follow(state, q0, q_prev, taken):  # type: ignore[no-untyped-def]
    """:meth:`lpik.command.TargetMotion.follow` on the state's ``memory*`` blocks.

    Compiled as :data:`follow_in_state` (the background compile's) and by
    :func:`lpik.fast.commanded.follow_kernel` (the controller's, typed).
    """
    seen = L.vector(state, L.MEMORY_Q)
    if L.vector(state, L.MEMORY)[0] != 0.0 and continues_with(seen, q0, q_prev, taken):
        for i in range(seen.shape[0]):
            seen[i] = taken[i]


follow_in_state = njit(cache=True)(follow)


@njit(cache=True)
def _equal(a, b, size):
    for i in range(size):
        if a[i] != b[i]:
            return False
    return True
