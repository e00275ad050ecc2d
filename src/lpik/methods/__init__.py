"""One-step inverse-kinematics methods: each takes one :class:`~lpik.problem.Problem`.

=========  ==================================================  ===============
name       what                                                paper
=========  ==================================================  ===============
pinv       Moore-Penrose pseudo-inverse                        eqs. 8-9
weighted   weighted least-norm step (M, f; Lambda, q_ref)      eq. 7, sec. 3.1
robust     Komainda's robust (damped) inverse                  eq. 19
lp1        Schlemmer's LP: max p, no criterion                 eqs. 11-14
l1         Ho's LP: min ||dq||_1                               sec. 2.3
lp2        max p with the quadratic criterion as LP rows       eqs. 15-18, 3.1-3.2
nlp        Schlemmer's nonlinear program (needs the model)     sec. 2.2
=========  ==================================================  ===============
"""

from __future__ import annotations

from collections.abc import Callable

from lpik.exceptions import InvalidProblemError
from lpik.methods.classical import pinv, robust, weighted, yoshikawa_manipulability
from lpik.methods.l1 import l1
from lpik.methods.lp1 import lp1
from lpik.methods.lp2 import affine_solution, lp2, ratio_test
from lpik.methods.nlp import nlp
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import TaskModel

#: Methods that need only the problem value, by name.
METHODS: dict[str, Callable[[Problem], Result]] = {
    "pinv": pinv,
    "weighted": weighted,
    "robust": robust,
    "lp1": lp1,
    "l1": l1,
    "lp2": lp2,
}

#: Methods whose answer is guaranteed to keep every limit (LPs and the NLP).
LIMIT_AWARE = frozenset({"lp1", "l1", "lp2", "nlp"})

#: Every method name, the model-based ``nlp`` included.
ALL_METHODS = (*METHODS, "nlp")


def solve(problem: Problem, method: str = "lp2", *, model: TaskModel | None = None) -> Result:
    """Solve one step with the named method.

    Args:
        problem: The validated step problem.
        method: One of :data:`ALL_METHODS`.
        model: The task model; required by ``"nlp"``, ignored by the others.

    Raises:
        InvalidProblemError: (a ``ValueError``) for an unknown method name, or
            ``"nlp"`` without a model.
    """
    if method == "nlp":
        if model is None:
            raise InvalidProblemError(
                "method", "'nlp' needs the robot model (use lpik simulate, or pass model=)"
            )
        return nlp(problem, model)
    try:
        fn = METHODS[method]
    except (KeyError, TypeError):
        raise InvalidProblemError(
            "method", f"unknown method {method!r}; available: {', '.join(ALL_METHODS)}"
        ) from None
    return fn(problem)


__all__ = [
    "ALL_METHODS",
    "LIMIT_AWARE",
    "METHODS",
    "affine_solution",
    "l1",
    "lp1",
    "lp2",
    "nlp",
    "pinv",
    "ratio_test",
    "robust",
    "solve",
    "weighted",
    "yoshikawa_manipulability",
]
