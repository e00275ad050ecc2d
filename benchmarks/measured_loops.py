"""Encoder noise fed back under acceleration limits, on every 3-D arm.

Runs :mod:`lpik_bench.measured_loops` (its docstring says what is measured); from
the repository root, with lpik installed (and pydrake for Drake's rows)::

    .venv/bin/python benchmarks/measured_loops.py [--sigma 0 1e-5 1e-4] [--seeds 3]

It writes its section of ``docs/benchmarks.md``.
"""

from __future__ import annotations

from lpik_bench.measured_loops import main

if __name__ == "__main__":
    raise SystemExit(main())
