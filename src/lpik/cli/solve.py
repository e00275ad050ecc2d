"""``lpik solve PROBLEM.json``: one step, printed as JSON (the contract the README documents)."""

from __future__ import annotations

import argparse
import json
import sys
from importlib import resources
from pathlib import Path

#: Largest --indent of the JSON output (spaces).
MAX_INDENT = 16


def example_names() -> list[str]:
    """Names of the bundled example problems."""
    root = resources.files("lpik") / "data" / "examples"
    return sorted(p.name.removesuffix(".json") for p in root.iterdir() if p.name.endswith(".json"))


def example_path(name: str) -> Path:
    """Path of a bundled example problem; ``ValueError`` listing the names when unknown."""
    names = example_names()
    if name not in names:
        raise ValueError(f"--example: unknown example {name!r}; available: {', '.join(names)}")
    return Path(str(resources.files("lpik") / "data" / "examples" / f"{name}.json"))


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik solve``."""
    parser = sub.add_parser(
        "solve",
        help="solve one step given as JSON and print the result as JSON",
        description="Solve one IK step. Input keys: method, J, dw, q0 and optional q_min, q_max, "
        "dq_min, dq_max, M, f, Lambda, q_ref, lam_min, lam_max, k, G, h, row_labels. "
        "Output keys: q, dq, p, lam, status, binding, pull_scale.",
    )
    parser.add_argument("problem", nargs="?", help="problem file (JSON); '-' reads stdin")
    parser.add_argument(
        "--example",
        metavar="NAME",
        help="solve a bundled example problem instead (see --list-examples)",
    )
    parser.add_argument("--list-examples", action="store_true", help="list bundled examples")
    parser.add_argument("--method", help="override the file's method")
    parser.add_argument(
        "--indent",
        type=int,
        default=None,
        help=f"indent the JSON output by this many spaces (0 to {MAX_INDENT}; default: one line)",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Solve and print; input errors propagate as ``ValueError`` (exit 2 in main)."""
    from lpik.methods import solve
    from lpik.problem_json import load_problem, validate_method

    if args.list_examples:
        print("\n".join(example_names()))
        return 0
    if args.indent is not None and not 0 <= args.indent <= MAX_INDENT:
        raise ValueError(f"--indent: must be in 0..{MAX_INDENT}, got {args.indent}")
    if (args.problem is None) == (args.example is None):
        raise ValueError("problem: give exactly one of PROBLEM.json or --example NAME")
    path = example_path(args.example) if args.example else args.problem
    method, problem = load_problem(path)
    if args.method is not None:
        method = validate_method(args.method)
    result = solve(problem, method)
    sys.stdout.write(json.dumps(result.to_dict(), indent=args.indent, allow_nan=False) + "\n")
    return 0
