"""The benchmark's output records (one JSON object each)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Record:
    """One line of the benchmark's output.

    Attributes:
        library: ``"lpik"`` or a peer's name.
        method: The method or function.
        what: What was timed or checked (see :mod:`lpik_bench.cases`).
        median_us: Median time per step [us]; ``None`` for non-timing records.
        p99_us: 99th percentile per step [us]; ``None`` for non-timing records.
        kind: ``"timing"``, ``"first call"``, ``"agreement"``, ``"skipped"`` or
            ``"environment"``.
        extra: Further keys of the JSON record.
    """

    library: str
    method: str
    what: str
    median_us: float | None = None
    p99_us: float | None = None
    kind: str = "timing"
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The JSON record: the five required keys, ``kind`` and the extras.

        Non-finite numbers (an empty check's error, a failed peer's inf) become ``None``.
        """
        return {
            key: _finite(value)
            for key, value in {
                "library": self.library,
                "method": self.method,
                "what": self.what,
                "median_us": self.median_us,
                "p99_us": self.p99_us,
                "kind": self.kind,
                **self.extra,
            }.items()
        }


def _finite(value: Any) -> Any:
    if isinstance(value, float | np.floating):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value
