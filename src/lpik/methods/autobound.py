"""The automatic multiplier bound (sec. 3.2): bound the multipliers only where it helps.

Bounded multipliers (sec. 3.2) are the paper's remedy for the chatter of LP2
near a singularity, but a fixed bound is a trade-off no user can tune: small
enough to stop the chatter when the command points out of the workspace, it
also slows LP2 wherever the arm passes close to a singular configuration with
a command it can follow, and however small, a push held long enough drives the
arm ever closer to the singularity, from which it then takes as long to come
back. :class:`~lpik.limits.AutomaticMultiplierBounds` applies a bound per step,
only where the unbounded step would race towards a singularity:

1. LP2 with unbounded multipliers. If it follows the whole command (``p = 1``),
   or ``J`` is far from singular (``sigma_min > ACTIVATION sigma_max``), that is
   the step: exact tracking, also through a singular configuration.
2. If its step moves away from the singularity (``sigma_min`` grows along
   ``dq``: a finite-difference probe of ``PROBE`` rad), that is the step: it is
   how the arm leaves a singular configuration, e.g. when the target comes back
   into the workspace.
3. Otherwise every multiplier is bounded, ``|lam_k| <= B_k``, and LP2 is solved
   again. With ``|lam| <= B`` the singular direction's share of a step is at
   most ``sigma_min^2 B``, while the distance to the workspace's boundary near a
   stretched singularity is about ``sigma_min^2 / L`` (``L`` a lever arm, here
   the largest singular value of ``J``'s position rows): with
   ``B_k = dt / (APPROACH_TIME L_k)`` the arm closes that distance
   exponentially with the time constant ``APPROACH_TIME``, never in one racing
   step (``L_k = L`` on a position row, 1 rad on an orientation row). The bound
   shrinks to 0 as ``sigma_min`` falls to ``FLOOR sigma_max``, so the arm stops
   there, a step short of the singularity it could not leave again.

Measured on the Panda (benchmarks/quality.py, scenario 2 with the target held
out of reach for 0.3 s and for 3 s): it recovers in every direction with no
chatter, where unbounded LP2 chatters and stays trapped, and fixed bounds of
0.01..1 are trapped after the longer push; through a singular configuration
with a reachable target it is unbounded LP2 exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from lpik.limits import AutomaticMultiplierBounds
from lpik.result import Result
from lpik.tolerances import (
    FLOOR_CREEP_TIME,
    FULL_P,
    MACHINE_EPSILON,
    PROBE_GRAM_MAX_SHARE,
    PROBE_GRAM_SAFETY,
    SINGULAR_RTOL,
)
from lpik.types import FloatArray

__all__ = [
    "MEMO_SIZE",
    "PARAMETERS",
    "automatic_bound",
    "bound_for_step",
    "extreme_singular_values",
    "floor_row",
    "parameters",
    "singular_memo",
    "singular_steps",
    "smallest_singular_value_before",
]

#: The parameters of :class:`~lpik.limits.AutomaticMultiplierBounds` in the order
#: :func:`automatic_bound` reads them (and the fused step's state holds them).
PARAMETERS = ("approach_time", "activation", "floor", "probe")


def parameters(limit: AutomaticMultiplierBounds) -> FloatArray:
    """``limit``'s :data:`PARAMETERS` as the array :func:`automatic_bound` takes."""
    return np.array([getattr(limit, name) for name in PARAMETERS], dtype=np.float64)


def _singular_values(A):  # the compiled twin binds lpik.fast.jacobi's SVD instead
    return np.linalg.svd(A, compute_uv=False)


def _task_jacobian(jacobian, q):  # the compiled twin: the chain in the state buffer
    return np.asarray(jacobian(q), dtype=np.float64)


def _svd(A):  # the compiled twin binds lpik.fast.jacobi's (the same full U and Vt)
    return np.linalg.svd(A)


def clearly_regular(J, activation):  # type: ignore[no-untyped-def]
    """True when ``sigma_min > activation sigma_max`` follows without a singular value.

    ``sigma_max^2`` is at most ``t``, the smaller of ``trace(J J^T)`` and its
    largest Gershgorin row sum, so ``J J^T - activation^2 t I`` positive
    definite (its Cholesky factorisation goes through) implies
    ``sigma_min^2 > activation^2 sigma_max^2``: step 1's test, for a tenth of an
    SVD's cost. False says nothing; the SVD decides then. Plain loops.
    """
    G = _gram(J)
    m = G.shape[0]
    top = 0.0  # sigma_max^2 <= the largest Gershgorin row sum of J J^T (and <= its trace)
    trace = 0.0
    for a in range(m):
        row = 0.0
        for b in range(m):
            row += abs(G[a, b])
        top = max(top, row)
        trace += G[a, a]
    return _positive_definite(G, activation * activation * min(top, trace))


def _gram(J):  # type: ignore[no-untyped-def]
    """``J J^T`` (m, m), or ``J^T J`` where ``J`` has fewer columns than rows."""
    m, n = J.shape
    k, rows = (m, True) if m <= n else (n, False)
    G = np.empty((k, k))
    for a in range(k):
        for b in range(a + 1):
            s = 0.0
            if rows:
                for i in range(n):
                    s += J[a, i] * J[b, i]
            else:
                for i in range(m):
                    s += J[i, a] * J[i, b]
            G[a, b] = s
            G[b, a] = s
    return G


def _positive_definite(G, shift):  # type: ignore[no-untyped-def]
    """Whether ``G - shift I`` is positive definite: its Cholesky factorisation, in ``G``."""
    m = G.shape[0]
    for a in range(m):  # lower triangle, in place
        for b in range(a + 1):
            s = G[a, b] - (shift if a == b else 0.0)
            for k in range(b):
                s -= G[a, k] * G[b, k]
            if a == b:
                if s <= 0.0:
                    return False
                G[a, a] = math.sqrt(s)
            else:
                G[a, b] = s / G[b, b]
    return True


def smallest_singular_value_grows(J_probe, s_min, s_max):  # type: ignore[no-untyped-def]
    """Step 2's probe: whether ``sigma_min`` of ``J_probe`` is at least ``s_min`` (``J``'s).

    Decided by two Cholesky tests of ``J_probe``'s Gram matrix, shifted by
    ``(s_min (1 + share))^2`` (positive definite: it grows) and
    ``(s_min (1 - share))^2`` (not: it falls), where ``share``
    (:data:`~lpik.tolerances.PROBE_GRAM_SAFETY`) lies far beyond their rounding;
    a change within the share (near a singular configuration, or a tie) goes to
    the singular values themselves. Either way the answer the SVD gives, at a
    tenth of its cost. Plain loops.
    """
    if s_min > 0.0:
        share = PROBE_GRAM_SAFETY * MACHINE_EPSILON * (s_max / s_min) ** 2
        if share <= PROBE_GRAM_MAX_SHARE:
            G = _gram(J_probe)
            above = s_min * (1.0 + share)
            if _positive_definite(G.copy(), above * above):  # (it factorises in place)
                return True
            below = s_min * (1.0 - share)
            if not _positive_definite(G, below * below):
                return False
    s = _singular_values(J_probe)
    return s[s.size - 1] >= s_min


#: Entries of a memo of the singular values the rule reads (:func:`singular_memo`):
#: ``sigma_min`` and ``sigma_max`` of ``J`` (``inf`` and 0 where :func:`clearly_regular`
#: decides without them), then ``sigma_min`` of ``J_before``; NaN where not known yet.
MEMO_SIZE = 3


def singular_memo() -> FloatArray:
    """A memo that knows nothing yet, for one step's :func:`automatic_bound` and stop ahead.

    The fused step keeps its memo in its state (the ``sigma`` block of
    :mod:`lpik.fast.layout`): the rule and the stop ahead of one step share one
    decomposition of ``J``, and in a loop the next step reads ``J``'s
    ``sigma_min`` as that of ``J_before``, the same Jacobian.
    """
    return np.full(MEMO_SIZE, np.nan)


def extreme_singular_values(J, activation, memo):  # type: ignore[no-untyped-def]
    """``(sigma_min, sigma_max)`` of ``J``; ``(inf, 0)`` where :func:`clearly_regular` holds.

    Read from ``memo`` (:func:`singular_memo`) where it knows them, else
    computed and written there. Plain loops; compiled as it is.
    """
    if math.isnan(memo[0]):
        if clearly_regular(J, activation):
            memo[0], memo[1] = math.inf, 0.0
        else:
            s = _singular_values(J)
            memo[0], memo[1] = s[s.size - 1], s[0]
    return memo[0], memo[1]


def smallest_singular_value_before(J_before, memo):  # type: ignore[no-untyped-def]
    """``sigma_min`` of ``J_before``, from ``memo`` where it knows it (else written there)."""
    if math.isnan(memo[2]):
        s = _singular_values(J_before)
        memo[2] = s[s.size - 1]
    return memo[2]


def automatic_bound(
    settings: FloatArray, J: FloatArray, rows: FloatArray, dt: float, q0: FloatArray,
    dq: FloatArray, jacobian: Any, bound: FloatArray, memo: FloatArray,
) -> bool:  # fmt: skip
    """Steps 1-3 (module docstring) after an unbounded step that moved with ``p < 1``.

    The one rule of every path: :func:`bound_for_step` runs it as it is
    (numpy's SVD, the task model's Jacobian at the probe), and the fused step
    compiles this very function (:mod:`lpik.fast.autobound`: the Jacobi SVD, the
    chain's kinematics from the state buffer). Plain loops over small arrays.

    Args:
        settings: The :data:`PARAMETERS` (:func:`parameters`).
        J: The task Jacobian at ``q0``, (m, n).
        rows: Each task row's index in x, y, z, rx, ry, rz, (m,).
        dt: Control period [s].
        q0: Joint coordinates now, (n,).
        dq: The unbounded step (eq. 18 with ``|lam|`` free), (n,).
        jacobian: What gives the task Jacobian at the probe's configuration
            (the task model's ``jacobian``; compiled: the state buffer).
        bound: Receives ``B_k`` of step 3, (m,), when the step is to be bounded.
        memo: ``J``'s extreme singular values where known (:func:`singular_memo`).

    Returns:
        True when the multipliers are to be bounded by ``bound`` (sec. 3.2),
        False to keep the unbounded step.
    """
    approach_time, activation, floor, probe = settings[0], settings[1], settings[2], settings[3]
    m, n = J.shape
    if m == 0:
        return False
    s_min, s_max = extreme_singular_values(J, activation, memo)
    if s_min > activation * s_max:
        return False  # far from a singularity: exact tracking
    size = 0.0
    for i in range(n):
        size += dq[i] * dq[i]
    size = math.sqrt(size)
    if size > 0.0:  # sigma_min a probe along dq away: does the step leave the singularity?
        q = np.empty(n)
        for i in range(n):
            q[i] = q0[i] + probe * dq[i] / size
        if smallest_singular_value_grows(_task_jacobian(jacobian, q), s_min, s_max):
            return False
    shrink = max(0.0, 1.0 - (floor * s_max / s_min) ** 2) if s_min > 0.0 else 0.0
    count = 0  # the lever arm L: the largest singular value of J's position rows
    for k in range(m):
        count += rows[k] < 3
    lever = 1.0
    if count > 0 and shrink > 0.0:  # (at the floor every B_k is 0, whatever L)
        position = np.empty((count, n))
        j = 0
        for k in range(m):
            if rows[k] < 3:
                for i in range(n):
                    position[j, i] = J[k, i]
                j += 1
        lever = max(_singular_values(position)[0], 1e-12)
    for k in range(m):
        bound[k] = dt / (approach_time * (lever if rows[k] < 3 else 1.0)) * shrink
    return True


def singular_steps(
    J: FloatArray, J_before: FloatArray, activation: float, floor: float, memo: FloatArray
) -> float:
    """In how many steps the arm's motion reaches the bound's floor near a singularity.

    Under acceleration limits the step is solved around the arm's motion
    (:mod:`lpik.continuation`), and a joint on its acceleration band is held by
    the band, not by the multipliers: with a small command the multipliers stay
    under the bound of step 3 while the joints speed up towards a singular
    configuration at their acceleration limits, and the arm reaches the floor
    too fast to stop there (a stretched arm then folds past its pose of
    greatest reach into an end-stop, a pose from which no step that brings the
    tool nearer its target leads home). So the floor is a stop ahead, as for a
    motion that stops paying (:func:`lpik.continuation.fading_steps`):
    ``sigma_min`` of ``J`` at ``q_prev`` and at ``q0``, extrapolated linearly
    along the motion to ``floor sigma_max`` (near a singular configuration
    ``sigma_min`` changes about linearly with the joint motion), gives the steps
    left, and every moving joint keeps the room to stop there
    (:func:`lpik.bands.fading_band`). Plain loops; the fused step compiles this
    very function (:mod:`lpik.fast.autobound`).

    Args:
        J: The task Jacobian at ``q0``, (m, n).
        J_before: The task Jacobian at ``q_prev``, (m, n).
        activation: Below this ``sigma_min / sigma_max`` the rule acts (the bound's).
        floor: The stop is at ``sigma_min = floor sigma_max`` (the bound's).
        memo: The singular values of ``J`` and ``J_before`` where known
            (:func:`singular_memo`).

    Returns:
        The steps to the floor (0 at or past it); ``inf`` where ``J`` is far from
        singular or ``sigma_min`` does not fall by more than rounding
        (:data:`~lpik.tolerances.SINGULAR_RTOL` of ``sigma_max``: the engines' SVDs
        round differently, and a fall of 9e-16 made one engine stop ahead and not the
        other).
    """
    if J.shape[0] == 0 or not activation > 0.0:
        return math.inf
    s_min, s_max = extreme_singular_values(J, activation, memo)
    if s_min > activation * s_max:
        return math.inf
    before = smallest_singular_value_before(J_before, memo)
    if not before - s_min > SINGULAR_RTOL * s_max:
        return math.inf
    return max(s_min - floor * s_max, 0.0) / (before - s_min)


def floor_row(
    J: FloatArray, jacobian: Any, q0: FloatArray, activation: float, floor: float, probe: float,
    dt: float, row: FloatArray,
) -> float:  # fmt: skip
    """The bound's floor as one row on the progress step, where the arm's motion has reached it.

    Where :func:`singular_steps` finds the floor 0 steps ahead, its stop ahead
    holds every moving joint to full braking. For the exact step that is the
    controlled stop it must be; for the stall stage's progress step
    (:mod:`lpik.methods.progress`) it made a cycle of two steps: the braked
    motion no longer nears the floor, so the next progress step, free again,
    sped up towards the singular configuration, and the stop ahead braked it
    once more (the acceleration reversing on every step: 27,683 reversals over
    the UR5e's random goals of ``benchmarks/random_goals.py``). There the
    progress step takes this row instead of the band: the first-order change of
    ``sigma_min`` along the step, ``sigma_min + grad . dq``, stays at least
    ``min(sigma_min, floor sigma_max) - floor sigma_max dt / FLOOR_CREEP_TIME``, so the arm slides
    along the floor and deepens the singular configuration only slowly
    (:data:`~lpik.tolerances.FLOOR_CREEP_TIME`), which a path through it needs.
    ``grad_i = u^T (dJ/dq_i) v`` (``u``, ``v`` the singular vectors of
    ``sigma_min``), by a forward difference of ``probe`` rad. Plain loops; the
    fused step's stall stage compiles this very function (:mod:`lpik.fast.autobound`).

    Args:
        J: The task Jacobian at ``q0``, (m, n).
        jacobian: What gives the task Jacobian at a configuration (compiled: the state).
        q0: Joint coordinates now, (n,).
        activation: Below this ``sigma_min / sigma_max`` the bound acts (the bound's).
        floor: The bound's floor, a share of ``sigma_max``.
        probe: The forward difference's step [rad] (the bound's).
        dt: Control period [s].
        row: Receives the row ``row . dq <= rhs``, (n,).

    Returns:
        ``rhs``; ``inf`` (no row) where ``J`` is far from singular.
    """
    m, n = J.shape
    if m == 0 or not activation > 0.0 or clearly_regular(J, activation):
        return math.inf
    U, s, Vt = _svd(J)
    last = s.size - 1
    s_max, s_min = s[0], s[last]
    if s_min > activation * s_max:
        return math.inf
    q = np.empty(n)
    for i in range(n):
        q[i] = q0[i]
    for i in range(n):
        q[i] = q0[i] + probe
        moved = _task_jacobian(jacobian, q)
        q[i] = q0[i]
        change = 0.0
        for a in range(m):
            for j in range(n):
                change += U[a, last] * (moved[a, j] - J[a, j]) * Vt[last, j]
        row[i] = -change / probe
    return max(s_min - floor * s_max, 0.0) + dt / FLOOR_CREEP_TIME * floor * s_max


def bound_for_step(
    limit: AutomaticMultiplierBounds,
    jacobian: Callable[[FloatArray], FloatArray],
    q0: FloatArray,
    J: FloatArray,
    rows: FloatArray,
    dt: float,
    unbounded: Result,
) -> FloatArray | None:
    """The multiplier bounds of this step (step 3), or ``None`` to keep the unbounded step.

    :func:`automatic_bound` through the numpy layers (``simulate``, and
    :class:`~lpik.control.controller.Lp2Controller` over a backend's kinematics).

    Args:
        limit: The automatic bound's parameters.
        jacobian: The task model's Jacobian at a configuration.
        q0: Joint coordinates now.
        J: ``jacobian(q0)``.
        rows: Each task row's index in x, y, z, rx, ry, rz.
        dt: Control period [s].
        unbounded: LP2's step with unbounded multipliers.
    """
    if not unbounded.moved or unbounded.p >= FULL_P:
        return None
    bound = np.empty(J.shape[0])
    q, dq = np.asarray(q0, dtype=np.float64), np.asarray(unbounded.dq, dtype=np.float64)
    found = automatic_bound(parameters(limit), J, rows, float(dt), q, dq, jacobian, bound,
                            singular_memo())  # fmt: skip
    return bound if found else None
