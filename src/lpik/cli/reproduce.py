"""``lpik reproduce --out DIR``: figures 3-12 (the paper's 3-9 and more), CSV logs, summary.md."""

from __future__ import annotations

import argparse
import sys
import time

#: Default output directory.
DEFAULT_OUT = "lpik-out"


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik reproduce``."""
    parser = sub.add_parser(
        "reproduce",
        help="rerun the paper's section 4 and write figures 3-12, CSV logs and summary.md",
        description="Run the pull-in scenario under LP1 and LP2 and the edge-singularity "
        "scenario under LP2 with unbounded, bounded and automatically bounded multipliers; "
        "write the paper's figures 3-9 as PNG, the CSV log behind every figure and summary.md "
        "with the runs' numbers; beyond the paper, the saturating LP2 (Fig. 10), collision "
        "avoidance (Figs. 11-12) and the 3-D arms (fig3d-*.png). Needs matplotlib and coal: "
        'pip install "lpik[reproduce]".',
    )
    parser.add_argument(
        "--out",
        default=DEFAULT_OUT,
        metavar="DIR",
        help=f"output directory (default {DEFAULT_OUT})",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run everything, write the files, and list them on stdout."""
    from lpik.paper.reproduce import reproduce
    from lpik.paper.style import require_backend

    require_backend()
    start = time.perf_counter()
    status = None
    if sys.stderr.isatty():
        from rich.console import Console

        status = Console(stderr=True).status("running")
        status.start()

    def say(stage: str) -> None:
        if status is not None:
            status.update(f"lpik reproduce: {stage}")

    try:
        result = reproduce(args.out, progress=say)
    finally:
        if status is not None:
            status.stop()
    for path in result.files:
        print(f"wrote {path}")
    print(
        f"{len(result.files)} files in {time.perf_counter() - start:.1f} s; multiplier bound "
        f"B = {result.choice.bound:g}; see {result.out_dir / 'summary.md'}"
    )
    return 0
