"""The public surface of the core: exports that resolve, errors with one root, the result."""

from __future__ import annotations

import importlib
import inspect
from pathlib import Path

import numpy as np
import pytest
import tomllib

import lpik
from lpik import check
from lpik import result as st
from lpik.exceptions import InvalidProblemError, LpikError, MissingBackendError
from lpik.methods import METHODS, solve
from lpik.problem import Problem

ROOT = Path(__file__).resolve().parents[1]

#: The core's modules (the ones this suite owns).
CORE_MODULES = [
    "lpik",
    "lpik.exceptions",
    "lpik.problem",
    "lpik.result",
    "lpik.check",
    "lpik.labels",
    "lpik.tolerances",
    "lpik.highs",
    "lpik.limits",
    "lpik.methods",
    "lpik.methods.classical",
    "lpik.methods.lp1",
    "lpik.methods.l1",
    "lpik.methods.lp2",
    "lpik.methods.nlp",
    "lpik.methods.registry",
    "lpik.robots",
    "lpik.robots.planar",
    "lpik.problem_json",
    "lpik.cli.main",
    "lpik.cli.solve",
    "lpik.control",
    "lpik.paper",
]


@pytest.mark.parametrize("name", CORE_MODULES)
def test_all_names_resolve(name: str) -> None:
    module = importlib.import_module(name)
    exported = getattr(module, "__all__", [])
    assert len(exported) == len(set(exported)), "duplicate names in __all__"
    for item in exported:
        assert hasattr(module, item), f"{name}.__all__ names {item!r}, which does not exist"


def test_version_matches_the_package_metadata() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert lpik.__version__ == meta["project"]["version"]


def test_bundled_examples_are_package_data() -> None:
    # A wheel only carries the files that [tool.setuptools.package-data] names.
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = meta["tool"]["setuptools"]["package-data"]["lpik"]
    package = ROOT / "src" / "lpik"
    examples = sorted((package / "data" / "examples").glob("*.json"))
    assert examples
    shipped = {found for pattern in patterns for found in package.glob(pattern)}
    for path in examples:
        assert path in shipped, f"{path.relative_to(package)} is not matched by {patterns}"
    assert "py.typed" in patterns


@pytest.mark.parametrize("method", list(METHODS))
def test_every_method_cites_the_paper(method: str) -> None:
    doc = inspect.getdoc(METHODS[method].function) or ""
    assert "eq" in doc or "sec." in doc, method


@pytest.mark.parametrize("bad", ["newton", "", "LP2", None, ["lp2"]])
def test_solve_refuses_an_unknown_method_naming_the_field(bad: object) -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[0.1], q0=[0.0, 0.0])
    with pytest.raises(InvalidProblemError) as info:
        solve(P, bad)  # type: ignore[arg-type]
    assert isinstance(info.value, ValueError)
    assert info.value.field == "method"
    assert "lp2" in str(info.value)  # lists the available methods


def test_exceptions_share_one_root() -> None:
    assert issubclass(InvalidProblemError, LpikError) and issubclass(
        InvalidProblemError, ValueError
    )
    err = MissingBackendError("plots", "plot")
    assert isinstance(err, LpikError) and isinstance(err, ImportError)
    assert 'pip install "lpik[plot]"' in str(err)
    bad = InvalidProblemError("q0", "must be finite")
    assert (bad.field, bad.reason, str(bad)) == ("q0", "must be finite", "q0: must be finite")


def test_statuses_are_documented_and_moving_ones_are_few() -> None:
    for word in (
        st.OPTIMAL,
        st.SCALED,
        st.VIOLATES_LIMITS,
        st.INFEASIBLE,
        st.SINGULAR,
        st.LIMIT_REACHED,
        st.SOLVER_ERROR,
        st.CHECK_FAILED,
        st.RECOVERING,
        st.OFF_DIRECTION,
    ):
        assert st.STATUSES[word]
    assert st.MOVING == {
        st.OPTIMAL, st.SCALED, st.RECOVERING, st.OFF_DIRECTION, st.VIOLATES_LIMITS
    }  # fmt: skip


def test_safe_step_and_result_json() -> None:
    P = Problem(J=[[1.0, 1.0]], dw=[0.1], q0=[0.5, -0.5])
    res = st.safe_step(P, "lp2", st.SOLVER_ERROR, "because")
    assert not res.moved
    assert res.to_dict() == {
        "q": [0.5, -0.5],
        "dq": [0.0, 0.0],
        "p": 0.0,
        "lam": None,
        "status": "solver_error",
        "binding": "because",
        "pull_scale": 1.0,
    }
    res.q[0] = 9.0  # a copy: the problem is untouched
    assert P.q0[0] == 0.5


def test_check_step_catches_each_kind_of_failure() -> None:
    P = Problem(
        J=[[1.0, 1.0]],
        dw=[1.0],
        q0=[0.0, 0.0],
        dq_max=[0.5, 0.5],
        lam_max=[1.0],
        G=[[1, 0]],
        h=[0.4],
    )
    ok = np.array([0.25, 0.25])
    assert check.check_step(P, ok, 0.5, np.array([0.0])) is None
    assert "outside [0, 1]" in check.check_step(P, ok, 1.5, None)
    assert "non-finite" in check.check_step(P, np.array([np.nan, 0.0]), 0.0, None)
    assert "joint 2 upper" in check.check_step(P, np.array([-0.1, 0.6]), 0.5, None)
    assert "multiplier 1 upper" in check.check_step(P, ok, 0.5, np.array([2.0]))
    assert "row 1" in check.check_step(P, np.array([0.45, 0.05]), 0.5, None)
    assert "J dq != p dw" in check.check_step(P, ok, 0.4, None)


def test_the_top_level_exports_one_step() -> None:
    assert lpik.solve is solve and lpik.Problem is Problem
    res = lpik.solve(lpik.Problem(J=[[1.0, 1.0]], dw=[0.1], q0=[0.0, 0.0]), "lp2")
    assert isinstance(res, lpik.Result)
    assert res.status == "optimal" and res.p == 1.0
