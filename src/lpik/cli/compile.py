"""``lpik compile``: compile every kernel of the compiled path now (or load it from the cache).

Prints one line per kernel: what it does, where it came from (``compiled``,
``disk cache`` or ``in memory``) and the seconds it took, then numba's cache
folder. ``lpik compile --json`` prints a JSON list of objects with the keys
``name``, ``source``, ``seconds`` and ``cache_path``. Run it once where lpik
is deployed (e.g. while building a container image) so that a controller's
first start does not wait for the compiler.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import asdict


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik compile``."""
    parser = sub.add_parser(
        "compile",
        help="compile (or load from numba's disk cache) every kernel of lpik.fast now",
        description="Compile every kernel of the compiled path (fused steps, their batches, "
        "LP2 alone and batched) or load it from numba's disk cache, and report which and how "
        "long: a deployment step, so that the first controller starts without compiling.",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON list instead")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Ready the kernels and report them; exit status 0."""
    from lpik.fast.precompile import compile_kernels  # without numba: one line, exit 2

    loads = compile_kernels()
    if args.json:
        print(json.dumps([asdict(load) for load in loads], indent=2))
        return 0
    width = max(len(load.name) for load in loads)
    for load in loads:
        print(f"{load.name:<{width}}  {load.source:<10}  {load.seconds:7.2f} s")
    for path in dict.fromkeys(load.cache_path for load in loads):
        print(f"numba cache: {path}")
    return 0
