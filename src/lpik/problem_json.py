"""Reading one step's problem from the ``lpik solve`` JSON contract (the README lists its keys).

The limits of a problem document are here, as constants (the README quotes
them): :data:`MAX_FILE_BYTES`, :data:`MAX_JSON_DEPTH`, :data:`MAX_JOINTS`,
:data:`MAX_TASK_ROWS`, :data:`MAX_EXTRA_ROWS`; every finite number must also be
at most :data:`lpik.tolerances.MAX_MAGNITUDE` in size (checked by
:class:`~lpik.problem.Problem`). They cover any real robot by far and keep
one solve of the largest problem they allow well under a second and its
memory small, whatever a file holds.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

from lpik.exceptions import InvalidProblemError
from lpik.methods.registry import METHODS, get_method
from lpik.problem import Problem

#: Largest problem file (or standard input) read [bytes]: the largest problem the
#: other caps allow, with dense M, Lambda and G written at full precision, fits.
MAX_FILE_BYTES = 2 * 1024 * 1024
#: Deepest nesting of JSON arrays and objects; a problem needs 3 (object, matrix, row).
MAX_JSON_DEPTH = 8
#: Most joints n (columns of J).
MAX_JOINTS = 128
#: Most task coordinates m (rows of J).
MAX_TASK_ROWS = 48
#: Most extra rows r of ``G q <= h``.
MAX_EXTRA_ROWS = 128

#: Keys every problem file must have.
REQUIRED_KEYS = ("method", "J", "dw", "q0")
#: Keys a problem file may have.
OPTIONAL_KEYS = (
    "q_min",
    "q_max",
    "dq_min",
    "dq_max",
    "M",
    "f",
    "Lambda",
    "q_ref",
    "lam_min",
    "lam_max",
    "k",
    "G",
    "h",
    "row_labels",
    "joint_names",
)


def validate_method(method: Any) -> str:
    """``method`` if it names a method that needs only the problem, else an error listing them."""
    problem_only = [name for name, spec in METHODS.items() if not spec.needs_model]
    if isinstance(method, str) and method in METHODS and method not in problem_only:
        raise InvalidProblemError(
            "method",
            f"{method!r} needs the robot model: use lpik simulate; available here: "
            + ", ".join(problem_only),
        )
    return get_method(method).name


#: Keys whose values are numbers, lists of them or lists of rows of them.
NUMBER_KEYS = (
    "J", "dw", "q0", "q_min", "q_max", "dq_min", "dq_max", "M", "f", "Lambda", "q_ref",
    "lam_min", "lam_max", "k", "G", "h",
)  # fmt: skip
#: Keys whose values are lists of names.
NAME_KEYS = ("row_labels", "joint_names")


class _TooLarge:
    """A JSON number too large for a float64, kept as its text for the message."""

    def __init__(self, text: str) -> None:
        self.text = text if len(text) <= 24 else f"{text[:12]}... ({len(text)} characters)"


def _json_float(text: str) -> float | _TooLarge:
    value = float(text)
    return _TooLarge(text) if value in (float("inf"), float("-inf")) else value


def _json_int(text: str) -> int | _TooLarge:
    if len(text.lstrip("-")) > 309:  # more digits than the largest float64 has
        return _TooLarge(text)
    value = int(text)
    return _TooLarge(text) if abs(value) > sys.float_info.max else value


def _check_numbers(key: str, value: Any) -> None:
    """Raise naming ``key`` unless ``value`` holds only JSON numbers (and null) at its leaves."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, list):
            stack.extend(item)
        elif item is None or type(item) is float:
            continue
        elif type(item) is int:
            if abs(item) > sys.float_info.max:
                raise InvalidProblemError(key, "an integer too large for a float64 (1.8e308)")
        elif isinstance(item, _TooLarge):
            raise InvalidProblemError(
                key, f"{item.text} is too large for a float64 (largest 1.8e308)"
            )
        elif isinstance(item, bool):
            raise InvalidProblemError(key, f"{json.dumps(item)} is not a number")
        elif isinstance(item, str):
            raise InvalidProblemError(
                key, f"the string {item[:20]!r} is not a number (write numbers without quotes)"
            )
        elif isinstance(item, dict):
            raise InvalidProblemError(key, "an object is not a number")
        # anything else (a numpy array from Python) is left to Problem's checks


def _check_names(key: str, value: Any) -> None:
    if isinstance(value, list) and not all(isinstance(v, str) for v in value):
        raise InvalidProblemError(key, "must be a list of strings")


def _check_sizes(data: dict[str, Any]) -> None:
    """Raise naming the key when J or G is larger than the caps allow."""
    J = data["J"]
    if not isinstance(J, list):
        raise InvalidProblemError("J", "must be a list of rows (an m x n matrix)")
    if len(J) > MAX_TASK_ROWS:
        raise InvalidProblemError(
            "J", f"has {len(J)} rows; lpik solve takes at most {MAX_TASK_ROWS} (MAX_TASK_ROWS)"
        )
    n = max((len(row) for row in J if isinstance(row, list)), default=0)
    if n > MAX_JOINTS:
        raise InvalidProblemError(
            "J", f"has {n} columns; lpik solve takes at most {MAX_JOINTS} joints (MAX_JOINTS)"
        )
    G = data.get("G")
    if isinstance(G, list) and len(G) > MAX_EXTRA_ROWS:
        raise InvalidProblemError(
            "G", f"has {len(G)} rows; lpik solve takes at most {MAX_EXTRA_ROWS} (MAX_EXTRA_ROWS)"
        )


def problem_from_dict(data: Any) -> tuple[str, Problem]:
    """Validate a decoded problem document and return ``(method, problem)``.

    Numbers must be JSON numbers (not strings, not ``true``/``false``); ``null``
    is read as in :class:`~lpik.problem.Problem` (unbounded, for a bound). J and
    G must be within :data:`MAX_TASK_ROWS`, :data:`MAX_JOINTS` and
    :data:`MAX_EXTRA_ROWS`.

    Raises:
        InvalidProblemError: (a ``ValueError``) naming the key that is missing, unknown or bad.
    """
    if not isinstance(data, dict):
        raise InvalidProblemError(
            "problem", "must be a JSON object with keys " + ", ".join(REQUIRED_KEYS)
        )
    for key in REQUIRED_KEYS:
        if key not in data:
            raise InvalidProblemError(
                key, "missing (required keys: " + ", ".join(REQUIRED_KEYS) + ")"
            )
    unknown = sorted(set(data) - set(REQUIRED_KEYS) - set(OPTIONAL_KEYS))
    if unknown:
        raise InvalidProblemError(
            unknown[0], "unknown key; valid keys: " + ", ".join(REQUIRED_KEYS + OPTIONAL_KEYS)
        )
    method = validate_method(data["method"])
    if "k" in data and method != "robust":
        raise InvalidProblemError("k", f"only the 'robust' method takes k, not {method!r}")
    for key in ("J", "M", "Lambda", "G"):
        if key in data and data[key] is not None and not isinstance(data[key], list):
            raise InvalidProblemError(
                key, "must be a list of rows (or, for M and Lambda, a diagonal)"
            )
    for key in NUMBER_KEYS:
        if key in data:
            _check_numbers(key, data[key])
    for key in NAME_KEYS:
        if key in data:
            _check_names(key, data[key])
    _check_sizes(data)
    fields = {key: value for key, value in data.items() if key != "method"}
    return method, Problem(**fields)


#: A JSON string or a bracket: what :func:`check_depth` looks at.
_TOKENS = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]')


def check_depth(text: str) -> None:
    """Raise unless arrays and objects in ``text`` nest at most :data:`MAX_JSON_DEPTH` deep.

    Checked before parsing (the parser recurses once per level). The error
    names the top-level key the nesting sits in, when there is one.
    """
    depth, key = 0, "problem"
    for token in _TOKENS.finditer(text):
        char = token.group()
        if char in "[{":
            depth += 1
            if depth > MAX_JSON_DEPTH:
                raise InvalidProblemError(
                    key,
                    f"JSON nested deeper than {MAX_JSON_DEPTH} levels (MAX_JSON_DEPTH; "
                    "a problem needs 3: the object, a matrix, its rows)",
                )
        elif char in "]}":
            depth -= 1
        elif depth == 1:  # a string in the top-level object: a key (or a method's name)
            key = char[1:-1][:40] or "problem"


def read_text(path: str | Path) -> str:
    """The text of a problem file (``-``: standard input), at most :data:`MAX_FILE_BYTES`.

    Raises:
        InvalidProblemError: For a file that cannot be read, is not UTF-8 or is too large.
    """
    name = "standard input" if str(path) == "-" else repr(str(path))
    too_large = InvalidProblemError(
        "problem",
        f"{name} is larger than {MAX_FILE_BYTES} bytes (MAX_FILE_BYTES), the largest "
        "problem file lpik solve reads",
    )
    try:
        if str(path) == "-":
            stream = getattr(sys.stdin, "buffer", None)
            if stream is None:  # a text stream without bytes (a test's StringIO)
                text = sys.stdin.read(MAX_FILE_BYTES + 1)
                if len(text.encode("utf-8", "surrogatepass")) > MAX_FILE_BYTES:
                    raise too_large
                return text
            raw = stream.read(MAX_FILE_BYTES + 1)
        else:
            with open(path, "rb") as file:
                if Path(path).is_file() and Path(path).stat().st_size > MAX_FILE_BYTES:
                    raise too_large
                raw = file.read(MAX_FILE_BYTES + 1)
        if len(raw) > MAX_FILE_BYTES:
            raise too_large
        return raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise InvalidProblemError("problem", f"cannot read {name}: {reason}") from None


def load_problem(path: str | Path) -> tuple[str, Problem]:
    """Read and validate a problem file (``-`` reads standard input).

    Raises:
        InvalidProblemError: For a file beyond the caps, unreadable JSON or a bad key.
    """
    text = read_text(path)
    check_depth(text)
    try:
        # NaN and Infinity (not JSON, but what json.dumps writes for Python floats) are
        # read as floats, so that validation names the key they sit in; numbers too
        # large for a float64 are kept aside for the same reason.
        data = json.loads(text, parse_float=_json_float, parse_int=_json_int)
    except json.JSONDecodeError as exc:
        raise InvalidProblemError(
            "problem", f"unreadable JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from None
    return problem_from_dict(data)
