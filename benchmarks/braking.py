"""Point-to-point moves under other acceleration limits, on every 3-D arm.

Runs :mod:`lpik_bench.braking` (its docstring says what is measured); from the
repository root, with lpik installed (and pydrake for Drake's rows)::

    .venv/bin/python benchmarks/braking.py [--robots panda ur5e iiwa14]

It writes its section of ``docs/benchmarks.md``.
"""

from __future__ import annotations

from lpik_bench.braking import main

if __name__ == "__main__":
    raise SystemExit(main())
