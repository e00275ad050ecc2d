"""``lpik solve``: its JSON contract, in-process and as a real command."""

from __future__ import annotations

import contextlib
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cli_documents import GOOD, LPIK, OUTPUT_KEYS
from core_strategies import examples
from lpik.cli.main import main
from lpik.cli.solve import example_names
from lpik.exceptions import InvalidProblemError
from lpik.methods import METHODS, solve
from lpik.problem_json import OPTIONAL_KEYS, REQUIRED_KEYS, problem_from_dict
from lpik.result import STATUSES


def doc(**changes: object) -> str:
    """The good document with some keys changed (a value of ``...`` deletes the key)."""
    data = {k: v for k, v in {**GOOD, **changes}.items() if v is not ...}
    return json.dumps(data)


#: (id, file text or None for no file, extra arguments, key the error line must name)
BAD_INPUTS = [
    ("missing-key", doc(dw=...), [], "dw"),
    ("missing-method", doc(method=...), [], "method"),
    ("wrong-shape", doc(dw=[0.0, 0.0, 0.0]), [], "dw"),
    ("wrong-shape-matrix", doc(J=[[1.0, 2.0]]), [], "dw"),
    ("nan", doc(dw=[math.nan, 0.0]), [], "dw"),
    ("inf", doc(q0=[1e999, 0.0, 0.0, 0.0]), [], "q0"),
    ("null-where-a-number-is-needed", doc(q0=[None, 0.0, 0.0, 0.0]), [], "q0"),
    ("q_min-above-q_max", doc(q_min=[2.0, -3.0, -3.0, -3.0]), [], "q_min"),
    ("M-not-positive-definite", doc(M=[1.0, -1.0, 1.0, 1.0]), [], "M"),
    ("Lambda-not-psd", doc(Lambda=[0.0, -0.5, 0.0, 0.0]), [], "Lambda"),
    ("unknown-method", doc(method="newton"), [], "method"),
    ("nlp-needs-a-model", doc(method="nlp"), [], "method"),
    ("unknown-key", doc(colour="red"), [], "colour"),
    ("labels-not-a-list", doc(G=[[1.0, 0, 0, 0]], h=[2.0], row_labels=7), [], "row_labels"),
    ("unreadable-json", '{"method": "lp2", "J": [[1, 2]', [], "problem"),
    ("not-an-object", "[1, 2, 3]", [], "problem"),
    ("bad-method-override", doc(), ["--method", "newton"], "method"),
    ("no-problem", None, [], "problem"),
    ("missing-file", None, ["does-not-exist.json"], "problem"),
    ("unknown-example", None, ["--example", "nope"], "--example"),
]


#: The cases of the error contract, also run through the installed command.
COMMAND_CASES = (
    "missing-key",
    "wrong-shape",
    "nan",
    "inf",
    "q_min-above-q_max",
    "M-not-positive-definite",
    "Lambda-not-psd",
    "unknown-method",
    "unreadable-json",
)
COMMAND_BAD_INPUTS = [c for c in BAD_INPUTS if c[0] in COMMAND_CASES]


def arguments(tmp_path: Path, text: str | None, extra: list[str]) -> list[str]:
    if text is None:
        return ["solve", *extra]
    path = tmp_path / "problem.json"
    path.write_text(text, encoding="utf-8")
    return ["solve", str(path), *extra]


def assert_one_line_naming(key: str, code: int, out: str, err: str) -> None:
    assert code == 2, err
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0].startswith("lpik: error: ")
    assert f"{key}:" in lines[0] or f"{key} " in lines[0], lines[0]


def assert_result_json(out: str, n: int, m: int) -> dict[str, object]:
    data = json.loads(out)
    assert set(data) == OUTPUT_KEYS
    assert isinstance(data["q"], list) and len(data["q"]) == n
    assert isinstance(data["dq"], list) and len(data["dq"]) == n
    assert isinstance(data["p"], float) and 0.0 <= data["p"] <= 1.0
    assert data["lam"] is None or len(data["lam"]) == m
    assert data["status"] in STATUSES
    assert data["binding"] is None or isinstance(data["binding"], str)
    return data


# --- in-process ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "extra", "key"), [c[1:] for c in BAD_INPUTS], ids=[c[0] for c in BAD_INPUTS]
)
def test_bad_input_is_one_line_naming_the_key(tmp_path, capsys, text, extra, key) -> None:  # type: ignore[no-untyped-def]
    code = main(arguments(tmp_path, text, extra))
    out, err = capsys.readouterr()
    assert_one_line_naming(key, code, out, err)


@pytest.mark.parametrize("name", example_names())
def test_every_bundled_example_solves(capsys, name: str) -> None:
    assert main(["solve", "--example", name]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    data = assert_result_json(out, 4, 2)
    assert data["status"] == "optimal"


def test_the_examples_are_listed(capsys) -> None:
    assert main(["solve", "--list-examples"]) == 0
    out, _ = capsys.readouterr()
    assert out.split() == example_names()
    assert {"pull-in-step", "joint1-at-end-stop", "near-singularity-bounded"} <= set(out.split())


def test_null_inside_q_min_means_unbounded(tmp_path, capsys) -> None:
    text = doc(q_min=[None, -3.14, None, None], lam_max=[None, 1.0])
    assert main(arguments(tmp_path, text, [])) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert assert_result_json(out, 4, 2)["status"] == "optimal"


@pytest.mark.parametrize("method", [m for m, spec in METHODS.items() if not spec.needs_model])
def test_every_method_can_be_asked_for(tmp_path, capsys, method: str) -> None:
    assert main(arguments(tmp_path, doc(), ["--method", method, "--indent", "1"])) == 0
    out, _ = capsys.readouterr()
    data = assert_result_json(out, 4, 2)
    if method in ("lp1", "l1"):
        assert data["lam"] is None


def test_the_result_is_the_library_s(tmp_path, capsys) -> None:
    text = doc(dw=[-0.05, 0.02])
    assert main(arguments(tmp_path, text, [])) == 0
    out, _ = capsys.readouterr()
    method, problem = problem_from_dict(json.loads(text))
    assert json.loads(out) == solve(problem, method).to_dict()


def test_stdin_is_read_for_a_dash(monkeypatch, capsys) -> None:
    monkeypatch.setattr(sys, "stdin", io.StringIO(doc()))
    assert main(["solve", "-"]) == 0
    out, _ = capsys.readouterr()
    assert_result_json(out, 4, 2)


def test_a_recovering_step_is_exit_0(tmp_path, capsys) -> None:
    text = doc(q0=[3.0, -0.524, -0.524, -0.524])  # 1.3 rad past joint 1's end-stop
    assert main(arguments(tmp_path, text, [])) == 0
    out, _ = capsys.readouterr()
    data = assert_result_json(out, 4, 2)
    assert data["status"] == "recovering" and data["binding"] == "joint 1 upper end-stop"


def test_an_infeasible_step_is_still_exit_0(tmp_path, capsys) -> None:
    text = doc(G=[[1.0, 0.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0]], h=[-1.0, -1.0])
    assert main(arguments(tmp_path, text, [])) == 0
    out, _ = capsys.readouterr()
    data = assert_result_json(out, 4, 2)
    assert data["status"] == "infeasible" and data["p"] == 0.0


# --- fuzzing the input ---------------------------------------------------------------------

JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-5, 5)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=4),
    lambda children: (
        st.lists(children, max_size=5) | st.dictionaries(st.text(max_size=3), children, max_size=2)
    ),
    max_leaves=12,
)
NUMBERS = st.floats(-5, 5, allow_nan=False)
PLAUSIBLE = st.one_of(
    st.lists(NUMBERS, min_size=1, max_size=5),
    st.lists(st.lists(NUMBERS, min_size=1, max_size=5), min_size=1, max_size=3),
    st.lists(st.one_of(st.none(), NUMBERS), min_size=4, max_size=4),
    NUMBERS,
)


@settings(max_examples=examples(300))
@given(
    key=st.sampled_from(REQUIRED_KEYS + OPTIONAL_KEYS),
    value=st.one_of(JSON_VALUES, PLAUSIBLE, st.just(...)),
    method=st.sampled_from(list(METHODS)),
)
def test_any_json_is_an_answer_or_one_line_naming_a_key(
    key: str, value: object, method: str
) -> None:
    data = {**GOOD, "method": method}
    if value is ...:
        data.pop(key, None)
    else:
        data[key] = value
    try:
        problem_method, problem = problem_from_dict(json.loads(json.dumps(data)))
    except InvalidProblemError as exc:
        assert "\n" not in str(exc)
        expected_error = exc.field
    else:
        expected_error = None
        res = solve(problem, problem_method)
        assert res.status in STATUSES

    out, err = io.StringIO(), io.StringIO()
    stdin = sys.stdin
    try:
        sys.stdin = io.StringIO(json.dumps(data))
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["solve", "-"])
    finally:
        sys.stdin = stdin
    if expected_error is None:
        assert code == 0, err.getvalue()
        assert_result_json(out.getvalue(), problem.n, problem.m)
    else:
        assert_one_line_naming(expected_error, code, out.getvalue(), err.getvalue())


# --- the installed command -------------------------------------------------------------------


@pytest.fixture(scope="module")
def command_runs(tmp_path_factory) -> dict[str, subprocess.CompletedProcess[str]]:
    """Every command-line case run by the installed ``lpik``, all started at once."""
    tmp = tmp_path_factory.mktemp("cli")
    cases: dict[str, list[str]] = {}
    for case_id, text, extra, _ in COMMAND_BAD_INPUTS:
        folder = tmp / case_id
        folder.mkdir()
        cases[case_id] = arguments(folder, text, extra)
    for name in example_names():
        cases[f"example:{name}"] = ["solve", "--example", name]
    null_q_min = tmp / "null-q-min.json"
    null_q_min.write_text(doc(q_min=[None, -3.14, None, None]), encoding="utf-8")
    cases["null-q_min"] = ["solve", str(null_q_min)]
    procs = {
        case_id: subprocess.Popen(
            [str(LPIK), *args], cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        for case_id, args in cases.items()
    }
    runs = {}
    for case_id, proc in procs.items():
        out, err = proc.communicate(timeout=120)
        runs[case_id] = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    return runs


@pytest.mark.parametrize(
    ("case_id", "key"),
    [(c[0], c[3]) for c in COMMAND_BAD_INPUTS],
    ids=[c[0] for c in COMMAND_BAD_INPUTS],
)
def test_command_bad_input_exits_2_with_one_line(command_runs, case_id: str, key: str) -> None:  # type: ignore[no-untyped-def]
    run = command_runs[case_id]
    assert_one_line_naming(key, run.returncode, run.stdout, run.stderr)


@pytest.mark.parametrize("case_id", [f"example:{n}" for n in example_names()] + ["null-q_min"])
def test_command_solves_examples_and_null_bounds(command_runs, case_id: str) -> None:  # type: ignore[no-untyped-def]
    run = command_runs[case_id]
    assert run.returncode == 0, run.stderr
    assert run.stderr == ""
    assert_result_json(run.stdout, 4, 2)


def test_command_lists_the_examples() -> None:
    run = subprocess.run(
        [str(LPIK), "solve", "--list-examples"], capture_output=True, text=True, check=False
    )
    assert run.returncode == 0
    assert run.stdout.split() == example_names()


@pytest.mark.parametrize("method", ["lp1", "l1", "lp2"])
def test_the_real_command_prints_only_json_on_stdout(tmp_path: Path, method: str) -> None:
    """stdout is the JSON document and nothing else: no solver banner or log, at the fd level."""
    path = tmp_path / "step.json"
    path.write_text(doc(method=method, dq_min=[-0.001] * 4, dq_max=[0.001] * 4))
    run = subprocess.run(
        [str(LPIK), "solve", str(path)], capture_output=True, text=True, check=False
    )
    assert (run.returncode, run.stderr) == (0, "")
    assert set(json.loads(run.stdout)) == OUTPUT_KEYS
    assert run.stdout.count("\n") == 1
