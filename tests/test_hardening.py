"""Hostile and careless input: every case is refused early, in one line that names the input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from lpik.exceptions import InvalidProblemError
from lpik.methods import solve
from lpik.methods.registry import METHODS
from lpik.problem import Problem
from lpik.tolerances import MAX_MAGNITUDE

PROBLEM_ONLY = [name for name, spec in METHODS.items() if not spec.needs_model]


# --- Problem: the size of its numbers ----------------------------------------------------------


def at_cap_problems() -> list[tuple[str, dict]]:
    """Problems with data at MAX_MAGNITUDE, field by field and all at once."""
    C = MAX_MAGNITUDE
    n = 4
    sign = np.array([[1.0, -1.0, 1.0, 1.0], [-1.0, 1.0, 1.0, -1.0]])
    base = {"J": sign, "dw": [0.1, -0.1], "q0": np.zeros(n)}
    full = {"q_min": np.full(n, -C), "q_max": np.full(n, C)}
    return [
        ("J", {**base, "J": C * sign}),
        ("J rank 1", {**base, "J": C * np.ones((2, n))}),
        ("dw", {**base, "dw": [C, -C]}),
        ("q0 and bounds", {**base, "q0": np.full(n, C / 2), **full}),
        ("step bounds", {**base, "dq_min": np.full(n, -C), "dq_max": np.full(n, C)}),
        ("M f", {**base, "M": np.full(n, C), "f": np.full(n, -C)}),
        ("Lambda q_ref", {**base, "Lambda": np.full(n, C), "q_ref": np.full(n, -C)}),
        ("G h", {**base, "G": C * np.ones((1, n)), "h": [-C]}),
        ("multipliers", {**base, "lam_min": [-C, -C], "lam_max": [C, C]}),
        ("J dw M", {**base, "J": C * sign, "dw": [C, -C], "M": np.full(n, C)}),
    ]


@pytest.mark.parametrize("method", PROBLEM_ONLY)
def test_no_method_warns_at_the_largest_magnitude(method: str) -> None:
    for label, fields in at_cap_problems():
        extra = [{}, {"k": MAX_MAGNITUDE}] if method == "robust" else [{}]
        for more in extra:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                result = solve(Problem(**fields, **more), method)
            assert 0.0 <= result.p <= 1.0, (label, more)
            assert np.isfinite(result.q).all(), (label, more)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("J", lambda J: 1e200 * J),
        ("J", lambda J: 2 * MAX_MAGNITUDE * np.sign(J + 0.1)),
        ("dw", lambda J: [1e13, 0.0]),
        ("q0", lambda J: [0.0, 0.0, -1e13]),
        ("q_min", lambda J: [-1e20, None, None]),
        ("M", lambda J: [1e13, 1.0, 1.0]),
        ("Lambda", lambda J: np.eye(3) * 1e300),
        ("f", lambda J: [0.0, 1e13, 0.0]),
        ("G", lambda J: [[1e13, 0.0, 0.0]]),
        ("k", lambda J: 1e13),
    ],
)
def test_the_python_api_refuses_numbers_beyond_the_cap(field: str, value) -> None:  # type: ignore[no-untyped-def]
    J = np.array([[1.0, 0.5, 0.25], [0.0, 1.0, 0.5]])
    fields = {"J": J, "dw": [0.01, 0.0], "q0": np.zeros(3), field: value(J)}
    if field == "G":
        fields["h"] = [1.0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InvalidProblemError) as info:
            Problem(**fields)
    assert info.value.field == field
    assert "1e+12" in str(info.value)


def test_infinite_bounds_are_still_unbounded() -> None:
    P = Problem(J=[[1.0, 0.0]], dw=[0.1], q0=[0.0, 0.0], q_min=[-np.inf, None], q_max=[np.inf, 1])
    assert np.isneginf(P.q_min).all() and P.q_max[0] == np.inf
