"""The result of one step and its statuses.

Every method returns a :class:`Result`. Its ``status`` is one of the words in
:data:`STATUSES`; ``binding`` says *why* ``p < 1`` (or which limit a classical
step breaks; :mod:`lpik.labels` spells it). :mod:`lpik.check` re-checks a
step independently of the solver that produced it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.problem import Problem
from lpik.types import FloatArray

OPTIMAL = "optimal"
SCALED = "scaled"
RECOVERING = "recovering"
OFF_DIRECTION = "off_direction"
VIOLATES_LIMITS = "violates_limits"
INFEASIBLE = "infeasible"
SINGULAR = "singular"
LIMIT_REACHED = "limit_reached"
SOLVER_ERROR = "solver_error"
CHECK_FAILED = "check_failed"

#: Every status a result can carry, with its meaning.
STATUSES: dict[str, str] = {
    OPTIMAL: "the method's problem was solved; every limit holds",
    SCALED: "l1: the full displacement is infeasible; the step is the least-L1 step "
    "achieving the largest feasible fraction p (binding names the limit); also the "
    "controller's step where LP2's conditions admit no step but LP1 has one (method l1)",
    VIOLATES_LIMITS: "classical methods only: the returned (unclamped) step breaks the limit "
    "named in binding",
    RECOVERING: "the state was outside a limit (binding names it: a joint past its end-stop, "
    "a speed above its limit); the step moves it back as fast as the limits allow and p is "
    "the fraction of the command the other joints achieve (J dq = p dw); where they cannot "
    "hold the task even at p = 0, the step is the safe step (p = 0, residual = |J dq|)",
    OFF_DIRECTION: "the step left the commanded direction to reduce the task error as much as "
    "every limit allows (least L1 error): the stall stage's progress step, where the exact "
    "step had stalled (on_stall; p = 0), or mode='progress''s second stage after the exact "
    "step (p and binding are the exact step's); residual = max |J dq - dw|, what remains of "
    "the command",
    INFEASIBLE: "no step meets the method's conditions and every limit, not even p = 0; "
    "the safe step",
    SINGULAR: "the method's linear system is singular; the safe step",
    LIMIT_REACHED: "the solver stopped at an iteration or time limit; the safe step",
    SOLVER_ERROR: "the solver failed; the safe step",
    CHECK_FAILED: "the solver claimed success but lpik's own check of the answer failed; "
    "the safe step",
}

#: What every method returns when it cannot answer (:func:`safe_step`).
SAFE_STEP = (
    "p = 0 and each joint comes to rest as fast as its limits allow: the step within the "
    "step's bounds nearest to no motion (no motion for a joint at rest within its limits; "
    "full deceleration for a joint moving under acceleration limits; a joint outside its "
    "end-stops moves back towards them)"
)

#: Statuses whose step moves the robot as the method intends.
MOVING = frozenset({OPTIMAL, SCALED, RECOVERING, OFF_DIRECTION, VIOLATES_LIMITS})


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
        pull_scale: The share ``s`` of sec. 3.1's pull ``Lambda (q_ref - q0)`` that LP2's step
            took (:func:`lpik.methods.pull.pull_scale`): 1 where the whole pull fits the step
            at ``p = 0`` (the paper's LP2), less where it was scaled to leave the command
            room. 1 without ``Lambda``, for methods without the pull and for safe steps.
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
    pull_scale: float = 1.0

    @classmethod
    def trusted(cls, fields: dict[str, Any]) -> Result:
        """Build a result from already-checked values without the dataclass ``__init__``.

        The one way the compiled path (:mod:`lpik.fast`, whose kernel checks its
        own answer) builds a result: a frozen dataclass's ``__init__`` is a
        sizeable part of a 1 kHz loop's step. ``fields`` holds every field by
        name; the result takes it over as its ``__dict__`` (no copy).
        """
        obj = object.__new__(cls)
        object.__setattr__(obj, "__dict__", fields)
        return obj

    @property
    def moved(self) -> bool:
        """True when the step is the method's answer (or a recovery), not the safe step."""
        return self.status in MOVING

    def to_dict(self) -> dict[str, Any]:
        """The ``lpik solve`` JSON contract: ``q, dq, p, lam, status, binding, pull_scale``."""
        return {
            "q": [float(v) for v in self.q],
            "dq": [float(v) for v in self.dq],
            "p": float(self.p),
            "lam": None if self.lam is None else [float(v) for v in self.lam],
            "status": self.status,
            "binding": self.binding,
            "pull_scale": float(self.pull_scale),
        }


def safe_step(
    problem: Problem,
    method: str,
    status: str,
    binding: str | None = None,
    *,
    solve_time: float = 0.0,
    path: str = "",
    name_outside: bool = True,
) -> Result:
    """The step returned whenever a method cannot answer: :data:`SAFE_STEP`.

    ``dq`` is 0 clipped to the step's bounds (:meth:`~lpik.problem.Problem.step_bounds`,
    which hold the acceleration limits and the precedence of :mod:`lpik.bands`),
    so the safe step never breaks an acceleration limit: it is a controlled stop,
    not an instant one. ``J dq`` need not be 0 while joints brake. An infeasible
    step from a state outside its limits is reported as ``recovering``, naming
    the limit the state is outside of (``name_outside=False``: ``infeasible``,
    naming the conflict, what LP2 with saturation needs from each pass).
    """
    lower, upper = problem.step_bounds()[:2]
    dq = np.clip(0.0, lower, upper)
    outside = problem.recovering()
    if status == INFEASIBLE and outside and name_outside:
        status, binding = RECOVERING, outside[0]
    return Result(
        q=problem.q0 + dq,
        dq=dq,
        p=0.0,
        lam=None,
        status=status,
        binding=binding,
        method=method,
        solve_time=solve_time,
        residual=float(np.abs(problem.J @ dq).max()),
        path=path,
    )
