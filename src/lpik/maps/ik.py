"""Reachability: configurations within the end-stops that put the tool on a pose.

A bounded least-squares solve (Levenberg-Marquardt on the pose error, every
iterate clipped into the end-stops, joints held at a bound they are pushed
against), compiled, one target after the other, from several seeds per
target. It is lpik's own reading of reachability for a map: a pose is
*reached* when some seed ends within :data:`POSITION_TOL` and
:data:`ROTATION_TOL` of it on the task's rows with every joint within its
end-stops. Of the seeds that reach it, the configuration kept is the one
nearest the middle of its end-stops (the default ``q_ref`` of sec. 3.1:
away from the limits, where a step has the most room).

Each target is solved on its own from its own seeds, with no state shared
between targets, so a target's answer does not depend on which batch it is
solved in: the map is the same for any number of workers or blocks.

Why not lpik's LP step as the solver: iterating :func:`lpik.lp2_batch`
towards the pose is as sound (every iterate within the end-stops) but takes
the full, undamped Newton step, and is stopped by the first end-stop in the
way (``p < 1``) where a damped least-squares step slides along it; both
need the same kinematics per iteration. ``benchmarks/bench_maps.py`` times
this solve against scipy's bounded least squares on the same poses.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from lpik.fast.kinematics import POSE_ERROR_SCRATCH, chain_fk_jacobian, pose_error
from lpik.types import FloatArray

#: A pose counts as reached within this distance of the cell centre [m] ...
POSITION_TOL = 1e-6
#: ... and this angle of the orientation [rad], on the task's rows.
ROTATION_TOL = 1e-6
#: Levenberg-Marquardt iterations of one seed at most.
MAX_ITERATIONS = 60
#: Largest change of a joint in one iteration [rad or m] (a trust region).
MAX_JOINT_STEP = 0.5
#: A seed whose squared error has not fallen below this share of itself over
#: this many iterations is given up (a local minimum, or an end-stop in the way).
STALL_SHARE, STALL_ITERATIONS = 0.5, 8
#: The damping a seed starts with, and beyond which it is given up (stuck).
DAMPING_START, DAMPING_GIVE_UP = 1e-3, 1e3


@njit(cache=True)
def _evaluate(origins, axes, revolute, tip, rows, target, q, T, J6, joints, e6, scratch):
    """Pose and Jacobian at ``q``, the pose error into ``e6``; its sum of squares on ``rows``."""
    chain_fk_jacobian(origins, axes, revolute, tip, q, T, J6, joints)
    pose_error(T, target, e6, scratch)
    total = 0.0
    for r in rows:
        total += e6[r] * e6[r]
    return total


@njit(cache=True)
def _within(rows, e6, tol_position, tol_rotation):
    """Whether the error ``e6`` is within the tolerances on every row of the task."""
    for r in rows:
        if abs(e6[r]) > (tol_position if r < 3 else tol_rotation):
            return False
    return True


@njit(cache=True)
def _damped_step(rows, J6, e6, q, q_min, q_max, damping, A, y, dq):
    """``dq = J_f^T (J_f J_f^T + damping I)^-1 e`` over the joints not held at a bound.

    A joint on a bound that the gradient ``J^T e`` pushes further out is held
    (its column left out); the step is then scaled to :data:`MAX_JOINT_STEP`.
    """
    m, n = rows.size, q.size
    for i in range(n):
        g = 0.0
        for a in range(m):
            g += J6[rows[a], i] * e6[rows[a]]
        held = (q[i] <= q_min[i] and g < 0.0) or (q[i] >= q_max[i] and g > 0.0)
        dq[i] = 0.0 if held else 1.0  # a mask until the step is known
    for a in range(m):
        for b in range(m):
            s = damping if a == b else 0.0
            for i in range(n):
                s += J6[rows[a], i] * J6[rows[b], i] * dq[i]
            A[a, b] = s
        y[a] = e6[rows[a]]
    _cholesky_solve(A, y, m)
    largest = 0.0
    for i in range(n):
        s = 0.0
        for a in range(m):
            s += J6[rows[a], i] * y[a]
        dq[i] *= s
        largest = max(largest, abs(dq[i]))
    if largest > MAX_JOINT_STEP:
        for i in range(n):
            dq[i] *= MAX_JOINT_STEP / largest


@njit(cache=True)
def _cholesky_solve(A, y, m):
    """Solve ``A x = y`` for symmetric positive definite ``A`` (m, m) in place (``y`` <- x)."""
    for j in range(m):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        A[j, j] = math.sqrt(max(s, 1e-300))
        for i in range(j + 1, m):
            t = A[i, j]
            for k in range(j):
                t -= A[i, k] * A[j, k]
            A[i, j] = t / A[j, j]
    for i in range(m):
        for k in range(i):
            y[i] -= A[i, k] * y[k]
        y[i] /= A[i, i]
    for i in range(m - 1, -1, -1):
        for k in range(i + 1, m):
            y[i] -= A[k, i] * y[k]
        y[i] /= A[i, i]


@njit(cache=True)
def _descend(origins, axes, revolute, tip, rows, q_min, q_max, target, q, tolerances):
    """One seed's bounded Levenberg-Marquardt descent from ``q`` (in place).

    Each iteration evaluates one trial configuration (the first: the seed)
    and keeps it where it lowers the error; the kinematics are called from
    one place only, which keeps the compiled code small.

    Returns:
        ``(reached, iterations)``.
    """
    n, m = q.size, rows.size
    T, J6, J2, joints = np.empty((4, 4)), np.empty((6, n)), np.empty((6, n)), np.empty((2, n, 3))
    e6, e2, scratch = np.empty(6), np.empty(6), np.empty(POSE_ERROR_SCRATCH)
    A, y, dq, q_try = np.empty((m, m)), np.empty(m), np.empty(n), q.copy()
    err, checkpoint, damping = np.inf, np.inf, DAMPING_START
    for it in range(MAX_ITERATIONS + 1):
        trial = _evaluate(origins, axes, revolute, tip, rows, target, q_try, T, J2, joints, e2,
                          scratch)  # fmt: skip
        if trial < err:
            q[:] = q_try
            J6[:, :] = J2
            e6[:] = e2
            err = trial
            damping = max(damping / 3.0, 1e-12) if it > 0 else damping
        else:
            damping *= 4.0
            if damping > DAMPING_GIVE_UP:
                return False, it
        if _within(rows, e6, tolerances[0], tolerances[1]):
            return True, it
        if it % STALL_ITERATIONS == 0:
            if err > STALL_SHARE * checkpoint:
                return False, it  # stalled: a local minimum, or an end-stop in the way
            checkpoint = err
        _damped_step(rows, J6, e6, q, q_min, q_max, damping, A, y, dq)
        for i in range(n):
            q_try[i] = min(max(q[i] + dq[i], q_min[i]), q_max[i])
    return False, MAX_ITERATIONS


@njit(cache=True)
def solve_targets(origins, axes, revolute, tip, rows, q_min, q_max, targets, seeds, tolerances,
                  out):  # fmt: skip
    """The configuration kept for every target (see the module docstring), NaN where none.

    Args:
        origins: ``SerialChain.arrays()``' joint origins (n, 4, 4) ...
        axes: ... joint axes (n, 3) ...
        revolute: ... revolute flags (n,) ...
        tip: ... and tip (4, 4).
        rows: Indices of the task's rows among x, y, z, rx, ry, rz.
        q_min: Lower end-stops (n,) (-inf where none).
        q_max: Upper end-stops (n,) (+inf where none).
        targets: Poses (B, 4, 4) in the base frame.
        seeds: Start configurations (B, S, n), within the end-stops, tried in order.
        tolerances: ``(POSITION_TOL, ROTATION_TOL)``.
        out: (B, n), written: the first seed's configuration that reaches the target.

    Returns:
        The iterations of every seed, summed (the work done).
    """
    B, S, n = seeds.shape
    iterations = 0
    for b in range(B):
        out[b, :] = np.nan
        for s in range(S):
            q = seeds[b, s].copy()
            reached, count = _descend(origins, axes, revolute, tip, rows, q_min, q_max,
                                      targets[b], q, tolerances)  # fmt: skip
            iterations += count
            if reached:
                out[b, :] = q
                break
    return iterations


@njit(cache=True)
def jacobians(origins, axes, revolute, tip, q, out):
    """The world-aligned Jacobians (B, 6, n) at the configurations ``q`` (B, n)."""
    n = q.shape[1]
    T, joints = np.empty((4, 4)), np.empty((2, n, 3))
    for b in range(q.shape[0]):
        chain_fk_jacobian(origins, axes, revolute, tip, q[b], T, out[b], joints)


def reach_bound(
    chain_arrays: tuple[FloatArray, ...], q_min: FloatArray, q_max: FloatArray
) -> float:
    """An upper bound of the tool point's distance from the base origin [m].

    The lengths of every fixed offset along the chain, plus the travel of each
    prismatic joint: no configuration puts the tool point farther.
    """
    origins, _, revolute, tip = chain_arrays
    length = float(np.linalg.norm(origins[:, :3, 3], axis=1).sum() + np.linalg.norm(tip[:3, 3]))
    for i in np.flatnonzero(~np.asarray(revolute, dtype=bool)):
        length += max(abs(float(q_min[i])), abs(float(q_max[i])))
    return length
