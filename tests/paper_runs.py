"""The paper's closed-loop runs, computed once per test session and shared by the test files.

Every run of the two scenarios takes a few tenths of a second; caching them
keeps the simulation, scenario and reproduce tests fast.
"""

from __future__ import annotations

import functools

from lpik.control.simulate import SimulationLog
from lpik.paper.runs import choose_lambda_bound
from lpik.paper.scenarios import get_scenario
from lpik.paper.setup import PAPER_COMMAND


@functools.cache
def run(
    scenario: str, method: str, lambda_bound: float | None = None, warm_start: bool = True
) -> SimulationLog:
    """One full run of a scenario (cached for the session)."""
    return get_scenario(scenario).run(
        method, lambda_bound=lambda_bound, warm_start=warm_start, **PAPER_COMMAND
    )


def lp1_cold() -> SimulationLog:
    """Pull-in under LP1, every step's LP solved on its own (the paper's Figs. 3, 4a)."""
    return run("pull-in", "lp1", warm_start=False)


def lp1_warm() -> SimulationLog:
    """Pull-in under LP1 with HiGHS warm-started across steps."""
    return run("pull-in", "lp1")


def lp2_pull_in() -> SimulationLog:
    """Pull-in under LP2 (Figs. 4b, 5, 6)."""
    return run("pull-in", "lp2")


def edge_unbounded() -> SimulationLog:
    """Edge singularity under LP2, multipliers unbounded (Figs. 7, 8)."""
    return run("edge-singularity", "lp2")


def chosen_bound() -> float:
    """The multiplier bound derived from the unbounded run's history."""
    return choose_lambda_bound(edge_unbounded()).bound


def edge_bounded() -> SimulationLog:
    """Edge singularity under LP2 with the derived multiplier bound (Fig. 9)."""
    return run("edge-singularity", "lp2", chosen_bound())
