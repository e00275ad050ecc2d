"""Hypothesis strategies and problem builders shared by the tests of the lpik core.

A *case* is a random planar arm (2-8 links of random lengths), a configuration
``q0``, a commanded displacement and limits that ``q0`` satisfies: end-stops
containing ``q0`` (sometimes with ``q0`` exactly on one), velocity bounds,
sometimes multiplier bounds, sometimes extra rows ``G q <= h`` with
``G q0 <= h``, sometimes weights (``M``, ``f``, ``Lambda``, ``q_ref``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypothesis import settings
from hypothesis import strategies as st

from lpik.methods import solve
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import TaskModel
from lpik.robots.planar import planar_arm


def examples(n: int) -> int:
    """``n`` examples under the default profile, scaled by the loaded profile."""
    return max(1, round(n * settings.default.max_examples / 100))


@dataclass(frozen=True, eq=False)
class Case:
    """A planar arm and one step's problem built from it."""

    arm: TaskModel
    problem: Problem

    def solve(self, method: str) -> Result:
        return solve(self.problem, method, model=self.arm)

    @property
    def criterion_is_zero(self) -> bool:
        """True when ``f = 0`` and ``Lambda (q_ref - q0) = 0``: LP2's step at p = 0 is dq = 0."""
        P = self.problem
        c = P.f + P.Lambda @ (P.q_ref - P.q0)
        return bool(np.all(c == 0))


def floats(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, allow_subnormal=False)


def vectors(size: int, elements: st.SearchStrategy[float]) -> st.SearchStrategy[np.ndarray]:
    return st.lists(elements, min_size=size, max_size=size).map(
        lambda v: np.array(v, dtype=np.float64)
    )


def offsets(size: float) -> st.SearchStrategy[float]:
    """0, or a number between 1e-3 and ``size`` in magnitude.

    Offsets far below a millimetre or milliradian sit within the solvers'
    tolerances of a limit, where two correct solvers may disagree on feasibility.
    """
    return st.one_of(st.just(0.0), floats(1e-3, size), floats(-size, -1e-3))


def joint_angles() -> st.SearchStrategy[float]:
    """0, or an angle at least 1e-3 rad from 0 and from +-pi (a link folded back on the
    one before it is aligned with it as much as a straight one)."""
    return st.one_of(st.just(0.0), floats(1e-3, np.pi - 1e-3), floats(-np.pi + 1e-3, -1e-3))


#: Distance of an end-stop from q0: on it, near, far, or none.
MARGINS = st.one_of(st.just(0.0), floats(1e-3, 1.0), st.just(np.inf))
#: One step's velocity bound (velocity times dt): small, large or none.
STEP_BOUNDS = st.one_of(floats(1e-3, 0.2), st.just(np.inf))
#: A multiplier bound's distance from 0.
LAMBDA_BOUNDS = st.one_of(st.just(0.0), floats(1e-3, 2.0), st.just(np.inf))
#: Size of the commanded displacement relative to the arm's reach.
DW_SIZES = st.sampled_from([0.0, 1e-3, 1e-2, 5e-2, 0.2, 1.0])


@st.composite
def cases(
    draw: st.DrawFn,
    *,
    tasks: tuple[str, ...] = ("position",),
    max_links: int = 8,
    weights: bool = True,
    multipliers: bool = True,
    rows: bool = True,
    well_posed: bool = False,
    dw_sizes: st.SearchStrategy[float] = DW_SIZES,
) -> Case:
    """A random planar arm, configuration, displacement and limits that q0 satisfies.

    ``well_posed=True`` bounds every joint's step (as a velocity limit does) and
    keeps every joint angle either exactly 0 or at least 1e-3 rad from 0 and +-pi, so
    that the programs have a bounded feasible set and no link is aligned to
    within the solvers' tolerances: then two LP solvers may be compared to
    1e-7. Otherwise some joints may move freely and links may be aligned to
    1e-9 rad, which the contract (feasibility, p in [0, 1], J dq = p dw) must
    survive all the same.
    """
    task = draw(st.sampled_from(tasks))
    m = 2 if task == "position" else 3
    n = draw(st.integers(m, max(m, max_links)))
    lengths = draw(vectors(n, floats(0.2, 2.0)))
    arm = planar_arm(lengths.tolist(), task=task)
    q0 = draw(vectors(n, joint_angles() if well_posed else floats(-np.pi, np.pi)))
    J = arm.jacobian(q0)
    dw = draw(directions(m)) * draw(dw_sizes) * float(lengths.sum())
    fields: dict[str, object] = {
        "q_min": q0 - draw(vectors(n, MARGINS)),
        "q_max": q0 + draw(vectors(n, MARGINS)),
    }
    if well_posed or draw(st.booleans()):
        steps = floats(1e-3, 0.2) if well_posed else STEP_BOUNDS
        fields["dq_min"] = -draw(vectors(n, steps))
        fields["dq_max"] = draw(vectors(n, steps))
    if multipliers and draw(st.integers(0, 3)) == 0:
        fields["lam_min"] = -draw(vectors(m, LAMBDA_BOUNDS))
        fields["lam_max"] = draw(vectors(m, LAMBDA_BOUNDS))
    if rows and draw(st.integers(0, 3)) == 0:
        r = draw(st.integers(1, 3))
        G = np.array([draw(vectors(n, offsets(1.0))) for _ in range(r)])
        slack = draw(vectors(r, st.one_of(st.just(0.0), floats(0.0, 0.5))))
        fields["G"], fields["h"] = G, G @ q0 + slack
    if weights and draw(st.booleans()):
        fields.update(draw(weight_fields(n, q0)))
    return Case(arm, Problem(J=J, dw=dw, q0=q0, **fields))


@st.composite
def directions(draw: st.DrawFn, m: int) -> np.ndarray:
    """A unit vector of length m (commands far below the solvers' tolerances are not drawn)."""
    v = draw(vectors(m, offsets(1.0)))  # no component far below the others
    norm = float(np.linalg.norm(v))
    if norm < 1e-3:
        v, norm = np.eye(m)[0], 1.0
    return v / norm


@st.composite
def weight_fields(draw: st.DrawFn, n: int, q0: np.ndarray) -> dict[str, object]:
    """Some of M (diagonal or full positive definite), f, Lambda (diagonal) and q_ref."""
    out: dict[str, object] = {}
    kind = draw(st.sampled_from(["identity", "diagonal", "full"]))
    if kind == "diagonal":
        out["M"] = draw(vectors(n, floats(0.1, 10.0)))
    elif kind == "full":
        # (no entries near HiGHS's small_matrix_value, 1e-9, which it drops)
        B = np.array([draw(vectors(n, offsets(1.0))) for _ in range(n)])
        out["M"] = B @ B.T + 0.1 * np.eye(n)
    if draw(st.booleans()):
        out["f"] = draw(vectors(n, offsets(0.05)))
    if draw(st.booleans()):
        out["Lambda"] = draw(vectors(n, st.one_of(st.just(0.0), floats(1e-3, 5.0))))
        if draw(st.booleans()):
            out["q_ref"] = q0 + draw(vectors(n, offsets(0.5)))
    return out


def paper_problem(arm: TaskModel, q0: np.ndarray, dw: np.ndarray, **fields: object) -> Problem:
    """A problem for the paper's arm at ``q0`` with its end-stops and a 1 rad/s, 10 ms bound."""
    defaults: dict[str, object] = {
        "q_min": arm.q_min,
        "q_max": arm.q_max,
        "dq_min": -arm.qd_max * 0.01,
        "dq_max": arm.qd_max * 0.01,
    }
    defaults.update(fields)
    return Problem(J=arm.jacobian(q0), dw=dw, q0=q0, **defaults)
