"""Recovery's restoration: the step of least total penetration where no step moves every pair
apart (lpik.collision.recovery.restoration), on the numpy (HiGHS) and compiled LPs."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from collision_cases import lp_paths
from core_strategies import examples
from lpik.collision.recovery import recovery_motion, restoration
from lpik.tolerances import MOTION_WEIGHT

fast = pytest.importorskip("lpik.fast.progress")

#: Each path's LPs: the least-error LP and the largest-share LP.
PATHS = lp_paths()
TOL = 1e-7


@st.composite
def contradicting_pairs(draw):
    """A step's arrays with rows of pairs inside d_s (``g < 0``), ordinary rows (``g >= 0``)
    and bounds (sometimes a braking joint whose bounds exclude 0), from a seed."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n, m = draw(st.integers(2, 7)), draw(st.integers(1, 3))
    inside, outside = draw(st.integers(2, 5)), draw(st.integers(0, 3))
    J, dw = rng.normal(size=(m, n)), rng.normal(size=m) * 0.01
    G = rng.normal(size=(inside + outside, n)) * rng.uniform(0.01, 1.0)
    g = np.concatenate([-rng.uniform(1e-3, 0.05, inside), rng.uniform(0.0, 0.05, outside)])
    lower, upper = -rng.uniform(0.0, 0.02, n), rng.uniform(0.0, 0.02, n)
    if draw(st.booleans()):  # a joint braking: its band does not hold dq = 0
        i = int(rng.integers(n))
        lower[i], upper[i] = 0.005, 0.005 + rng.uniform(0.0, 0.01)
    return J, dw, lower, upper, G, g, list(range(inside))


def shortfall(G, g, dq) -> float:  # type: ignore[no-untyped-def]
    """How far the rows fall short of their demand, summed: ``sum max(0, G dq - g)``."""
    return float(np.maximum(G @ dq - g, 0.0).sum())


def penalty(G, g, dq) -> float:  # type: ignore[no-untyped-def]
    """The restoration LP's objective: ``sum |G dq - g| + MOTION_WEIGHT sum |dq|``."""
    return float(np.abs(G @ dq - g).sum() + MOTION_WEIGHT * np.abs(dq).sum())


@pytest.mark.parametrize("path", list(PATHS))
@settings(max_examples=examples(150), deadline=None)
@given(contradicting_pairs())
def test_the_recovery_step_keeps_every_limit_and_never_adds_penetration(path, case) -> None:
    """Whatever the pairs' gradients: the step keeps the bounds and the other rows, and where
    standing still is allowed it leaves no more total shortfall of the demands than standing
    still; the restoration's own step is the least-L1 shortfall (no worse than any other)."""
    J, dw, lower, upper, G, g, rows = case
    least_error, largest_share = PATHS[path]
    others = [k for k in range(g.size) if k not in rows]
    dq = recovery_motion(J, dw, lower, upper, G, g, rows, least_error, largest_share)
    restored = restoration(G, g, lower, upper, rows, least_error)
    if dq is None:
        assert restored is None
        return
    assert np.all(dq >= lower - TOL) and np.all(dq <= upper + TOL)
    assert np.all(G[others] @ dq <= g[others] + TOL * np.maximum(1.0, np.abs(g[others])))
    if np.all(lower <= 0.0) and np.all(upper >= 0.0):  # standing still is a step
        assert shortfall(G[rows], g[rows], dq) <= float(-g[rows].sum()) + TOL
    if restored is not None:
        relaxed, step = restored
        assert np.all(G[rows] @ step <= relaxed[rows] + TOL)
        rng = np.random.default_rng(0)
        for _ in range(20):  # no step within the bounds and the other rows does better
            other = rng.uniform(lower, upper)
            if np.all(G[others] @ other <= g[others]):
                assert penalty(G[rows], g[rows], step) <= penalty(G[rows], g[rows], other) + 1e-9


def test_the_paths_agree_where_the_optimum_is_unique() -> None:
    """Two rows that ask one joint to move both ways, the other joint free of them: the
    restoration splits the difference by the rows' weights alike on both paths."""
    G = np.array([[-1.0, 0.0], [2.0, 0.0]])
    g = np.array([-0.01, -0.01])  # dq0 >= 0.01 and dq0 <= -0.005
    lower, upper = np.full(2, -0.02), np.full(2, 0.02)
    steps = [restoration(G, g, lower, upper, [0, 1], le)[1] for le, _ in PATHS.values()]
    # |-x + 0.01| + |2x + 0.01|: least at x = -0.005 (the steeper row met), value 0.015
    for dq in steps:
        np.testing.assert_allclose(dq, [-0.005, 0.0], atol=1e-12)
