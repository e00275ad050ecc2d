"""Independent references for the tests of the lpik core.

Everything here is written from the paper, LP2 in ABSOLUTE joint coordinates
``q`` (LP1 and Ho's LP in the step ``dq = q - q0``, see :func:`lp1_reference`),
with scipy.optimize.linprog (method="highs") or numpy: nothing calls lpik's
LP assembly, its step bounds or its checker. End-stops (eq. 13) are variable
bounds; the per-step bounds of eq. 14 and the extra rows ``G q <= h`` are
inequality rows. Two things are taken from lpik: which joints
LP2 pins (:meth:`lpik.problem.Problem.pinned`, a rule tested on its own in
``test_recovery.py``), which the reference then fixes, dropping their
criterion rows as eq. 18 over the free joints reads; and the scale of sec.
3.1's pull (:func:`lpik.methods.kkt.smoothing`, tested on its own in
``test_lp2.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from lpik.methods.kkt import smoothing
from lpik.problem import Problem

#: Tolerances handed to linprog's HiGHS (tighter than its defaults, like lpik's).
LINPROG_OPTIONS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}
#: A hard limit may be exceeded by at most this, relative to max(1, |bound|).
HARD_TOL = 1e-7


#: Two paths of lp2s (numpy and compiled) may differ by this in ``q``: its later passes
#: run over fewer free joints, whose Schur complement may be ill-conditioned up to
#: :data:`lpik.tolerances.MAX_SCHUR_CONDITION` (rounding times that condition); plain
#: LP2 on a regular Jacobian agrees to 1e-12.
SATURATION_ROUNDING = 1e-7


#: Margin by which :func:`bracket` relaxes (and tightens) every limit: 100 times the
#: solvers' feasibility tolerance, so that their tolerance cannot cross it.
MARGIN = 1e-8


@dataclass(frozen=True)
class Reference:
    """A reference LP's answer; ``q``, ``lam`` and ``p`` are ``None`` when it is infeasible."""

    feasible: bool
    q: np.ndarray | None = None
    lam: np.ndarray | None = None
    p: float | None = None
    objective: float | None = None


def _interval(lo: float, hi: float, margin: float) -> tuple[float | None, float | None]:
    """``[lo - margin, hi + margin]`` (a negative margin tightens; a fixed value stays fixed)."""
    a, b = lo - margin, hi + margin
    if a > b:
        a = b = 0.5 * (lo + hi)
    return (a if np.isfinite(a) else None, b if np.isfinite(b) else None)


def _q_rows(
    P: Problem, extra_cols: int, margin: float, skip: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 14 (``q0 + dq_min <= q <= q0 + dq_max``) and ``G q <= h`` as ``A q <= b`` rows.

    Joints in ``skip`` (fixed by their variable bounds) get no eq. 14 rows.
    """
    eye = np.eye(P.n)
    keep = np.ones(P.n, dtype=bool) if skip is None else ~skip
    hi = np.isfinite(P.dq_max) & keep
    lo = np.isfinite(P.dq_min) & keep
    A = np.vstack([eye[hi], -eye[lo], P.G])
    b = np.concatenate([(P.q0 + P.dq_max)[hi], -(P.q0 + P.dq_min)[lo], P.h]) + margin
    return np.hstack([A, np.zeros((A.shape[0], extra_cols))]), b


#: HiGHS treats matrix entries at or below this size as zero (its ``small_matrix_value``).
HIGHS_SMALL_MATRIX_VALUE = 1e-9


def _linprog(c, A_ub, b_ub, A_eq, b_eq, bounds):  # type: ignore[no-untyped-def]
    """linprog, trusted only when it is optimal or when default tolerances agree.

    HiGHS's presolve with very tight tolerances can misjudge programs with
    nearly parallel columns (aligned links), so the tight solve runs without
    presolve, then with it, and a verdict other than optimal is confirmed with
    HiGHS's default tolerances.
    """
    kwargs = {
        "A_ub": A_ub if A_ub.shape[0] else None,
        "b_ub": b_ub if A_ub.shape[0] else None,
        "A_eq": A_eq,
        "b_eq": b_eq,
        "bounds": bounds,
        "method": "highs",
    }
    res = linprog(c, options={**LINPROG_OPTIONS, "presolve": False}, **kwargs)
    if res.status != 0:
        res = linprog(c, options=LINPROG_OPTIONS, **kwargs)
    if res.status != 0:
        res = linprog(c, **kwargs)
    return res


def lp2_reference(P: Problem, margin: float = 0.0) -> Reference:
    """Eq. 18 with sec. 3.1's term and sec. 3.2's multiplier bounds; variables (dq, lam, p).

    ``margin`` relaxes (> 0) or tightens (< 0) every limit, the equality rows never.
    Written in the step ``dq`` for the reason :func:`lp1_reference` gives: in absolute
    coordinates a Jacobian entry of 1e-9 that HiGHS dropped moved a task row by
    ``1e-9 |q0|`` and made a pinned arm's program infeasible (a hypothesis draw of
    tests/test_lp2s.py).
    """
    n, m = P.n, P.m
    H = P.M + P.Lambda
    pinned, d = P.pinned()
    free = ~pinned
    A_eq = np.block([[H, P.J.T, np.zeros((n, 1))], [P.J, np.zeros((m, m)), -P.dw[:, None]]])
    s = smoothing(P)  # sec. 3.1's pull, scaled as lpik scales it
    b_eq = np.concatenate([s * P.Lambda @ (P.q_ref - P.q0) + P.f, np.zeros(m)])
    keep = np.concatenate([free, np.ones(m, dtype=bool)])  # a pinned joint has no criterion row
    A_ub, b_ub = _dq_rows(P, m + 1, margin, skip=pinned)
    lam_bounds = [_interval(lo, hi, margin) for lo, hi in zip(P.lam_min, P.lam_max)]
    stops = [
        (float(d[i]),) * 2 if pinned[i] else bound for i, bound in enumerate(_dq_stops(P, margin))
    ]
    c = np.zeros(n + m + 1)
    c[-1] = -1.0
    res = _linprog(c, A_ub, b_ub, A_eq[keep], b_eq[keep], stops + lam_bounds + [(0.0, 1.0)])
    if res.status != 0:
        return Reference(False)
    q = P.q0 + res.x[:n]
    return Reference(True, q, res.x[n : n + m], float(res.x[-1]), float(-res.fun))


def _dq_rows(
    P: Problem, extra_cols: int, margin: float, skip: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 14 and ``G q <= h`` as rows ``A dq <= b`` in the step ``dq = q - q0``."""
    A, b = _q_rows(P, extra_cols, margin, skip)
    return A, b - A[:, : P.n] @ P.q0


def _dq_stops(P: Problem, margin: float) -> list[tuple[float | None, float | None]]:
    """Eq. 13's end-stops as bounds on the step ``dq = q - q0``."""
    return [_interval(lo, hi, margin) for lo, hi in zip(P.q_min - P.q0, P.q_max - P.q0)]


def lp1_reference(P: Problem, margin: float = 0.0) -> Reference:
    """Eqs. 11-14: max p s.t. ``J dq = p dw`` and the bounds; variables (dq, p).

    Written in the step ``dq`` rather than in ``q``: HiGHS drops matrix entries
    below 1e-9 (its ``small_matrix_value``), which in absolute coordinates moves
    a row by that entry times ``|q0|`` and can make a pinned arm's program
    infeasible; in the step the same drop moves a row by at most 1e-9 ``|dq|``.
    """
    n = P.n
    A_eq = np.hstack([P.J, -P.dw[:, None]])
    A_ub, b_ub = _dq_rows(P, 1, margin)
    c = np.zeros(n + 1)
    c[-1] = -1.0
    res = _linprog(c, A_ub, b_ub, A_eq, np.zeros(P.m), _dq_stops(P, margin) + [(0.0, 1.0)])
    if res.status != 0:
        return Reference(False)
    return Reference(True, P.q0 + res.x[:n], None, float(res.x[-1]), float(-res.fun))


def l1_reference(P: Problem, p: float = 1.0, margin: float = 0.0) -> Reference:
    """Ho's LP: min ``sum |dq|`` s.t. ``J dq = p dw`` and the bounds; variables (dq, t).

    In the step ``dq`` for the reason :func:`lp1_reference` gives.
    """
    n = P.n
    eye = np.eye(n)
    A_rows, b_rows = _dq_rows(P, n, margin)
    A_ub = np.vstack([A_rows, np.hstack([eye, -eye]), np.hstack([-eye, -eye])])
    b_ub = np.concatenate([b_rows, np.zeros(2 * n)])
    A_eq = np.hstack([P.J, np.zeros((P.m, n))])
    c = np.concatenate([np.zeros(n), np.ones(n)])
    bounds = _dq_stops(P, margin) + [(0.0, None)] * n
    res = _linprog(c, A_ub, b_ub, A_eq, p * P.dw, bounds)
    if res.status != 0:
        return Reference(False)
    return Reference(True, P.q0 + res.x[:n], None, p, float(res.fun))


def exactly_feasible(P: Problem, ref: Reference, *, criterion: bool = False) -> bool:
    """True when a reference's point keeps every limit and equality to 1e-12 (not 1e-10).

    Only such a point proves that its value is attainable: a solver may buy a
    much larger p with a violation inside its tolerance when the feasible set is
    a thin sliver.
    """
    if not ref.feasible or ref.q is None or ref.p is None:
        return False
    dq = ref.q - P.q0
    scale = max(1.0, float(np.abs(P.J).max() * np.abs(dq).max() + np.abs(P.dw).max()))
    ok = hard_violation(P, ref.q, ref.lam) <= 1e-12 and _task_rows_hold(P, ref)
    if criterion and ref.lam is not None:
        H = P.M + P.Lambda
        c = P.f + P.Lambda @ (P.q_ref - P.q0)
        free = ~P.pinned()[0]  # a pinned joint's row of eq. 18 is dropped (its bound holds it)
        criterion_rows = (H @ dq + P.J.T @ ref.lam - c)[free]
        ok = ok and float(np.abs(criterion_rows).max(initial=0.0)) <= 1e-12 * scale
    return bool(ok)


@dataclass(frozen=True)
class Bracket:
    """What an optimal value may be, whatever the solvers' tolerances.

    ``loose`` solves the program with every limit relaxed by :data:`MARGIN`,
    ``tight`` with every limit tightened by it, ``exact`` as given. The optimum
    lies between the tightened optimum (or an exactly feasible point of the
    exact solve) and the relaxed optimum; for a well-posed program the three
    agree, and the bracket is as sharp as the tolerance.
    """

    tight: Reference
    exact: Reference
    loose: Reference
    exact_is_feasible: bool
    tight_is_feasible: bool = True

    def attainable(self, sense: float = 1.0) -> float | None:
        """The best value proven attainable (``sense`` 1 for max p, -1 for min objective).

        The tightened optimum counts when its point keeps the limits as given: a
        solver can return a point of a tightened program that is empty (a bound
        and a row that meet exactly), inside its tolerance but outside the limits.
        """
        values = [r.objective for r in (self.tight,) if r.feasible and self.tight_is_feasible]
        if self.exact_is_feasible:
            values.append(self.exact.objective)
        values = [v for v in values if v is not None]
        return (max if sense > 0 else min)(values) if values else None


def bracket(reference, P: Problem, *args: object, criterion: bool = False) -> Bracket:  # type: ignore[no-untyped-def]
    """:class:`Bracket` of ``reference(P, *args, margin=...)``."""
    exact = reference(P, *args)
    tight = reference(P, *args, margin=-MARGIN)
    return Bracket(
        tight=tight,
        exact=exact,
        loose=reference(P, *args, margin=MARGIN),
        exact_is_feasible=exactly_feasible(P, exact, criterion=criterion),
        # strictly: a tightened program's point lies inside the limits by about MARGIN, and
        # keeps J dq = p dw and, for LP2, the criterion's rows (a row of tiny coefficients
        # lets a solver buy p within its equality tolerance: off LP2's affine path, a
        # row G dq <= 0 with G b_q = 1e-8 > 0 admits p = 0.2 instead of 0)
        tight_is_feasible=exactly_feasible(P, tight, criterion=criterion),
    )


def _task_rows_hold(P: Problem, ref: Reference) -> bool:
    """``J dq = p dw`` at a reference's point, to 1e-12 of the rows' scale."""
    dq = ref.q - P.q0
    scale = max(1.0, float(np.abs(P.J).max() * np.abs(dq).max() + np.abs(P.dw).max()))
    return float(np.abs(P.J @ dq - ref.p * P.dw).max()) <= 1e-12 * scale


def weighted_reference(P: Problem) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 7 with sec. 3.1's term, solved directly for (q, lam) in absolute coordinates."""
    n, m = P.n, P.m
    H = P.M + P.Lambda
    K = np.block([[H, P.J.T], [P.J, np.zeros((m, m))]])
    rhs = np.concatenate([P.M @ P.q0 + P.Lambda @ P.q_ref + P.f, P.J @ P.q0 + P.dw])
    x = np.linalg.solve(K, rhs)
    return x[:n], x[n:]


def hard_violation(P: Problem, q: np.ndarray, lam: np.ndarray | None = None) -> float:
    """Largest violation of an end-stop, step bound, row or multiplier bound.

    Written in absolute coordinates: ``q_min <= q <= q_max`` and
    ``q0 + dq_min <= q <= q0 + dq_max`` (absolute amounts [rad]), ``G q <= h``
    and ``lam_min <= lam <= lam_max`` (relative to ``max(1, |bound|)``).
    """
    excess = [P.q_min - q, q - P.q_max, P.q0 + P.dq_min - q, q - P.q0 - P.dq_max]
    if P.G.shape[0]:
        excess.append((P.G @ q - P.h) / np.maximum(1.0, np.abs(P.h)))
    if lam is not None:
        for bound, diff in ((P.lam_min, P.lam_min - lam), (P.lam_max, lam - P.lam_max)):
            with np.errstate(invalid="ignore"):
                excess.append(diff / np.maximum(1.0, np.abs(bound)))
    values = np.concatenate(excess)
    values = values[np.isfinite(values)]
    return float(max(0.0, values.max(initial=0.0)))


def task_error(P: Problem, dq: np.ndarray, p: float) -> float:
    """``max |J dq - p dw|`` relative to ``max(1, |J| |dq| + |dw|)`` (eqs. 12 and 15)."""
    scale = max(1.0, float(np.abs(P.J).max() * np.abs(dq).max() + np.abs(P.dw).max()))
    return float(np.abs(P.J @ dq - p * P.dw).max()) / scale


def kkt_condition(P: Problem) -> float:
    """Condition number of ``[[M + Lambda, J^T], [J, 0]]`` over the free joints (inf: singular)."""
    m = P.m
    free = ~P.pinned()[0]
    H, J = (P.M + P.Lambda)[np.ix_(free, free)], P.J[:, free]
    K = np.block([[H, J.T], [J, np.zeros((m, m))]])
    return float(np.linalg.cond(K))


def kkt_step(P: Problem, p: float) -> tuple[np.ndarray, np.ndarray]:
    """``(dq, lam)`` of eq. 16 (with sec. 3.1's term) for a given p, by a direct solve."""
    n, m = P.n, P.m
    K = np.block([[P.M + P.Lambda, P.J.T], [P.J, np.zeros((m, m))]])
    c = P.f + P.Lambda @ (P.q_ref - P.q0)
    x = np.linalg.solve(K, np.concatenate([c, p * P.dw]))
    return x[:n], x[n:]


def limiting_ratios(P: Problem) -> list[tuple[float, str]] | None:
    """Where LP2's path ``p -> (dq(p), lam(p))`` reaches each limit, first first.

    Returns ``(p, label)`` for every bound or row that the path reaches at some
    ``p >= 0`` moving outward, sorted by ``p``; ``None`` when the path starts
    outside a limit (then LP2 may need ``p`` above a lower limit: not this case).
    """
    dq0, lam0 = kkt_step(P, 0.0)
    dq1, lam1 = kkt_step(P, 1.0)
    lower, upper, lower_labels, upper_labels = P.step_bounds()
    lam_lo_labels, lam_hi_labels = P.multiplier_labels()
    g = P.h - P.G @ P.q0
    values = [
        (dq0, dq1 - dq0, upper, +1, upper_labels),
        (dq0, dq1 - dq0, lower, -1, lower_labels),
        (lam0, lam1 - lam0, P.lam_max, +1, lam_hi_labels),
        (lam0, lam1 - lam0, P.lam_min, -1, lam_lo_labels),
        (P.G @ dq0, P.G @ (dq1 - dq0), g, +1, P.row_labels),
    ]
    ratios = []
    for a, b, bound, sign, labels in values:
        for i in range(a.size):
            if not np.isfinite(bound[i]):
                continue
            slack = sign * (bound[i] - a[i])
            if slack < -1e-12 * max(1.0, abs(bound[i])):
                return None
            rate = sign * b[i]
            if rate > 1e-12:
                ratios.append((max(0.0, slack) / rate, labels[i]))
    return sorted(ratios, key=lambda item: item[0])


def plausible_last(
    q0: np.ndarray, q_prev: np.ndarray, model: object, qdd: np.ndarray, dt: float
) -> np.ndarray:
    """The last step ``q0 - q_prev`` as the acceleration limits are kept around it.

    Written from the contract (``docs/concepts.md``), not from :mod:`lpik.bands`:
    a step faster than the velocity limit is taken at the limit, or at rest where
    it lies more than one step of acceleration past it (a sample that tells nothing
    of the motion), and any step at most one full deceleration beyond the largest
    step after which the joint can still stop before its end-stop (no step of the
    arm's own goes further).
    """
    last = np.asarray(q0, float) - np.asarray(q_prev, float)
    vel = model.qd_max * dt  # type: ignore[attr-defined]
    decel = qdd * dt * dt

    def braking(room: np.ndarray) -> np.ndarray:
        room = np.maximum(room, 0.0)
        bound = np.maximum(np.minimum(room, decel), np.sqrt(2.0 * decel * room) - 0.5 * decel)
        return np.where(room > 0.0, bound, 0.0)

    brake_hi = braking(model.q_max - q0)  # type: ignore[attr-defined]
    brake_lo = -braking(q0 - model.q_min)  # type: ignore[attr-defined]
    plausible = np.where(np.abs(last) > vel + decel, 0.0, np.clip(last, -vel, vel))
    return np.clip(plausible, brake_lo - decel, brake_hi + decel)
