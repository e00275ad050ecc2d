"""Geometry for the motion-quality scenarios: target paths, reachability, unlimited paths.

- :func:`solve_within_limits`: bounded least squares on the pose error, the
  check that a target pose is reachable with every joint within its end-stops;
- :func:`reachable_mask`: that check along a target trajectory, sampled, each
  sample seeded from the one before (continuation from the leg's start): the
  branch of the inverse kinematics it follows is the solver's, which need not
  be the one a library's arm is on (scenario 2's leg -x: a target reachable on
  the solver's branch is 93 mm beyond a bounded solve started from lpik's arm);
- :func:`reach_along`: how far a pose can move along a direction (orientation
  held) and stay reachable, by bisection;
- :func:`unlimited_path`: the least-norm (pseudo-inverse) tracking of a target
  trajectory with no limits at all, to find where a straight-line path would
  carry a joint past its end-stop.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from lpik.robots.rotations import exp_so3, log_so3
from lpik.robots.tasks import PoseTask
from lpik.types import FloatArray

#: A target counts as reachable when the bounded solve ends this close [m, rad].
REACH_TOL = (1e-5, 1e-4)
#: Steps between two reachability samples along a trajectory.
SAMPLE_EVERY = 25


def moved(pose: FloatArray, offset: FloatArray) -> FloatArray:
    """``pose`` translated by ``offset`` [m] (orientation kept)."""
    out = np.array(pose, dtype=float)
    out[:3, 3] += offset
    return out


def blend(a: FloatArray, b: FloatArray, s: float) -> FloatArray:
    """The pose a fraction ``s`` of the way from ``a`` to ``b``: straight line, geodesic turn."""
    out = np.eye(4)
    out[:3, 3] = (1.0 - s) * a[:3, 3] + s * b[:3, 3]
    out[:3, :3] = exp_so3(s * log_so3(b[:3, :3] @ a[:3, :3].T)) @ a[:3, :3]
    return out


def smoothstep(s: FloatArray | float) -> FloatArray:
    """``3 s^2 - 2 s^3`` on [0, 1] (zero slope at both ends), clipped outside."""
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def pose_error(model: PoseTask, pose: FloatArray, target: FloatArray) -> tuple[float, float]:
    """Position [m] and orientation [rad] error of ``pose`` against ``target``."""
    d = model.difference(pose, target)
    return float(np.linalg.norm(d[:3])), float(np.linalg.norm(d[3:]))


def solve_within_limits(
    model: PoseTask, target: FloatArray, seeds: list[FloatArray]
) -> tuple[FloatArray, bool]:
    """A configuration within the end-stops that reaches ``target``, tried from each seed.

    Returns the best configuration found and whether it reaches the target
    within :data:`REACH_TOL`.
    """
    lo, hi = model.q_min, model.q_max
    inner = 1e-9 * np.maximum(1.0, hi - lo)

    def residual(q: FloatArray) -> FloatArray:
        return model.difference(target, model.pose(q))

    def jacobian(q: FloatArray) -> FloatArray:
        return model.difference_jacobian(target, q)

    best, best_cost = np.clip(seeds[0], lo, hi), np.inf
    for seed in seeds:
        x0 = np.clip(seed, lo + inner, hi - inner)
        fit = least_squares(
            residual,
            x0,
            jac=jacobian,
            bounds=(lo, hi),
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=200,
        )
        pos, ori = pose_error(model, model.pose(fit.x), target)
        if pos <= REACH_TOL[0] and ori <= REACH_TOL[1]:
            return fit.x, True
        if fit.cost < best_cost:
            best, best_cost = fit.x, fit.cost
    return best, False


def reachable_mask(
    model: PoseTask,
    targets: FloatArray,
    q0: FloatArray,
    hints: tuple[FloatArray, ...] = (),
    every: int = SAMPLE_EVERY,
) -> FloatArray:
    """One flag per target: reachable within the end-stops (sampled every ``every`` targets).

    Each sample is solved from the previous sample's answer, the last
    reachable one's, ``q0`` and the ``hints``; a step between two samples is
    reachable only when both are (the last step takes the last sample's flag).
    """
    n = len(targets)
    picks = list(range(0, n, every))
    if picks[-1] != n - 1:
        picks.append(n - 1)
    flags = []
    q0 = np.array(q0, dtype=float)
    previous = last_good = q0
    for k in picks:
        seeds = [previous] + [s for s in (last_good, q0, *hints) if s is not previous]
        q, ok = solve_within_limits(model, targets[k], seeds)
        flags.append(ok)
        previous = q
        if ok:
            last_good = q
    mask = np.zeros(n, dtype=bool)
    for (a, fa), (b, fb) in zip(zip(picks, flags), zip(picks[1:], flags[1:])):
        mask[a:b] = fa and fb
    mask[picks[-1]] = flags[-1]
    return mask


def reach_along(
    model: PoseTask, q0: FloatArray, direction: FloatArray, longest: float = 2.0
) -> float:
    """How far [m] the pose at ``q0`` can move along ``direction`` and stay reachable.

    Bisection to 1 mm on the distance, orientation held, each solve seeded
    from the last reachable configuration.
    """
    start = model.pose(q0)
    unit = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    lo, hi, seed = 0.0, longest, np.array(q0, dtype=float)
    while hi - lo > 1e-3:
        mid = 0.5 * (lo + hi)
        q, ok = solve_within_limits(model, moved(start, mid * unit), [seed, q0])
        if ok:
            lo, seed = mid, q
        else:
            hi = mid
    return lo


def unlimited_path(model: PoseTask, q0: FloatArray, targets: FloatArray) -> FloatArray:
    """Least-norm tracking of ``targets`` with no limits: ``q += pinv(J) difference``, (N, n)."""
    q = np.array(q0, dtype=float)
    out = np.empty((len(targets), q.size))
    for k, target in enumerate(targets):
        for _ in range(3):  # a few Newton steps per target: the path, not one control law
            q = q + np.linalg.pinv(model.jacobian(q)) @ model.difference(model.pose(q), target)
        out[k] = q
    return out
