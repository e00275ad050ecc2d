"""Run the motion-quality suite and regenerate docs/quality.md: the one command to rerun.

Run it with the Python of an environment where lpik and the peers are
installed (``pip install -e ".[bench]"``), from the repository root::

    /tmp/benchvenv/bin/python benchmarks/quality.py

It runs :mod:`lpik_bench.quality` (every scenario, every lpik variant, every
installed peer) and writes ``docs/quality.md``, which names this command and
the machine. Extra arguments go to ``lpik_bench.quality``, e.g.
``--max-steps 300 --out /tmp/quick.md`` for a quick look.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "quality.md"


def main() -> int:
    from lpik_bench.quality import main as run

    args = sys.argv[1:]
    command = " ".join([sys.executable, "benchmarks/quality.py", *args])
    if "--out" not in args:
        args = [*args, "--out", str(DOC)]
    return run(args, command=command)


if __name__ == "__main__":
    sys.exit(main())
