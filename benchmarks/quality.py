"""Run the motion-quality suite and regenerate docs/quality.md: the one command to rerun.

Run it with the Python of an environment where lpik and the peers are
installed (``pip install -e ".[bench]"``), from the repository root::

    python benchmarks/quality.py                  # the Panda: docs/quality.md
    python benchmarks/quality.py --robot iiwa14   # docs/quality-iiwa14.md
    python benchmarks/quality.py --robot ur5e     # docs/quality-ur5e.md

It runs :mod:`lpik_bench.quality` (every scenario, every lpik variant, every
installed peer) and writes the arm's page, which names this command and the
machine. Extra arguments go to ``lpik_bench.quality``, e.g.
``--max-steps 300 --out /tmp/quick.md`` for a quick look.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "quality.md"


def page(robot: str) -> Path:
    """The page of ``robot``'s suite: :data:`DOC` for the Panda, ``quality-<robot>.md`` else."""
    return DOC if robot == "panda" else DOC.with_name(f"quality-{robot}.md")


def main() -> int:
    from lpik_bench.quality import main as run

    args = sys.argv[1:]
    command = " ".join([sys.executable, "benchmarks/quality.py", *args])
    if "--out" not in args:
        robot = args[args.index("--robot") + 1] if "--robot" in args[:-1] else "panda"
        args = [*args, "--out", str(page(robot))]
    return run(args, command=command)


if __name__ == "__main__":
    sys.exit(main())
