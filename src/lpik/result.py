"""The result of one step, its statuses, and the independent check of a step.

Every method returns a :class:`Result`. Its ``status`` is one of the words in
:data:`STATUSES`; ``binding`` says *why* ``p < 1`` (or which limit a classical
step breaks). :func:`check_step` re-checks a step against the problem's
limits and equations with lpik's own tolerance, independently of the solver
that produced it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.problem import Problem

FloatArray = NDArray[np.float64]

OPTIMAL = "optimal"
SCALED = "scaled"
VIOLATES_LIMITS = "violates_limits"
INFEASIBLE = "infeasible"
SINGULAR = "singular"
LIMIT_REACHED = "limit_reached"
SOLVER_ERROR = "solver_error"
CHECK_FAILED = "check_failed"

#: Every status a result can carry, with its meaning.
STATUSES: dict[str, str] = {
    OPTIMAL: "the method's problem was solved; every limit holds",
    SCALED: "l1 only: the full displacement is infeasible; the step is the least-L1 step "
    "achieving the largest feasible fraction p (binding names the limit)",
    VIOLATES_LIMITS: "classical methods only: the returned (unclamped) step breaks the limit "
    "named in binding",
    INFEASIBLE: "no step satisfies the limits, not even p = 0; safe no-motion step",
    SINGULAR: "the method's linear system is singular; safe no-motion step",
    LIMIT_REACHED: "the solver stopped at an iteration or time limit; safe no-motion step",
    SOLVER_ERROR: "the solver failed; safe no-motion step",
    CHECK_FAILED: "the solver claimed success but lpik's own check of the answer failed; "
    "safe no-motion step",
}

#: Statuses whose step moves the robot as the method intends.
MOVING = frozenset({OPTIMAL, SCALED, VIOLATES_LIMITS})

#: Absolute tolerance of :func:`check_step` on bounds and rows, scaled by the bound's size.
FEASIBILITY_TOL = 1e-7
#: Tolerance of :func:`check_step` on ``J dq = p dw``, relative to ``|J| |dq| + |dw|``.
EQUALITY_RTOL = 1e-7


@dataclass(frozen=True, eq=False)
class Result:
    """One step's answer.

    Attributes:
        q: New joint coordinates, shape (n,) [rad or m].
        dq: Step ``q - q0``, shape (n,).
        p: Affine dexterity in [0, 1] (eq. 10): the achieved fraction of ``dw``.
        lam: Lagrange multipliers, shape (m,), or ``None`` for methods without them
            and for safe steps.
        status: One of :data:`STATUSES`.
        binding: The limit that keeps ``p`` below 1 (or, for ``violates_limits``,
            the limit broken worst); ``None`` when ``p = 1`` and nothing is violated.
        method: Name of the method that produced the step.
        solve_time: Wall time of the method [s].
        residual: ``max |J dq - p dw|`` [m or rad].
        path: How the answer was computed (e.g. ``"ratio-test"``, ``"highs"``, ``"closed-form"``).
    """

    q: FloatArray
    dq: FloatArray
    p: float
    lam: FloatArray | None
    status: str
    binding: str | None
    method: str
    solve_time: float = 0.0
    residual: float = 0.0
    path: str = ""

    @classmethod
    def trusted(cls, **fields: Any) -> Result:
        """Build a result from already-checked values without the dataclass ``__init__``.

        For the compiled path (:mod:`lpik.fast`), whose kernel checks its own
        answer: a frozen dataclass's ``__init__`` costs about 2 us, a sizeable
        part of a 1 kHz loop's step. Every field must be given.
        """
        obj = object.__new__(cls)
        obj.__dict__.update(fields)
        return obj

    @property
    def moved(self) -> bool:
        """True when the step is the method's answer, not a safe no-motion step."""
        return self.status in MOVING

    def to_dict(self) -> dict[str, Any]:
        """The ``lpik solve`` JSON contract: ``q, dq, p, lam, status, binding``."""
        return {
            "q": [float(v) for v in self.q],
            "dq": [float(v) for v in self.dq],
            "p": float(self.p),
            "lam": None if self.lam is None else [float(v) for v in self.lam],
            "status": self.status,
            "binding": self.binding,
        }


def safe_step(
    problem: Problem,
    method: str,
    status: str,
    binding: str | None = None,
    *,
    solve_time: float = 0.0,
    path: str = "",
) -> Result:
    """The no-motion step ``q = q0, p = 0`` returned whenever a method cannot answer."""
    return Result(
        q=problem.q0.copy(),
        dq=np.zeros(problem.n),
        p=0.0,
        lam=None,
        status=status,
        binding=binding,
        method=method,
        solve_time=solve_time,
        residual=0.0,
        path=path,
    )


@dataclass(frozen=True)
class Violation:
    """The worst limit a step breaks, by how much, and its label."""

    amount: float
    label: str | None


def worst_violation(problem: Problem, dq: FloatArray, lam: FloatArray | None = None) -> Violation:
    """The largest scaled violation of any bound or row by a step (eqs. 13-14, sec. 3.2, G q <= h).

    Each violation is divided by ``max(1, |bound|)`` so that one tolerance fits
    bounds of any size.
    """
    lower, upper, lower_labels, upper_labels = problem.step_bounds()
    worst = Violation(0.0, None)
    checks: list[tuple[FloatArray, FloatArray, tuple[str, ...]]] = [
        (lower - dq, lower, lower_labels),
        (dq - upper, upper, upper_labels),
    ]
    if lam is not None:
        lam_lo, lam_hi = problem.multiplier_labels()
        checks.append((problem.lam_min - lam, problem.lam_min, lam_lo))
        checks.append((lam - problem.lam_max, problem.lam_max, lam_hi))
    if problem.G.shape[0]:
        rhs = problem.h - problem.G @ problem.q0
        checks.append((problem.G @ dq - rhs, rhs, tuple(problem.row_labels)))
    for excess, bound, labels in checks:
        if excess.size == 0:
            continue
        with np.errstate(invalid="ignore"):
            scaled = excess / np.maximum(1.0, np.where(np.isfinite(bound), np.abs(bound), 1.0))
        scaled = np.where(np.isnan(scaled), -np.inf, scaled)
        i = int(np.argmax(scaled))
        if scaled[i] > worst.amount:
            worst = Violation(float(scaled[i]), labels[i])
    return worst


def task_residual(problem: Problem, dq: FloatArray, p: float) -> float:
    """``max |J dq - p dw|``: how far a step is from the linearised task (eqs. 12, 15)."""
    return float(np.abs(problem.J @ dq - p * problem.dw).max())


def check_step(problem: Problem, dq: FloatArray, p: float, lam: FloatArray | None) -> str | None:
    """Independent re-check of an LP answer; ``None`` when it holds, else what fails.

    Checks ``0 <= p <= 1``, every bound and row (:func:`worst_violation`) within
    :data:`FEASIBILITY_TOL`, and ``J dq = p dw`` within :data:`EQUALITY_RTOL`.
    """
    if not (math.isfinite(p) and -FEASIBILITY_TOL <= p <= 1 + FEASIBILITY_TOL):
        return f"p = {p} outside [0, 1]"
    if not np.isfinite(dq).all() or (lam is not None and not np.isfinite(lam).all()):
        return "non-finite step"
    violation = worst_violation(problem, dq, lam)
    if violation.amount > FEASIBILITY_TOL:
        return f"{violation.label} violated by {violation.amount:.3g}"
    scale = float(np.abs(problem.J).max() * np.abs(dq).max() + np.abs(problem.dw).max())
    if task_residual(problem, dq, p) > EQUALITY_RTOL * max(1.0, scale):
        return "J dq != p dw"
    return None


def clip_to_bounds(problem: Problem, dq: FloatArray) -> FloatArray:
    """Remove solver-tolerance excursions (below :data:`FEASIBILITY_TOL`) past the bounds."""
    lower, upper, _, _ = problem.step_bounds()
    return np.clip(dq, lower, upper)
