"""Reachable goals drawn at random, with and without acceleration limits, on every 3-D arm.

Runs :mod:`lpik_bench.random_goals` (its docstring says what is measured); from
the repository root, with lpik installed::

    .venv/bin/python benchmarks/random_goals.py [--goals 30] [--qdd-max 10]

It writes its section of ``docs/benchmarks.md``.
"""

from __future__ import annotations

from lpik_bench.random_goals import main

if __name__ == "__main__":
    raise SystemExit(main())
