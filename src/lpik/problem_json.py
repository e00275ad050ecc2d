"""Reading one step's problem from the ``lpik solve`` JSON contract (the README lists its keys)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from lpik.exceptions import InvalidProblemError
from lpik.methods.registry import METHODS, get_method
from lpik.problem import Problem

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


def problem_from_dict(data: Any) -> tuple[str, Problem]:
    """Validate a decoded problem document and return ``(method, problem)``.

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
    fields = {key: value for key, value in data.items() if key != "method"}
    return method, Problem(**fields)


def load_problem(path: str | Path) -> tuple[str, Problem]:
    """Read and validate a problem file (``-`` reads standard input).

    Raises:
        InvalidProblemError: For unreadable JSON or a bad key.
    """
    import sys

    try:
        text = sys.stdin.read() if str(path) == "-" else Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise InvalidProblemError("problem", f"cannot read {str(path)!r}: {reason}") from None
    try:
        # NaN and Infinity (not JSON, but what json.dumps writes for Python floats) are
        # read as floats, so that validation names the key they sit in.
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InvalidProblemError(
            "problem", f"unreadable JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from None
    return problem_from_dict(data)
