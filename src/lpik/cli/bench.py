"""``lpik bench``: time lpik against other IK libraries on the same robot, targets and limits.

Prints the medians, 99th percentiles and ratios to the fastest peer of every
case, the first-call (import and compile) costs, and the agreement checks.
``lpik bench --json`` prints a JSON list of records; every record has the
keys ``library``, ``method``, ``what``, ``median_us`` and ``p99_us`` (``null``
for records that are not timings) and ``kind`` (``timing``, ``first call``,
``agreement``, ``skipped`` or ``environment``), plus kind-specific keys.
Peers (Drake, pink, mink, the Robotics Toolbox) run when installed:
``pip install "lpik[bench]"``. The arm is a bundled one (``--robot NAME``,
default ``panda``) or any URDF's chain (``--urdf FILE --tip LINK [--base LINK]``,
read as every command reads it: :func:`lpik.cli.robots.add_robot_arguments`).
"""

from __future__ import annotations

import argparse
import json
import sys

from lpik.cli import as_option


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik bench``."""
    from lpik.cli.robots import add_robot_arguments

    parser = sub.add_parser(
        "bench",
        help="time lpik's methods and other IK libraries on the same steps",
        description="Interleaved timing of lpik (every method, the fused compiled step, "
        "batches, FK + Jacobian) and, when installed, Drake, pink, mink and the Robotics "
        "Toolbox on the same robot, configurations and targets; agreement checks; "
        "first-call costs.",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON list of records")
    parser.add_argument(
        "--quick", action="store_true", help="a smoke test: small workload, 3 rounds"
    )
    parser.add_argument("--rounds", type=int, default=None, metavar="N", help="timing rounds")
    add_robot_arguments(
        parser,
        default="panda",
        urdf_help="any arm from a URDF file (with --tip): its chain from --base to --tip",
    )
    parser.add_argument(
        "--peers",
        default=None,
        metavar="LIST",
        help="comma-separated peers to try (drake,pink,mink,rtb; 'none' for lpik only)",
    )
    parser.add_argument(
        "--no-cold",
        action="store_true",
        help="skip timing a cold compile of the kernels (a fresh process, empty cache)",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark and print it; a bad ``--urdf``, ``--tip`` or ``--base`` raises first."""
    from lpik.cli.progress import compile_progress
    from lpik.cli.robots import robot_from_arguments
    from lpik_bench.runner import run_benchmark
    from lpik_bench.table import text_report
    from lpik_bench.workload import ArmFile

    robot = robot_from_arguments(args)  # the file and its links checked before the run
    if not isinstance(robot, str):
        robot = ArmFile(args.urdf, args.tip, args.base)

    peers = None
    if args.peers is not None:
        peers = () if args.peers == "none" else tuple(p for p in args.peers.split(",") if p)
    command = "lpik " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["bench"] else "lpik bench"
    try:
        with compile_progress("lpik bench"):  # a first run compiles the compiled path
            records = run_benchmark(
                robot,
                quick=args.quick,
                rounds=args.rounds,
                peers=peers,
                cold=False if args.no_cold else None,
                command=command,
            )
    except ValueError as exc:  # the runner names its arguments; the command line, its options
        raise ValueError(as_option(str(exc), ("rounds", "peers"))) from None
    dicts = [r.to_dict() for r in records]
    if args.json:
        print(json.dumps(dicts, indent=1, allow_nan=False, default=_jsonable))
    else:
        print(text_report(dicts), end="")
    return 0


def _jsonable(value: object) -> object:
    """Numpy scalars as plain numbers (``json.dumps``'s ``default``)."""
    return value.item() if hasattr(value, "item") else str(value)
