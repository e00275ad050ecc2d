"""The one table of lpik's methods: what each needs and offers, and :func:`solve`.

``solve``, ``simulate``, ``lpik solve`` and ``lpik simulate`` all read
:data:`METHODS`; a new method is one function and one :class:`MethodSpec` here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from lpik.defaults import DEFAULT_METHOD
from lpik.exceptions import InvalidProblemError
from lpik.methods.classical import pinv, robust, weighted
from lpik.methods.l1 import l1
from lpik.methods.lp1 import lp1
from lpik.methods.lp2 import lp2
from lpik.methods.lp2s import lp2s
from lpik.methods.nlp import nlp
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import TaskModel


@dataclass(frozen=True)
class MethodSpec:
    """One method and what a caller must know to run it.

    Attributes:
        name: The name ``solve``, the CLI and the logs use.
        function: ``function(problem, **options) -> Result``.
        summary: One line saying what it does.
        paper: The paper's equations or section it implements.
        needs_model: Takes the task model itself (``function(problem, model)``).
        takes_solver: Takes a reusable ``solver=`` (:class:`~lpik.highs.HighsSolver`).
        bounds_multipliers: Honours ``lam_min`` / ``lam_max`` (sec. 3.2).
        limit_aware: Every step it returns keeps every limit.
        continuable: Its step is ``J dq = p dw`` (eq. 12), which under acceleration
            limits is solved around the current motion (:mod:`lpik.continuation`).
        takes_criterion: Minimises the quadratic criterion of eq. 3 (``M``, ``f``),
            through which a scene's potential field acts (its force is ``f``).
    """

    name: str
    function: Callable[..., Result]
    summary: str
    paper: str
    needs_model: bool = False
    takes_solver: bool = False
    bounds_multipliers: bool = False
    limit_aware: bool = False
    continuable: bool = False
    takes_criterion: bool = False


#: Every method, by name, in the order the paper introduces them.
METHODS: dict[str, MethodSpec] = {
    spec.name: spec
    for spec in (
        MethodSpec("pinv", pinv, "Moore-Penrose pseudo-inverse step", "eqs. 8-9"),
        MethodSpec(
            "weighted", weighted, "weighted least-norm step (M, f; Lambda, q_ref)",
            "eq. 7, sec. 3.1", takes_criterion=True,
        ),
        MethodSpec(
            "robust", robust, "Komainda's robust (damped) inverse", "eq. 19",
            takes_criterion=True,
        ),
        MethodSpec(
            "lp1", lp1, "Schlemmer's LP: max p, redundancy unresolved", "eqs. 11-14",
            takes_solver=True, limit_aware=True, continuable=True,
        ),
        MethodSpec(
            "l1", l1, "Ho's LP: min ||dq||_1", "sec. 2.3", takes_solver=True, limit_aware=True,
            continuable=True,
        ),
        MethodSpec(
            "lp2", lp2, "max p with the quadratic criterion as LP rows",
            "eqs. 15-18, secs. 3.1-3.2",
            takes_solver=True, bounds_multipliers=True, limit_aware=True, continuable=True,
            takes_criterion=True,
        ),
        MethodSpec(
            "lp2s", lp2s, "LP2 with saturation in the null space: a joint at its bound is "
            "fixed and the others carry on", "eqs. 15-18 over the free joints",
            takes_solver=True, bounds_multipliers=True, limit_aware=True, continuable=True,
            takes_criterion=True,
        ),
        MethodSpec(
            "nlp", nlp, "Schlemmer's nonlinear program (needs the robot model)", "sec. 2.2",
            needs_model=True, limit_aware=True,
        ),
    )
}  # fmt: skip

#: Every method name.
ALL_METHODS = tuple(METHODS)


def methods_with(capability: str) -> str:
    """The names of the methods whose :class:`MethodSpec` has ``capability``, comma-separated.

    What an error or a help text lists as the methods that do (e.g. ``"bounds_multipliers"``).
    """
    return ", ".join(name for name, spec in METHODS.items() if getattr(spec, capability))


def get_method(name: Any, *, field: str = "method") -> MethodSpec:
    """The method called ``name``, or an error (naming ``field``) that lists them."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise InvalidProblemError(
            field, f"unknown method {name!r}; available: {', '.join(METHODS)}"
        ) from None


def solve(
    problem: Problem, method: str = DEFAULT_METHOD, *, model: TaskModel | None = None
) -> Result:
    """Solve one step with the named method.

    Args:
        problem: The validated step problem.
        method: A name from :data:`METHODS` (default :data:`DEFAULT_METHOD`).
        model: The task model; required by methods that need it (``"nlp"``),
            ignored by the others.

    Raises:
        InvalidProblemError: (a ``ValueError``) for an unknown method name, or a
            method that needs the model called without one.
    """
    spec = get_method(method)
    if spec.needs_model:
        if model is None:
            raise InvalidProblemError(
                "method", f"{method!r} needs the robot model (use lpik simulate, or pass model=)"
            )
        return spec.function(problem, model)
    return spec.function(problem)
