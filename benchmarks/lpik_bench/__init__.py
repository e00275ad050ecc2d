"""``lpik bench``: lpik's speed against other IK libraries, on the same steps.

- :mod:`lpik_bench.workload`: the robot, seeded configurations and targets,
  shared by every library;
- :mod:`lpik_bench.cases`: lpik's timed cases (every method, the fused compiled
  step, batches, FK + Jacobian alone);
- :mod:`lpik_bench.singular`: the fused step at and near the Panda's singular
  configurations, and which path (ratio test, singular path, HiGHS) its steps take;
- :mod:`lpik_bench.peers`: one adapter per peer (Drake, pink, mink, the
  Robotics Toolbox), imported only when installed (``pip install "lpik[bench]"``);
- :mod:`lpik_bench.agreement`: the checks that hold answers together where they
  must agree;
- :mod:`lpik_bench.runner`: interleaved timing, first-call costs (in fresh
  processes, :mod:`lpik_bench.firstcall`), the run;
- :mod:`lpik_bench.records`: the output records;
- :mod:`lpik_bench.table`: the records as a text table and as markdown.

Importing this package imports nothing heavy; :func:`run_benchmark` does.
"""

from __future__ import annotations

import os
from typing import Any

# The benchmarks time the compiled step: every controller compiles when it is built,
# not in a background process while the numpy engine steps (lpik.control.warmup).
os.environ.setdefault("LPIK_COMPILE", "now")

__all__ = ["run_benchmark"]


def run_benchmark(*args: Any, **kwargs: Any) -> Any:
    """:func:`lpik_bench.runner.run_benchmark` (imported on first use)."""
    from lpik_bench.runner import run_benchmark as run

    return run(*args, **kwargs)
