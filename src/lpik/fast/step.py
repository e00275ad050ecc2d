"""One fused LP2 control step, compiled: kinematics, command, limits and LP2 in one call.

:func:`chain_step` does for a task over a
:class:`~lpik.robots.chain.SerialChain` what :func:`lpik.limits.build_problem`
and :func:`lpik.methods.lp2.lp2` do through the numpy layers: the pose and
Jacobian at ``q0``, the commanded displacement ``dw`` of eq. 2 (the law of
:mod:`lpik.command`: :func:`~lpik.command.command_rows`,
compiled in :mod:`lpik.fast.command_law`, less the last step's second-order
term where the controller asks for it), the bounds on ``dq`` from end-stops,
velocity and acceleration limits (eqs. 13-14), the criterion's ``c`` (eq. 3, sec. 3.1)
and LP2's ratio
test (eqs. 15-18), and under the automatic multiplier bound
(:mod:`lpik.methods.autobound`, sec. 3.2) what ``simulate`` does after an
unbounded step with ``p < 1``: the rule, and LP2 again under its bound
(:func:`tighten_bounds`, and the step once more). Everything it reads and writes lives in one state
buffer (:mod:`lpik.fast.layout`).

:func:`step_kernel` compiles the step on first use (or loads it from the disk
cache) for its explicit signatures only: a call with other types raises
``TypeError`` instead of compiling a new specialisation in the middle of a
control loop. :func:`chain_step_batch` runs it over a batch of independent
states, in parallel.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, prange, types

from lpik import bands
from lpik.collision import avoidance
from lpik.continuation import fading_steps as _fading_steps
from lpik.continuation import motion_decay as _motion_decay
from lpik.continuation import progress_scale
from lpik.fast import layout as L
from lpik.fast.autobound import bound_in_state, singular_steps
from lpik.fast.command_law import (
    add_target_motion,
    braking_share,
    command_rows,
    hold_kinematics,
    last_task_motion,
    previous_kinematics,
    take_off_second_order,
    target_fits,
    target_motion,
)
from lpik.fast.jacobi import jacobi_svd
from lpik.fast.kinematics import chain_fk_jacobian, pose_error, target_pose
from lpik.fast.lp2_kernel import (
    INFEASIBLE,
    OK,
    SINGULAR_PATH_ALWAYS,
    lp2_core,
    pull_scale_of,
    singular_helpers,
)
from lpik.fast.saturation import lp2s_core
from lpik.fast.signatures import cached_kernel, loaded_kernel, typed_kernel
from lpik.fast.twins import compiled_twin, inlined_twin, rebound
from lpik.tolerances import FULL_P, MAX_SCHUR_CONDITION, NO_CHANGE_P

#: A step's outcome when q0, q_prev or the target has the wrong size or is not finite.
BAD_INPUT = 4

_yield_to = njit(cache=True)(bands.yield_to)
rate_band = compiled_twin(
    bands.rate_band,
    plausible_step=njit(cache=True)(bands.plausible_step),
    stoppable_step=njit(cache=True)(bands.stoppable_step),
    yield_to=_yield_to,
    braking_room=njit(cache=True)(bands.braking_room),
)
row_deceleration = njit(cache=True)(bands.row_deceleration)
braked_room = compiled_twin(bands.braked_room, braking_room=njit(cache=True)(bands.braking_room))
motion_decay = njit(cache=True)(_motion_decay)
fading_steps = compiled_twin(_fading_steps, progress_scale=njit(cache=True)(progress_scale))
fading_band = compiled_twin(bands.fading_band, braking_room=njit(cache=True)(bands.braking_room))
_outside_tolerance = njit(cache=True)(bands.outside_tolerance)
_stop_side = compiled_twin(bands.stop_side, outside_tolerance=_outside_tolerance)
stop_band = compiled_twin(bands.stop_band, yield_to=_yield_to, stop_side=_stop_side)
beyond_stops = compiled_twin(bands.beyond_stops, stop_side=_stop_side)
#: The field's null-space motion and share of the step's room
#: (:mod:`lpik.collision.avoidance`), compiled as they are.
null_space_motion = compiled_twin(
    avoidance.null_space_motion, _svd=jacobi_svd,
    **{name: singular_helpers[name]
       for name in ("forward_substitution", "back_substitution", "regular_count")},
)  # fmt: skip
field_share = njit(cache=True)(avoidance.field_share)


@njit(cache=True)
def step_bounds(limits, dt, q0, q_prev, lower, upper, kinds, fading=math.inf, hold=math.inf):
    """Bounds on ``dq`` from end-stops, velocity and acceleration limits (eqs. 13-14).

    The rule of :mod:`lpik.bands`, as :func:`lpik.limits.build_problem` and
    :meth:`lpik.problem.Problem.step_bounds` apply it. ``limits`` is (6, n):
    q_min, q_max, qd_min, qd_max, qdd_min, qdd_max (inf when none); the last
    step is ``q0 - q_prev`` (``q_prev = q0``: at rest); ``fading``: in how many
    steps that motion stops paying (:func:`fading_in_state`; ``inf``: it does
    not), a stop ahead that the joints keep the room to brake for, and ``hold``
    the motion's own stop without the singular one, near which they do not speed
    up (:func:`lpik.bands.fading_band`). Writes ``lower`` and ``upper`` (n,) and, in
    ``kinds`` (2, n), which limit sets each bound (0 end-stop, 1 velocity, 2
    acceleration).

    Returns:
        The label index (:func:`lpik.labels.step_label_table`) of the first limit
        the state is outside of (an end-stop past ``q0``, then a rate limit the
        motion exceeds), or -1 when the state is within its limits.
    """
    n = q0.shape[0]
    stop_outside, rate_outside = -1, -1
    for i in range(n):
        q_min, q_max = limits[0, i], limits[1, i]
        lo, hi, k_lo, k_hi, verdict = rate_band(
            q0[i] - q_prev[i], q_min - q0[i], q_max - q0[i], limits[2, i] * dt,
            limits[3, i] * dt, limits[4, i], limits[5, i], dt,
        )  # fmt: skip
        if rate_outside < 0 and verdict != 0:
            side = 1 if verdict > 0 else 0
            rate_outside = 3 * (2 * i + side) + (k_hi if verdict > 0 else k_lo)
        if not beyond_stops(q0[i], q_min, q_max):  # an end-stop outranks a stop ahead
            lo, hi, lo_fades, hi_fades = fading_band(
                q0[i] - q_prev[i], fading, lo, hi, limits[4, i], limits[5, i], dt, hold
            )  # fmt: skip
            k_lo, k_hi = 2 if lo_fades else k_lo, 2 if hi_fades else k_hi
        lo, hi, lo_stop, hi_stop, out = stop_band(q0[i], q_min, q_max, lo, hi)
        lower[i], upper[i] = lo, hi
        kinds[0, i] = 0 if lo_stop else k_lo
        kinds[1, i] = 0 if hi_stop else k_hi
        if stop_outside < 0 and out != 0:
            stop_outside = 3 * (2 * i + (1 if out > 0 else 0))
    return stop_outside if stop_outside >= 0 else rate_outside


@njit(cache=True)
def criterion_and_rows(f_ref, Lam, G, h, q0, c, c_ref, g):
    """``c = f`` (eq. 3), ``c_ref = Lambda (q_ref - q0)`` (sec. 3.1) and the rows' ``g = h - G q0``.

    A NaN in ``q_ref`` (``f_ref[1]``) means ``q_ref = q0`` for that joint.
    """
    n, r = q0.shape[0], G.shape[0]
    for i in range(n):
        c[i] = f_ref[0, i]
        s = 0.0
        for k in range(n):
            ref = f_ref[1, k]
            if not math.isnan(ref):
                s += Lam[i, k] * (ref - q0[k])
        c_ref[i] = s
    for j in range(r):
        s = h[j]
        for i in range(n):
            s -= G[j, i] * q0[i]
        g[j] = s


@njit(cache=True)
def brake_rows(state, q0, g):
    """Each row's stop ahead where the rows are limits on ``q``: ``g`` less what cannot be braked.

    Under acceleration limits a row's room for the step, ``h - G q0``, is at most
    what the joints can still brake from (:func:`lpik.bands.braked_room`, as
    :func:`lpik.limits.build_problem` takes a user's rows); ``g`` (r,) is the rows'
    right-hand side about any origin. Nothing where the ``rows_braked`` block is 0
    (a scene's rows bound the step's approach themselves).
    """
    if L.vector(state, L.ROWS_BRAKED)[0] == 0.0:
        return
    n, r = q0.shape[0], int(state[L.R])
    G, h = L.matrix_at(state, L.ROWS_G, r, n), L.vector(state, L.ROWS_H)
    limits, dt = L.matrix_at(state, L.LIMITS, 6, n), state[L.DT]
    for j in range(r):
        room = h[j]
        for i in range(n):
            room -= G[j, i] * q0[i]
        g[j] += braked_room(room, row_deceleration(G[j], 1.0, limits[4], limits[5], dt)) - room


@njit(cache=True)
def continues(state, q0, q_prev):
    """Whether the step is solved around the current motion (:mod:`lpik.continuation`).

    Not where the ``continuation`` block is 0 (off) or -1 (the through-rest stage's
    step: :func:`lpik.continuation.through_rest`).
    """
    return L.vector(state, L.CONTINUATION)[0] > 0.0 and stops_ahead(state, q0, q_prev)


@njit(cache=True)
def stops_ahead(state, q0, q_prev):
    """Whether the step keeps the moving arm's stops ahead (:func:`fading_in_state`).

    Around the motion and through rest alike (the ``continuation`` block 1 or -1).
    """
    if L.vector(state, L.CONTINUATION)[0] == 0.0:
        return False
    for i in range(q0.shape[0]):
        if q0[i] != q_prev[i]:
            return True
    return False


@njit(cache=True)
def fading_in_state(state, q0, q_prev, J, dw, singular_stop):
    """In how many steps the motion ``q0 - q_prev`` is to stop: the stops ahead of the step.

    ``(stop, own)``: ``own`` is :func:`lpik.continuation.fading_steps` (``J(q_prev)
    last`` is the ``rho`` block's row 0, :func:`last_task_motion`), where the
    motion stops paying; ``stop`` the nearer of it and, with ``singular_stop``,
    the stop before a singular configuration (the ``singular`` block:
    :func:`singular_ahead`, finite only in a step solved under the automatic
    multiplier bound). :func:`step_bounds` takes them as ``fading`` and ``hold``.
    """
    n, m = q0.shape[0], J.shape[0]
    last = L.vector(state, L.LAST)  # scratch here: continue_motion fills it afterwards
    for i in range(n):
        last[i] = q0[i] - q_prev[i]
    own = fading_steps(J, dw, last, L.matrix_at(state, L.RHO, 2, m)[0])
    return (min(own, L.vector(state, L.SINGULAR)[0]) if singular_stop else own), own


@njit(cache=True)
def singular_ahead(state, q0, q_prev, J, rows):
    """:func:`lpik.methods.autobound.singular_steps` into the ``singular`` block (inf: none).

    For the step solved again under the automatic multiplier bound (after
    :func:`tighten_bounds`, or where the caller applied it: the ``auto_bound``
    block's first entry -1), with the arm moving; its activation and floor are
    the ``auto_bound`` block's. ``J(q_prev)`` is the task rows of
    ``prev_jacobian6``, which :func:`task_step` moves ``q0``'s into only after the solve.
    """
    ahead = L.vector(state, L.SINGULAR)
    ahead[0] = math.inf
    settings = L.vector(state, L.AUTO_BOUND)  # (on, approach time, activation, floor, probe)
    if not (settings[2] > 0.0 and stops_ahead(state, q0, q_prev)):
        return
    n, m = q0.shape[0], J.shape[0]
    J6 = L.matrix_at(state, L.PREV_JACOBIAN6, 6, n)
    before = np.empty((m, n))
    for k in range(m):
        for i in range(n):
            before[k, i] = J6[int(rows[k]), i]
    ahead[0] = singular_steps(J, before, settings[2], settings[3], L.vector(state, L.SIGMA))


@njit(cache=True)
def continue_motion(state, q0, q_prev, J, dw, lower, upper):
    """The step in ``u = dq - last``: :func:`lpik.continuation.continued`, in place.

    ``last = q0 - q_prev`` clipped to the step's bounds goes to the ``last``
    block; the bounds become bounds on ``u`` and ``dw`` becomes ``dw - J last``.

    Returns:
        The continued step's origin ``q0 + last`` (the ``origin`` block).
    """
    n, m = q0.shape[0], J.shape[0]
    last, origin = L.vector(state, L.LAST), L.vector(state, L.ORIGIN)
    safe = L.vector(state, L.SAFE)
    for i in range(n):
        last[i] = min(max(q0[i] - q_prev[i], lower[i]), upper[i])
        origin[i] = q0[i] + last[i]
        safe[i] = min(max(0.0, lower[i]), upper[i])  # the safe step: a controlled stop
        lower[i] -= last[i]
        upper[i] -= last[i]
    for k in range(m):
        s = 0.0
        for i in range(n):
            s += J[k, i] * last[i]
        dw[k] -= s
    return origin


@njit(cache=True)
def pull_back(state, c, lower, upper):
    """``c -= decay M last``: the criterion of eq. 3 in ``u`` (:func:`motion_decay`'s share)."""
    n = c.shape[0]
    last = L.vector(state, L.LAST)
    H, Lam = L.matrix_at(state, L.CRITERION, n, n), L.matrix_at(state, L.LAMBDA, n, n)
    decay = motion_decay(lower, upper, last)
    for i in range(n):
        s = 0.0
        for k in range(n):
            s += (H[i, k] - Lam[i, k]) * last[k]
        c[i] -= decay * s


@njit(cache=True)
def field_in_state(state, J, c, lower, upper, G, g):
    """``c += s force``: the potential field's force (the ``field`` block) at its share ``s``.

    :func:`lpik.collision.avoidance.field_scale_for` on the step as the state holds
    it: ``c`` the criterion's ``f`` (eq. 3; around the motion, less its pull back),
    ``lower`` and ``upper`` the bounds and ``G dq <= g`` the rows of that step, and
    ``M = H - Lambda``. Nothing where the force is 0 (no scene, no pair within
    ``d_i``, or the damper's rows alone).
    """
    n = c.shape[0]
    force = L.vector(state, L.FIELD)
    acting = False
    for i in range(n):
        acting = acting or force[i] != 0.0
    if not acting:
        return
    H, Lam = L.matrix_at(state, L.CRITERION, n, n), L.matrix_at(state, L.LAMBDA, n, n)
    M = np.empty((n, n))
    for i in range(n):
        for k in range(n):
            M[i, k] = H[i, k] - Lam[i, k]
    share = field_share(null_space_motion(J, M, force), null_space_motion(J, M, c), lower, upper,
                        G, g)  # fmt: skip
    for i in range(n):
        c[i] += share * force[i]


@njit(cache=True)
def resume_motion(state, code, J, dw, dq):
    """Back to a step from ``q0`` (:func:`lpik.continuation.resumed`): ``dw`` and ``dq``.

    An infeasible step becomes the original step's safe step (the ``safe``
    block), 0 clipped to its bounds. The bounds stay those of ``u`` (scratch:
    LP2 with saturation changes them).
    """
    n, m = dq.shape[0], J.shape[0]
    last, safe = L.vector(state, L.LAST), L.vector(state, L.SAFE)
    for i in range(n):
        dq[i] = safe[i] if code == INFEASIBLE else dq[i] + last[i]
    for k in range(m):
        s = 0.0
        for i in range(n):
            s += J[k, i] * last[i]
        dw[k] += s


@njit(cache=True)
def binding_label_index(code, kinds, constraints):
    """Where the LP2 kernel's binding limit ``code`` (``2 k + side``) sits in the label table.

    The table is :func:`lpik.labels.step_label_table`; ``kinds`` (2, n) says
    which limit sets each joint's bounds (:func:`step_bounds`), and
    ``constraints`` is the number of multipliers and rows.
    """
    n = kinds.shape[1]
    if code >= 2 * n:
        return 4 * n + code
    return 3 * code + int(kinds[code % 2, code // 2])


@njit(cache=True)
def limit_and_solve(state, q0, q_prev, J, dw):
    """Bounds, criterion and rows, then LP2 (with saturation when the header says so).

    Returns the LP2 kernel's outcome.

    Fills the out blocks ``q``, ``dq``, ``lam``, ``p``, ``label``, ``residual``
    and ``outside`` of ``state``; ``J`` and ``dw`` are the step's task rows.
    On an infeasible step ``dq`` is the safe step (:func:`lpik.result.safe_step`).
    """
    n, m, r = q0.shape[0], J.shape[0], int(state[L.R])
    dt = state[L.DT]
    limits = L.matrix_at(state, L.LIMITS, 6, n)
    lower, upper = L.vector(state, L.LOWER), L.vector(state, L.UPPER)
    kinds = L.matrix_at(state, L.KINDS, 2, n)
    dq, lam = L.vector(state, L.DQ), L.vector(state, L.LAM)
    moving = continues(state, q0, q_prev)
    fading, own = math.inf, math.inf
    if stops_ahead(state, q0, q_prev):
        fading, own = fading_in_state(state, q0, q_prev, J, dw, True)
    outside = step_bounds(limits, dt, q0, q_prev, lower, upper, kinds, fading, own)
    origin = continue_motion(state, q0, q_prev, J, dw, lower, upper) if moving else q0
    G = L.matrix_at(state, L.ROWS_G, r, n)
    c, c_ref, g = L.vector(state, L.C), L.vector(state, L.C_REF), L.vector(state, L.G_RHS)
    criterion_and_rows(L.matrix_at(state, L.F_REF, 2, n), L.matrix_at(state, L.LAMBDA, n, n),
                       G, L.vector(state, L.ROWS_H), origin, c, c_ref, g)  # fmt: skip
    brake_rows(state, q0, g)
    if moving:
        pull_back(state, c, lower, upper)
    field_in_state(state, J, c, lower, upper, G, g)
    lam_bounds = L.matrix_at(state, L.LAM_BOUNDS, 2, m)
    H, h_diag, ws = (
        L.matrix_at(state, L.CRITERION, n, n),
        state[L.H_DIAG] != 0.0,
        L.vector(state, L.LP2_WS),
    )
    if state[L.SATURATE] != 0.0:
        code, p, binding, residual = lp2s_core(
            J, dw, H, h_diag, c, c_ref, lower, upper, lam_bounds[0], lam_bounds[1], G, g, dq,
            lam, ws, L.vector(state, L.SATURATION),
        )  # fmt: skip
    else:
        code, p, binding, residual = lp2_core(
            J, dw, H, h_diag, c, c_ref, lower, upper, lam_bounds[0], lam_bounds[1], G, g, dq,
            lam, ws, SINGULAR_PATH_ALWAYS, MAX_SCHUR_CONDITION,
        )  # fmt: skip
    if moving:
        if code == OK and p <= NO_CHANGE_P:  # no change toward the command (continuation.resumed)
            code = INFEASIBLE
        resume_motion(state, code, J, dw, dq)
    q = L.vector(state, L.Q)
    for i in range(n):
        q[i] = q0[i] + dq[i]
    if code == INFEASIBLE:  # the safe step: how far it moves the task, max |J dq|
        for a in range(m):
            s = 0.0
            for i in range(n):
                s += J[a, i] * dq[i]
            residual = max(residual, abs(s))
    state[int(state[L.P])] = p
    label = -1 if binding == -1 else binding_label_index(binding, kinds, m + r)
    state[int(state[L.LABEL])] = label
    state[int(state[L.RESIDUAL])] = residual
    state[int(state[L.OUTSIDE])] = outside
    state[int(state[L.PULL_SCALE])] = pull_scale_of(ws, n, m, r) if code == OK else 1.0
    return code


@njit(cache=True)
def tighten_bounds(state, q0, m, saved):
    """After an unbounded step with ``p < 1``: the automatic multiplier bound (sec. 3.2).

    The rule (:func:`lpik.fast.autobound.bound_in_state`, that of
    :mod:`lpik.methods.autobound`) on the step :func:`limit_and_solve` left in
    ``state``. Where it bounds the multipliers, the state's multiplier bounds
    (copied into ``saved``, (2, m)) get ``|lam_k| <= B_k`` added and the
    ``bounded`` block says so; returns whether the step is to be solved again.
    """
    bounded = int(state[L.BOUNDED])
    state[bounded] = 0.0
    if state[int(state[L.P])] >= FULL_P or not bound_in_state(state, q0, L.vector(state, L.DQ)):
        return False
    lam_bounds, bound = L.matrix_at(state, L.LAM_BOUNDS, 2, m), L.vector(state, L.BOUND)
    for k in range(m):  # loops: an array assignment compiles its error message, seconds
        saved[0, k], saved[1, k] = lam_bounds[0, k], lam_bounds[1, k]
        lam_bounds[0, k] = max(saved[0, k], -bound[k])
        lam_bounds[1, k] = min(saved[1, k], bound[k])
    state[bounded] = 1.0
    return True


@njit(cache=True)
def restore_bounds(state, m, saved):
    """The state's multiplier bounds back as :func:`tighten_bounds` found them."""
    lam_bounds = L.matrix_at(state, L.LAM_BOUNDS, 2, m)
    for k in range(m):
        lam_bounds[0, k], lam_bounds[1, k] = saved[0, k], saved[1, k]


@njit(cache=True)
def _finite_joints(q0, q_prev, n):
    """True when ``q0`` and ``q_prev`` both have ``n`` finite entries."""
    if q0.shape[0] != n or q_prev.shape[0] != n:
        return False
    for i in range(n):
        if not (math.isfinite(q0[i]) and math.isfinite(q_prev[i])):
            return False
    return True


def chain_step(state, q0, q_prev, target):
    """One fused LP2 control step of a serial chain: FK, Jacobian, command, limits, LP2.

    Where the state's ``chain`` block is 0, a kinematics backend (Pinocchio,
    MuJoCo: :mod:`lpik.control.backend_step`) has written the pose and Jacobian
    at ``q0`` (and at ``q_prev``) into the state, and the step starts from them:
    one compiled kernel for both.

    Call it compiled, through :func:`step_kernel`: for C-contiguous float64 arrays
    only; other arguments raise a ``TypeError`` (the caller converts them), so a
    step never compiles anew.

    Args:
        state: The controller's buffer (:func:`lpik.fast.layout.pack`); the step
            writes its out and scratch blocks.
        q0: Joint coordinates now, (n,).
        q_prev: Joint coordinates one period ago, (n,); ``q0`` for a robot at rest.
        target: Commanded xyz (3,), rotation (3, 3) or pose (4, 4).

    Returns:
        The LP2 kernel's outcome code (:mod:`lpik.fast.lp2_kernel`), or :data:`BAD_INPUT`.
    """
    n = int(state[L.N])
    if not _finite_joints(q0, q_prev, n):
        return BAD_INPUT
    if L.vector(state, L.CHAIN)[0] != 0.0:  # else a backend wrote them (control.backend_step)
        chain_fk_jacobian(
            L.tensor_at(state, L.ORIGINS, n, 4, 4), L.matrix_at(state, L.AXES, n, 3),
            L.vector(state, L.REVOLUTE), L.matrix_at(state, L.TIP, 4, 4), q0,
            L.matrix_at(state, L.FRAME, 4, 4), L.matrix_at(state, L.JACOBIAN6, 6, n),
            L.tensor_at(state, L.JOINTS, 2, n, 3),
        )  # fmt: skip
        previous_kinematics(state, q0, q_prev)
    return task_step(state, q0, q_prev, target)


@njit(cache=True)
def task_step(state, q0, q_prev, target):
    """The fused step once the kinematics are known: command (eq. 2), limits and LP2.

    Reads the task frame at ``q0`` from the ``frame`` block (4, 4) and the
    world-aligned Jacobian from ``jacobian6`` (6, n), as :func:`chain_step`
    leaves them, or as a kinematics backend (Pinocchio, MuJoCo) writes them
    (:mod:`lpik.control.backend_step`); then the pose error to the target,
    the task rows, the clamped command (less the last step's second-order
    term where the ``second_order`` block says so: the ``prev_*`` blocks then
    hold the kinematics at ``q_prev``, as :func:`previous_kinematics` and the
    backend step leave them), the bounds and LP2, and, where the
    state's ``auto_bound`` block says so, the step again under the
    automatic bound (:func:`tighten_bounds`).

    Returns:
        The LP2 kernel's outcome code, or :data:`BAD_INPUT`.
    """
    n, m = int(state[L.N]), int(state[L.M])
    state[int(state[L.BOUNDED])] = -1.0
    sigma = L.vector(state, L.SIGMA)  # nothing known of J at this q0 yet
    sigma[0], sigma[1] = math.nan, math.nan
    goal = L.matrix_at(state, L.GOAL, 4, 4)
    if not (_finite_joints(q0, q_prev, n) and target_pose(target, goal)):
        return BAD_INPUT
    rows = L.vector(state, L.ROW_INDEX)
    if not target_fits(target.ndim == 1 or target.shape[0] == 4, target.ndim == 2, rows):
        return BAD_INPUT  # a target that leaves a part the task controls
    T = L.matrix_at(state, L.FRAME, 4, 4)
    J6 = L.matrix_at(state, L.JACOBIAN6, 6, n)
    e6 = L.vector(state, L.ERROR6)
    pose_error(T, goal, e6, L.vector(state, L.LOG_SCRATCH))
    J = L.matrix_at(state, L.JACOBIAN, m, n)
    dw = L.vector(state, L.DW)
    for k in range(m):
        row = int(rows[k])
        for i in range(n):
            J[k, i] = J6[row, i]
    second_order = L.vector(state, L.SECOND_ORDER)[0] != 0.0
    previous = second_order or L.vector(state, L.CONTINUATION)[0] != 0.0
    if previous:
        last_task_motion(state, q0, q_prev, rows)
    brake, moved = math.inf, False
    if L.vector(state, L.CONTINUATION)[0] != 0.0:
        brake = braking_share(state, J, e6, rows, q0, q_prev)
        moved = target_motion(state, q0, q_prev, goal)[0] != 0.0
    command_rows(e6, rows, dw, state[L.V_MAX], state[L.W_MAX], state[L.DT], brake)
    if moved:
        motion = L.vector(state, L.TARGET_MOTION)
        add_target_motion(dw, motion[7 : 7 + m], rows, state[L.V_MAX], state[L.W_MAX], state[L.DT])
    if second_order:
        take_off_second_order(state, q0, q_prev, rows, dw)
    position = L.vector(state, L.POSITION)
    for a in range(3):
        position[a] = T[a, 3]
    L.vector(state, L.SINGULAR)[0] = math.inf  # the stop ahead: only under the bound
    if state[int(state[L.AUTO_BOUND])] < 0.0:  # solved under the bound its caller applied
        singular_ahead(state, q0, q_prev, J, rows)
    # The step, then (sec. 3.2) where the automatic bound applies the step once more under
    # it: one call site, so that the solve is compiled (inlined) once.
    saved = np.empty((2, m))
    code = OK
    for again in range(2):
        code = limit_and_solve(state, q0, q_prev, J, dw)
        if again:
            restore_bounds(state, m, saved)
            break
        if code != OK or state[int(state[L.AUTO_BOUND])] <= 0.0:
            break
        if not tighten_bounds(state, q0, m, saved):
            break
        singular_ahead(state, q0, q_prev, J, rows)
    if previous:  # q0's kinematics kept for the next step, after the stop ahead read q_prev's
        hold_kinematics(state, q0, J6)
    return code


# The compiled steps inline their parts at numba's IR level (lpik.fast.twins.inlined_twin):
# compiled one by one, each part would be optimised again inside each part above it.
#: :func:`task_step` with :func:`limit_and_solve` and
#: :func:`lpik.fast.saturation.lp2s_core` inlined, to be inlined into a compiled step.
_parts = {"limit_and_solve": inlined_twin(limit_and_solve, lp2s_core=inlined_twin(lp2s_core))}
fused_task_step = inlined_twin(task_step, **_parts)
_chain_step = rebound(chain_step, task_step=fused_task_step)

_VECTOR = types.float64[::1]
#: The argument types of the compiled steps, by the number of axes of the target:
#: 1 for an xyz (3,), 2 for a rotation (3, 3) or a pose (4, 4). Argument types
#: alone, as numba keys its disk cache when the batch kernel compiles the step.
STEP_SIGNATURES = {
    1: (_VECTOR, _VECTOR, _VECTOR, _VECTOR),
    2: (_VECTOR, _VECTOR, _VECTOR, types.float64[:, ::1]),
}
#: Both kinds of target.
TARGET_AXES = (1, 2)


def step_kernel(target_axes: tuple[int, ...] = TARGET_AXES) -> Any:
    """The compiled :func:`chain_step` (a numba dispatcher), for targets of ``target_axes`` axes.

    Each of their :data:`STEP_SIGNATURES` is compiled (or loaded from numba's
    disk cache) the first time it is asked for; a call with other types raises
    ``TypeError`` instead of compiling in the middle of a loop.
    """
    return typed_kernel("chain_step", _chain_step, (STEP_SIGNATURES[a] for a in target_axes))


def cached_step_kernel(target_axes: tuple[int, ...] = TARGET_AXES) -> Any:
    """:func:`step_kernel` if numba's disk cache has each signature it needs, else None.

    Compiles nothing (:func:`lpik.fast.signatures.load_cached`).
    """
    return cached_kernel("chain_step", _chain_step, (STEP_SIGNATURES[a] for a in target_axes))


def loaded_step_kernel() -> Any:
    """The compiled step if :func:`step_kernel` has readied it in this process, else None."""
    return loaded_kernel("chain_step")


# The same step without explicit signatures, for the batch loop below. It compiles
# for the batch's argument types, which are those of STEP_SIGNATURES, so it shares
# their disk-cache entries with step_kernel's dispatcher.
_chain_step_any = njit(cache=True)(_chain_step)


@njit(cache=True, parallel=True)
def chain_step_batch(state, q0, q_prev, targets, outs, codes, chunks):
    """:func:`chain_step` for every row of the batch, in parallel.

    ``q0`` and ``q_prev`` are (B, n), ``targets`` (B, 3), (B, 3, 3) or (B, 4, 4).
    The batch is cut into ``chunks`` parts; each works on its own copy of
    ``state``. Row ``b`` of ``outs`` (B, size of the out blocks) receives the
    step's out blocks and ``codes[b]`` its outcome.
    """
    B = q0.shape[0]
    chunks = max(1, min(B, chunks))
    for chunk in prange(chunks):
        local = state.copy()
        for b in range(chunk * B // chunks, (chunk + 1) * B // chunks):
            local[int(local[L.MEMORY])] = 0.0  # rows are independent: no target motion
            codes[b] = _chain_step_any(local, q0[b], q_prev[b], targets[b])
            L.copy_out(local, outs, b)
