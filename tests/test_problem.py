"""The validated one-step problem: defaults, derived bounds, and errors that name the field."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from lpik.exceptions import InvalidProblemError, LpikError
from lpik.problem import Problem
from lpik.problem_json import load_problem, problem_from_dict

J = [[1.0, 0.5, 0.25], [0.0, 1.0, 0.5]]
GOOD = {"J": J, "dw": [0.01, 0.0], "q0": [0.1, 0.2, 0.3]}


def make(**changes: object) -> Problem:
    return Problem(**{**GOOD, **changes})


def test_defaults_follow_the_contract() -> None:
    P = make()
    assert (P.m, P.n) == (2, 3)
    np.testing.assert_array_equal(P.M, np.eye(3))
    np.testing.assert_array_equal(P.Lambda, np.zeros((3, 3)))
    np.testing.assert_array_equal(P.f, np.zeros(3))
    assert np.isneginf(P.q_min).all() and np.isposinf(P.q_max).all()
    assert np.isneginf(P.dq_min).all() and np.isposinf(P.dq_max).all()
    assert np.isneginf(P.lam_min).all() and np.isposinf(P.lam_max).all()
    np.testing.assert_array_equal(P.q_ref, P.q0)  # no finite end-stops: q_ref = q0
    assert P.G.shape == (0, 3) and P.h.shape == (0,) and P.row_labels == ()
    assert P.joint_names == ("joint 1", "joint 2", "joint 3")
    assert P.k is None


def test_q_ref_defaults_to_the_midpoint_where_both_end_stops_are_finite() -> None:
    P = make(q_min=[-1.0, None, -2.0], q_max=[3.0, 1.0, None])
    np.testing.assert_array_equal(P.q_ref, [1.0, 0.2, 0.3])


def test_null_inside_a_bound_list_means_unbounded() -> None:
    P = make(q_min=[None, -1.0, None], q_max=[1.0, None, None], lam_max=[None, 2.0])
    np.testing.assert_array_equal(P.q_min, [-np.inf, -1.0, -np.inf])
    np.testing.assert_array_equal(P.q_max, [1.0, np.inf, np.inf])
    np.testing.assert_array_equal(P.lam_max, [np.inf, 2.0])


def test_diagonal_weights_become_matrices() -> None:
    P = make(M=[1.0, 2.0, 3.0], Lambda=[0.0, 0.5, 0.0])
    np.testing.assert_array_equal(P.M, np.diag([1.0, 2.0, 3.0]))
    np.testing.assert_array_equal(P.Lambda, np.diag([0.0, 0.5, 0.0]))


def test_a_single_row_of_g_may_be_given_flat() -> None:
    P = make(G=[1.0, 0.0, 0.0], h=[1.0])
    assert P.G.shape == (1, 3)
    assert P.row_labels == ("row 1",)


def test_problem_is_frozen_and_replace_validates_again() -> None:
    P = make()
    with pytest.raises(dataclasses.FrozenInstanceError):
        P.q0 = np.zeros(3)  # type: ignore[misc]
    Q = P.replace(dw=[0.0, 0.02])
    np.testing.assert_array_equal(Q.dw, [0.0, 0.02])
    np.testing.assert_array_equal(P.dw, [0.01, 0.0])
    with pytest.raises(InvalidProblemError) as info:
        P.replace(q_min=[1.0, 1.0, 1.0], q_max=[0.0, 0.0, 0.0])
    assert info.value.field == "q_min"


def test_step_bounds_keep_the_tighter_limit_and_name_it() -> None:
    P = make(
        q0=[0.0, 0.0, 0.0],
        q_min=[-0.005, -1.0, -0.01],
        q_max=[1.0, 0.003, 0.01],
        dq_min=[-0.01, -0.01, -0.01],
        dq_max=[0.01, 0.01, 0.01],
        dq_max_kind=["velocity limit", "acceleration limit", "velocity limit"],
    )
    lower, upper, lower_labels, upper_labels = P.step_bounds()
    np.testing.assert_array_equal(lower, [-0.005, -0.01, -0.01])
    np.testing.assert_array_equal(upper, [0.01, 0.003, 0.01])
    assert lower_labels == (
        "joint 1 lower end-stop",
        "joint 2 lower velocity limit",
        "joint 3 lower end-stop",  # a tie names the end-stop
    )
    assert upper_labels == (
        "joint 1 upper velocity limit",
        "joint 2 upper end-stop",
        "joint 3 upper end-stop",
    )


def test_step_bounds_are_relative_to_q0() -> None:
    P = make(q0=[1.0, 2.0, 3.0], q_min=[0.5, 1.5, 2.5], q_max=[1.25, 2.5, 3.5])
    lower, upper, _, _ = P.step_bounds()
    np.testing.assert_array_equal(lower, [-0.5, -0.5, -0.5])
    np.testing.assert_array_equal(upper, [0.25, 0.5, 0.5])


def test_labels_use_the_joint_and_row_names() -> None:
    P = make(joint_names=["shoulder", "elbow", "wrist"], G=[[1, 0, 0]], h=[1], row_labels=["wall"])
    assert P.step_bounds()[3][1] == "elbow upper end-stop"
    assert P.row_labels == ("wall",)
    assert P.multiplier_labels() == (
        ("multiplier 1 lower bound", "multiplier 2 lower bound"),
        ("multiplier 1 upper bound", "multiplier 2 upper bound"),
    )


NAN, INF = math.nan, math.inf

#: (field that must be named, changes to the good problem).
BAD_FIELDS = [
    ("J", {"J": [1.0, 2.0, 3.0]}),
    ("J", {"J": [[1.0, 2.0], [3.0]]}),
    ("J", {"J": [[1.0, NAN, 0.0], [0.0, 1.0, 0.0]]}),
    ("J", {"J": [[1.0, INF, 0.0], [0.0, 1.0, 0.0]]}),
    ("J", {"J": "not a matrix"}),
    ("J", {"J": [[]]}),
    ("dw", {"dw": [0.01, 0.0, 0.0]}),
    ("dw", {"dw": [NAN, 0.0]}),
    ("dw", {"dw": [INF, 0.0]}),
    ("dw", {"dw": [None, 0.0]}),
    ("dw", {"dw": {"x": 1}}),
    ("q0", {"q0": [0.0, 0.0]}),
    ("q0", {"q0": [[0.0, 0.0, 0.0]]}),
    ("q0", {"q0": [0.0, -INF, 0.0]}),
    ("q0", {"q0": "abc"}),
    ("q_min", {"q_min": [1.0, 0.0, 0.0], "q_max": [0.0, 1.0, 1.0]}),
    ("q_min", {"q_min": [NAN, 0.0, 0.0]}),
    ("q_min", {"q_min": [0.0, 0.0]}),
    ("q_min", {"q_min": [INF, 0.0, 0.0]}),
    ("q_max", {"q_max": [-INF, 1.0, 1.0]}),
    ("q_max", {"q_max": "high"}),
    ("dq_min", {"dq_min": [0.02, 0.0, 0.0], "dq_max": [0.01, 0.01, 0.01]}),
    ("dq_max", {"dq_max": [0.01, NAN, 0.01]}),
    ("M", {"M": -np.eye(3)}),
    ("M", {"M": [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),
    ("M", {"M": [1.0, 0.0, 1.0]}),
    ("M", {"M": [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),
    ("M", {"M": np.eye(2)}),
    ("M", {"M": [1.0, NAN, 1.0]}),
    ("Lambda", {"Lambda": [-1.0, 0.0, 0.0]}),
    ("Lambda", {"Lambda": [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]}),
    ("Lambda", {"Lambda": [INF, 0.0, 0.0]}),
    ("f", {"f": [0.0, 0.0]}),
    ("f", {"f": [0.0, INF, 0.0]}),
    ("q_ref", {"q_ref": [0.0, NAN, 0.0]}),
    ("lam_min", {"lam_min": [1.0, 1.0], "lam_max": [0.0, 2.0]}),
    ("lam_min", {"lam_min": [0.0, 0.0, 0.0]}),
    ("h", {"G": [[1.0, 0.0, 0.0]]}),
    ("G", {"h": [1.0]}),
    ("G", {"G": [[1.0, 0.0], [0.0, 1.0]], "h": [1.0, 1.0]}),
    ("G", {"G": [[1.0], [0.0], [0.0], [1.0], [0.0], [0.0]], "h": [1.0, 1.0]}),
    ("G", {"G": [[1.0, NAN, 0.0]], "h": [1.0]}),
    ("h", {"G": [[1.0, 0.0, 0.0]], "h": [1.0, 2.0]}),
    ("h", {"G": [[1.0, 0.0, 0.0]], "h": [INF]}),
    ("row_labels", {"G": [[1.0, 0.0, 0.0]], "h": [1.0], "row_labels": ["a", "b"]}),
    ("row_labels", {"G": [[1.0, 0.0, 0.0]], "h": [1.0], "row_labels": 5}),
    ("joint_names", {"joint_names": ["a", "b"]}),
    ("joint_names", {"joint_names": 3}),
    ("k", {"k": -1.0}),
    ("k", {"k": NAN}),
    ("k", {"k": "big"}),
]


@pytest.mark.parametrize(("field", "changes"), BAD_FIELDS, ids=[f for f, _ in BAD_FIELDS])
def test_bad_field_raises_a_value_error_naming_it(field: str, changes: dict[str, object]) -> None:
    with pytest.raises(InvalidProblemError) as info:
        make(**changes)
    err = info.value
    assert isinstance(err, ValueError) and isinstance(err, LpikError)
    assert err.field == field
    assert str(err).startswith(f"{field}: ")
    assert "\n" not in str(err)


@pytest.mark.parametrize("key", ["method", "J", "dw", "q0"])
def test_a_missing_key_is_named(key: str) -> None:
    data = {"method": "lp2", **GOOD}
    del data[key]
    with pytest.raises(InvalidProblemError) as info:
        problem_from_dict(data)
    assert info.value.field == key
    assert "missing" in info.value.reason


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"method": "magic", **GOOD}, "method"),
        ({"method": 3, **GOOD}, "method"),
        ({"method": "nlp", **GOOD}, "method"),
        ({"method": "lp2", "colour": "red", **GOOD}, "colour"),
        ({"method": "lp2", "k": 0.1, **GOOD}, "k"),
        ({"method": "lp2", **GOOD, "J": {"a": 1}}, "J"),
        ({"method": "lp2", **GOOD, "M": 2.0}, "M"),
        ([1, 2, 3], "problem"),
    ],
)
def test_problem_documents_are_validated(data: object, field: str) -> None:
    with pytest.raises(InvalidProblemError) as info:
        problem_from_dict(data)
    assert info.value.field == field


def test_unknown_method_lists_the_available_ones() -> None:
    with pytest.raises(InvalidProblemError, match="available: pinv, weighted, robust"):
        problem_from_dict({"method": "magic", **GOOD})


def test_nlp_in_a_file_points_at_simulate() -> None:
    with pytest.raises(InvalidProblemError, match="simulate"):
        problem_from_dict({"method": "nlp", **GOOD})


DOC = '{"method": "lp2", "J": [[1, 0.5, 0.25], [0, 1, 0.5]], "dw": %s, "q0": %s'


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("{not json", "problem"),
        ("", "problem"),
        (DOC % ("[0.01, 0]", "[0, 0, 0]"), "problem"),  # truncated: no closing brace
        (DOC % ("[1e999, 0]", "[0, 0, 0]") + "}", "dw"),  # overflows to inf
        (DOC % ("[NaN, 0]", "[0, 0, 0]") + "}", "dw"),
        (DOC % ("[0, 0]", "[0, Infinity, 0]") + "}", "q0"),
    ],
    ids=["garbage", "empty", "truncated", "overflow-inf", "nan-literal", "infinity-literal"],
)
def test_load_problem_names_the_key_of_bad_json(tmp_path, text: str, field: str) -> None:
    path = tmp_path / "problem.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InvalidProblemError) as info:
        load_problem(path)
    assert info.value.field == field


def test_load_problem_reports_a_missing_file_and_a_directory(tmp_path) -> None:
    for path in (tmp_path / "absent.json", tmp_path):
        with pytest.raises(InvalidProblemError) as info:
            load_problem(path)
        assert info.value.field == "problem"
        assert str(path) in str(info.value)


def test_load_problem_reads_null_bounds(tmp_path) -> None:
    path = tmp_path / "problem.json"
    doc = {"method": "lp1", **GOOD, "q_min": [None, -1, None], "q_max": [1, None, None]}
    path.write_text(json.dumps(doc), encoding="utf-8")
    method, P = load_problem(path)
    assert method == "lp1"
    np.testing.assert_array_equal(P.q_min, [-np.inf, -1.0, -np.inf])
