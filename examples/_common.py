"""Settings the examples share: how long they run and where they write.

The test suite runs every example with ``LPIK_EXAMPLE_STEPS`` set to a small
number and ``LPIK_EXAMPLE_OUT`` to a temporary folder; run by hand, they take
their full length and write to ``lpik-examples/``.
"""

from __future__ import annotations

import os
from pathlib import Path


def steps(default: int) -> int:
    """The number of control steps to run: ``LPIK_EXAMPLE_STEPS`` when set, else ``default``."""
    return int(os.environ.get("LPIK_EXAMPLE_STEPS", default))


def out_dir() -> Path:
    """Where an example writes its files (created when missing)."""
    path = Path(os.environ.get("LPIK_EXAMPLE_OUT", "lpik-examples"))
    path.mkdir(parents=True, exist_ok=True)
    return path
