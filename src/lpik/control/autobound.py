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

from collections.abc import Callable

import numpy as np

from lpik.limits import AutomaticMultiplierBounds
from lpik.result import Result
from lpik.tolerances import FULL_P
from lpik.types import FloatArray

__all__ = ["bound_for_step", "bounds", "decide"]


def bounds(
    limit: AutomaticMultiplierBounds,
    J: FloatArray,
    rows: FloatArray,
    dt: float,
    s_max: float,
    s_min: float,
) -> FloatArray:
    """``B_k`` of step 3 (module docstring), shrunk towards the floor.

    Args:
        limit: The parameters (approach time, floor).
        J: The task Jacobian, (m, n).
        rows: Each task row's index in x, y, z, rx, ry, rz, (m,).
        dt: Control period [s].
        s_max: ``J``'s largest singular value.
        s_min: ``J``'s smallest singular value.

    Returns:
        The bound of each multiplier, (m,).
    """
    position = rows < 3
    lever = np.linalg.svd(J[position], compute_uv=False)[0] if position.any() else 1.0
    scale = np.where(position, max(float(lever), 1e-12), 1.0)
    shrink = max(0.0, 1.0 - (limit.floor * s_max / s_min) ** 2) if s_min > 0 else 0.0
    return dt / (limit.approach_time * scale) * shrink


def decide(
    limit: AutomaticMultiplierBounds,
    J: FloatArray,
    rows: FloatArray,
    dt: float,
    singular_values: tuple[float, float, float],
) -> FloatArray | None:
    """Steps 1-3 (module docstring) from ``(sigma_max, sigma_min, sigma_min at the probe)``.

    The probe's value is NaN where none was taken (``dq = 0``, or far from a
    singularity). Returns the bounds, or ``None`` to keep the unbounded step.
    The one rule of both paths: :func:`bound_for_step` (numpy) and
    :class:`~lpik.control.controller.Lp2Controller` (its compiled
    :func:`lpik.fast.singular_values.probe_singular_values`) feed it.
    """
    s_max, s_min, s_probe = singular_values
    if s_min > limit.activation * s_max or s_probe >= s_min:
        return None  # far from a singularity, or the step leaves it
    return bounds(limit, J, rows, dt, s_max, s_min)


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

    Args:
        limit: The automatic bound's parameters.
        jacobian: The task model's Jacobian at a configuration.
        q0: Joint coordinates now.
        J: ``jacobian(q0)``.
        rows: Each task row's index in x, y, z, rx, ry, rz.
        dt: Control period [s].
        unbounded: LP2's step with unbounded multipliers.
    """
    if not unbounded.moved or unbounded.p >= FULL_P or not J.size:
        return None
    s = np.linalg.svd(J, compute_uv=False)
    probe = np.nan
    size = float(np.linalg.norm(unbounded.dq))
    if s[-1] <= limit.activation * s[0] and size > 0.0:
        q = q0 + limit.probe * unbounded.dq / size
        probe = float(np.linalg.svd(jacobian(q), compute_uv=False)[-1])
    return decide(limit, J, rows, dt, (float(s[0]), float(s[-1]), probe))
