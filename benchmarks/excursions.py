"""Excursions beyond reach and back under acceleration limits, on every 3-D arm.

Runs :mod:`lpik_bench.excursions` (its docstring says what is measured); from the
repository root, with lpik installed::

    .venv/bin/python benchmarks/excursions.py [--qdd-max 10] [--far 0.5 1.0]

It writes its section of ``docs/benchmarks.md``.
"""

from __future__ import annotations

from lpik_bench.excursions import main

if __name__ == "__main__":
    raise SystemExit(main())
