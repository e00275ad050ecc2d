"""Run the full benchmark and regenerate docs/benchmarks.md: the one command to rerun.

Run it with the Python of an environment where lpik and the peers are
installed (``pip install -e ".[bench]"``), from the repository root, on a
quiet machine::

    /tmp/benchvenv/bin/python benchmarks/run_all.py

It runs ``lpik bench --json`` (through this interpreter), keeps the records in
``benchmarks/results.json`` and writes ``docs/benchmarks.md`` with
:mod:`lpik_bench.markdown`. Extra arguments go to ``lpik bench``, e.g.
``--rounds 400`` or ``--quick``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results.json"
DOC = ROOT / "docs" / "benchmarks.md"


def main() -> int:
    command = [sys.executable, "-m", "lpik.cli.main", "bench", "--json", *sys.argv[1:]]
    print("running:", " ".join(command), file=sys.stderr, flush=True)
    done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False, cwd=ROOT)
    if done.returncode != 0:
        print(f"lpik bench failed with exit status {done.returncode}", file=sys.stderr)
        return done.returncode
    RESULTS.write_text(done.stdout)
    writer = ["-m", "lpik_bench.markdown", "benchmarks/results.json", "docs/benchmarks.md"]
    subprocess.run([sys.executable, *writer], check=True, cwd=ROOT)
    return 0


if __name__ == "__main__":
    sys.exit(main())
