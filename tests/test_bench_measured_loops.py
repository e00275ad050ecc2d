"""benchmarks/measured_loops.py: a failed step brakes the commands within the limits.

The errors themselves are the benchmark's findings (docs/benchmarks.md, "Encoder noise
fed back"); tests/test_commanded.py holds lpik's measured loops to their contract.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.robots.registry import home_configuration, load_robot  # noqa: E402
from lpik_bench import measured_loops as M  # noqa: E402


def test_a_step_that_fails_brakes_the_commands_within_the_limits() -> None:
    model, q0 = load_robot("panda", task="pose"), home_configuration("panda")
    targets = M.goal_targets(model, q0, 400)
    speed = np.linspace(0.1, 0.5, q0.size) * M.DT
    calls = []

    def fails_later(q, prev, target):  # type: ignore[no-untyped-def]
        calls.append(q)
        return q + min(len(calls), 60) / 60 * speed if len(calls) < 100 else None

    run = M.run(fails_later, model, targets, q0, 0.0, 0)
    assert run["failed"] == 301  # calls 100 to 400
    # at the acceleration limit, the fastest joint (0.5 rad/s) is at rest after 50 ms
    assert run["acc"] == 0.0  # the median step: at rest by then
    steps = np.diff(np.asarray(calls), axis=0)  # each call reads the last command (no noise)
    change = np.abs(np.diff(steps[98:], axis=0)) / M.DT**2  # from the last motion answered
    assert np.all(change <= M.QDD_MAX * (1 + 1e-9))  # no stop at once
    assert np.allclose(steps[-1], 0.0)
