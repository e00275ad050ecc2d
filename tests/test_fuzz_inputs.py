"""Fuzzing ``lpik solve`` with malformed problem files: an answer, or one line and exit 2.

Whatever a file holds (wrong types, deep nesting, numbers no float64 holds,
NaN and Infinity tokens, numeric strings, booleans, missing and unknown keys,
wrong shapes, crossed bounds, values beyond the caps), ``lpik solve`` either
answers (exit 0, the result as JSON on stdout, nothing on stderr) or refuses
(exit 2, nothing on stdout, exactly one line on stderr starting with
``lpik: error:``). No other exit status, no traceback, no warning.
"""

from __future__ import annotations

import contextlib
import io
import json
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from cli_documents import GOOD, OUTPUT_KEYS
from core_strategies import examples
from lpik.cli.main import main
from lpik.problem_json import OPTIONAL_KEYS, REQUIRED_KEYS
from lpik.result import STATUSES

#: Number tokens that Python's json.dumps never writes, spliced into the text by name.
RAW_NUMBERS = {
    "1e400": "1e400",
    "-1e400": "-1e400",
    "10**400": "1" + "0" * 400,
    "-(10**5000 - 1)": "-" + "9" * 5000,
    "NaN": "NaN",
    "Infinity": "Infinity",
    "-Infinity": "-Infinity",
    "1e-400": "1e-400",
    "-0": "-0",
    "1E12": "1E12",
    "1e13": "1e13",
    "max float64": "1.7976931348623157e308",
}
RAW = st.sampled_from(sorted(RAW_NUMBERS)).map(lambda name: f"@raw:{name}@")

NUMBERS = st.one_of(
    st.floats(-5, 5, allow_nan=False),
    st.integers(-3, 3),
    st.sampled_from([1e12, -1e12, 1.1e12, 1e200, -1e300, 5e-324]),
)
LEAVES = st.one_of(
    NUMBERS,
    RAW,
    st.none(),
    st.booleans(),
    st.sampled_from(["1.0", "0", "", "lp2", "inf", "nan"]),
    st.text(max_size=3),
)
VALUES = st.recursive(
    LEAVES,
    lambda children: (
        st.lists(children, max_size=5) | st.dictionaries(st.text(max_size=3), children, max_size=2)
    ),
    max_leaves=15,
)
PLAUSIBLE = st.one_of(
    st.lists(st.one_of(NUMBERS, RAW, st.none()), min_size=1, max_size=5),
    st.lists(st.lists(st.one_of(NUMBERS, RAW), min_size=1, max_size=5), min_size=1, max_size=4),
    st.lists(st.lists(NUMBERS, min_size=4, max_size=4), min_size=1, max_size=3),
    st.lists(NUMBERS, min_size=4, max_size=4),  # a vector of the right length, any values
    NUMBERS,
)
KEYS = st.sampled_from(REQUIRED_KEYS + OPTIONAL_KEYS + ("colour", "METHOD", ""))
METHOD_NAMES = st.sampled_from(["lp2", "lp1", "l1", "pinv", "weighted", "robust", "nlp", "x"])


#: Mostly ordinary numbers, sometimes one at or beyond the size cap.
SHAPED_NUMBERS = st.one_of(st.floats(-2, 2), st.floats(-2, 2), st.floats(-2, 2), NUMBERS)


def _vector(size: int, *, bound: bool = False) -> st.SearchStrategy[list]:
    entries = st.one_of(SHAPED_NUMBERS, st.none()) if bound else SHAPED_NUMBERS
    return st.lists(entries, min_size=size, max_size=size)


#: Values of the right shape for each key (n = 4 joints, m = 2 task rows), any numbers:
#: crossed bounds, an indefinite M, a huge k, numbers at and beyond the size cap.
RIGHT_SHAPE = {
    "J": st.lists(_vector(4), min_size=2, max_size=2),
    "dw": _vector(2),
    "q0": _vector(4),
    "q_min": _vector(4, bound=True),
    "q_max": _vector(4, bound=True),
    "dq_min": _vector(4, bound=True),
    "dq_max": _vector(4, bound=True),
    "M": _vector(4),
    "f": _vector(4),
    "Lambda": _vector(4),
    "q_ref": _vector(4),
    "lam_min": _vector(2, bound=True),
    "lam_max": _vector(2, bound=True),
    "k": SHAPED_NUMBERS,
    "G": st.lists(_vector(4), min_size=1, max_size=1),
    "h": _vector(1),
    "row_labels": st.just(["obstacle"]),
    "joint_names": st.just(["a", "b", "c", "d"]),
}


@st.composite
def documents(draw: st.DrawFn) -> str:
    """The text of a problem file: a good one changed in a few places, or something else."""
    kind = draw(
        st.sampled_from(["shaped", "shaped", "changed", "changed", "any", "deep", "truncated"])
    )
    if kind == "any":
        return _text(draw(VALUES))
    data: dict[str, object] = {**GOOD, "method": draw(METHOD_NAMES)}
    if kind == "shaped":  # right shapes, any numbers: mostly answers
        data["method"] = draw(st.sampled_from(["lp2", "lp1", "l1", "pinv", "weighted", "robust"]))
        for key in draw(st.lists(st.sampled_from(sorted(RIGHT_SHAPE)), max_size=4)):
            data[key] = draw(RIGHT_SHAPE[key])
        return _text(data)
    for _ in range(draw(st.integers(1, 3))):
        key = draw(KEYS)
        action = draw(st.sampled_from(["set", "set", "plausible", "delete", "nest"]))
        if action == "delete":
            data.pop(key, None)
        elif action == "nest":
            depth = draw(st.sampled_from([2, 5, 9, 40]))
            data[key] = _Nested(depth, draw(PLAUSIBLE))
        else:
            data[key] = draw(VALUES if action == "set" else PLAUSIBLE)
    text = _text(data)
    if kind == "deep":
        depth = draw(st.sampled_from([9, 1000, 100_000]))
        return "[" * depth + text + "]" * draw(st.sampled_from([0, depth]))
    if kind == "truncated":
        return text[: draw(st.integers(0, max(0, len(text) - 1)))]
    return text


class _Nested:
    """A value wrapped in ``depth`` single-element lists (written by :func:`_text`)."""

    def __init__(self, depth: int, value: object) -> None:
        self.depth, self.value = depth, value


def _text(value: object) -> str:
    """JSON text of ``value``, with the raw number tokens and the nesting spliced in."""

    def plain(v: object) -> object:
        if isinstance(v, _Nested):
            return "@open:" + str(v.depth) + "@" + json.dumps(plain(v.value)) + "@close@"
        if isinstance(v, list):
            return [plain(x) for x in v]
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        return v

    text = json.dumps(plain(value))
    while '"@open:' in text:  # each wrapped value is one JSON string: unwrap it
        start = text.index('"@open:')
        end = text.index('@close@"', start) + len('@close@"')
        depth, body = json.loads(text[start:end])[len("@open:") :].split("@", 1)
        body = body[: -len("@close@")]
        text = text[:start] + "[" * int(depth) + body + "]" * int(depth) + text[end:]
    for name, token in RAW_NUMBERS.items():
        text = text.replace(f'"@raw:{name}@"', token)
    return text


@pytest.fixture(scope="module")
def problem_file(tmp_path_factory) -> Path:  # type: ignore[no-untyped-def]
    return tmp_path_factory.mktemp("fuzz") / "problem.json"


@settings(
    max_examples=examples(150),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(text=documents())
# A subnormal command: the ratio test's rates are below its tolerance, and
# dividing by them once overflowed (a warning on an otherwise good answer).
@example(
    text='{"method": "lp2", "J": [[-0.866, 0.0, 0.5, 0.5], [3.232, 2.732, 1.866, 0.866]],'
    ' "dw": [0.0, 2.225073858507e-311], "q0": [1.047, -0.524, -0.524, -0.524],'
    ' "q_min": [-3.14, -3.14, -3.14, -3.14], "q_max": [1.658, 3.14, 3.14, 3.14],'
    ' "dq_min": [-0.01, -0.01, -0.01, -0.01], "dq_max": [0.01, 0.01, 0.01, 0.01]}'
)
def test_any_problem_file_is_an_answer_or_one_line_and_exit_2(
    problem_file: Path, text: str
) -> None:
    problem_file.write_text(text, encoding="utf-8")
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["solve", str(problem_file)])
    assert not caught, [str(w.message) for w in caught]
    stdout, stderr = out.getvalue(), err.getvalue()
    event(f"exit {code}")
    assert code in (0, 2), stderr
    if code == 0:
        assert stderr == ""
        data = json.loads(stdout)
        assert set(data) == OUTPUT_KEYS
        assert data["status"] in STATUSES
        assert 0.0 <= data["p"] <= 1.0
    else:
        assert stdout == ""
        lines = stderr.splitlines()
        assert len(lines) == 1 and stderr.endswith("\n"), stderr
        assert lines[0].startswith("lpik: error: "), lines[0]


def test_the_text_builder_splices_raw_numbers_and_nesting() -> None:
    text = _text({"dw": ["@raw:1e400@", _Nested(3, [1, "@raw:NaN@"])]})
    assert text == '{"dw": [1e400, [[[[1, NaN]]]]]}'
    assert _text(["@raw:10**400@"]) == "[1" + "0" * 400 + "]"
