"""``lpik bench``: lpik's speed against other IK libraries, on the same steps.

- :mod:`lpik.bench.workload`: the robot, seeded configurations and targets,
  shared by every library;
- :mod:`lpik.bench.cases`: lpik's timed cases (every method, the fused compiled
  step, batches, FK + Jacobian alone);
- :mod:`lpik.bench.peers`: one adapter per peer (Drake, pink, mink, the
  Robotics Toolbox), imported only when installed (``pip install "lpik[bench]"``);
- :mod:`lpik.bench.agreement`: the checks that hold answers together where they
  must agree;
- :mod:`lpik.bench.runner`: interleaved timing, first-call costs (in fresh
  processes, :mod:`lpik.bench.firstcall`), the run;
- :mod:`lpik.bench.records`: the output records;
- :mod:`lpik.bench.table`: the records as a text table and as markdown.

Importing this package imports nothing heavy; :func:`run_benchmark` does.
"""

from __future__ import annotations

from typing import Any

__all__ = ["run_benchmark"]


def run_benchmark(*args: Any, **kwargs: Any) -> Any:
    """:func:`lpik.bench.runner.run_benchmark` (imported on first use)."""
    from lpik.bench.runner import run_benchmark as run

    return run(*args, **kwargs)
