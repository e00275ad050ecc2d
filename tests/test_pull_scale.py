"""Sec. 3.1's pull is the paper's where it fits, and the share taken is reported.

LP2 with the smoothing term (eqs. 15-18 with sec. 3.1's rows) is solved whole
wherever the pull keeps the step at ``p = 0`` within its bounds; only where it
does not is the pull scaled (:func:`lpik.methods.pull.pull_scale`). The share
taken is :attr:`lpik.result.Result.pull_scale`, in ``lpik solve``'s JSON and
the ``lpik simulate`` CSV. The paper's LP is assembled here on its own (sec. 3.1's
rows over ``(q, lam, p)``) and solved by HiGHS through scipy.
"""

from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from lpik.cli.main import main
from lpik.command import ClampedTarget
from lpik.control.simulate import simulate
from lpik.methods.kkt import affine_solution
from lpik.methods.lp2 import lp2
from lpik.problem import Problem
from lpik.problem_json import problem_from_dict
from lpik.robots.planar import planar_arm

pytest.importorskip("numba")


def planar_jacobian(q: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The (x, y) Jacobian of a planar chain of revolute joints, links ``lengths``."""
    angles = np.cumsum(q)
    tail_x = np.cumsum((lengths * np.cos(angles))[::-1])[::-1]
    tail_y = np.cumsum((lengths * np.sin(angles))[::-1])[::-1]
    return np.vstack([-tail_y, tail_x])


def paper_lp2(doc: dict) -> tuple[float, np.ndarray]:
    """Sec. 3.1's LP2 as the paper writes it, by HiGHS: ``(p, q - q0)``.

    max p over ``(q, lam, p)`` subject to ``[[M + Lambda, J^T, 0], [J, 0, w0 - w]]
    [q; lam; p] = [M q0 + Lambda q_ref + f; J q0]``, ``0 <= p <= 1``, ``lam`` free and
    ``q`` within its end-stops and the step's velocity bounds.
    """
    J, q0, dw = np.array(doc["J"]), np.array(doc["q0"]), np.array(doc["dw"])
    m, n = J.shape
    M, Lam, q_ref = np.eye(n), np.diag(doc["Lambda"]), np.array(doc["q_ref"])
    A = np.block([[M + Lam, J.T, np.zeros((n, 1))], [J, np.zeros((m, m)), -dw[:, None]]])
    b = np.concatenate([M @ q0 + Lam @ q_ref, J @ q0])
    lo = np.maximum(doc["q_min"], q0 + np.array(doc["dq_min"]))
    hi = np.minimum(doc["q_max"], q0 + np.array(doc["dq_max"]))
    cost = np.zeros(n + m + 1)
    cost[-1] = -1.0
    bounds = [*zip(lo, hi), *[(None, None)] * m, (0.0, 1.0)]
    res = linprog(cost, A_eq=A, b_eq=b, bounds=bounds, method="highs")
    assert res.status == 0, res.message
    return float(res.x[-1]), res.x[:n] - q0


#: A 3-link planar arm (links 1 m) where the whole pull fits: the paper's p is 0.48800;
#: the pull scaled to half the room (the rule before) gave p = 0.59574, another LP.
Q0 = np.array([-0.1, 0.3, 0.5])
FITS = {
    "method": "lp2",
    "J": planar_jacobian(Q0, np.ones(3)).tolist(),
    "dw": [-0.08, 0.18],
    "q0": Q0.tolist(),
    "q_min": [-2.0] * 3,
    "q_max": [2.0] * 3,
    "dq_min": [-0.05] * 3,
    "dq_max": [0.05] * 3,
    "Lambda": [2.0] * 3,
    "q_ref": [0.0] * 3,
}


def solve_json(doc: dict, tmp_path) -> dict:
    """``lpik solve`` on ``doc``: its JSON answer."""
    path = tmp_path / "problem.json"
    path.write_text(json.dumps(doc))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["solve", str(path)]) == 0
    return json.loads(out.getvalue())


def test_where_the_pull_fits_lpik_solve_is_the_papers_lp2(tmp_path) -> None:
    p, dq = paper_lp2(FITS)
    assert p == pytest.approx(0.48800, abs=1e-5)
    data = solve_json(FITS, tmp_path)
    assert data["status"] == "optimal" and data["pull_scale"] == 1.0
    assert abs(data["p"] - p) <= 1e-9
    np.testing.assert_allclose(data["dq"], dq, rtol=0, atol=1e-9)
    problem = problem_from_dict(FITS)[1]
    compiled = lp2(problem, path="compiled")
    assert compiled.pull_scale == 1.0 and abs(compiled.p - p) <= 1e-9
    np.testing.assert_allclose(compiled.dq, dq, rtol=0, atol=1e-9)


def test_where_the_pull_does_not_fit_it_is_scaled_and_the_step_stays_feasible(tmp_path) -> None:
    # joint 1 sits on its upper end-stop and q_ref pulls it past: the whole pull would put
    # the step at p = 0 beyond the stop (the paper's LP2 has no feasible p)
    doc = {**FITS, "dw": [0.08, -0.18], "q0": [0.5, 0.3, 0.5], "q_max": [0.5, 2.0, 2.0],
           "q_ref": [2.0, 1.0, -1.0],
           "J": planar_jacobian(np.array([0.5, 0.3, 0.5]), np.ones(3)).tolist()}  # fmt: skip
    problem = problem_from_dict(doc)[1]
    with pytest.raises(AssertionError, match="infeasible"):
        paper_lp2(doc)
    data = solve_json(doc, tmp_path)
    assert data["status"] == "optimal" and 0.0 < data["p"]
    assert 0.0 <= data["pull_scale"] < 1.0
    compiled = lp2(problem, path="compiled")
    assert compiled.status == "optimal"
    assert compiled.pull_scale == pytest.approx(data["pull_scale"], rel=1e-12, abs=1e-15)
    assert affine_solution(problem).smoothing == data["pull_scale"]


def full_pull_violation(problem: Problem) -> float | None:
    """How far the step at ``p = 0`` with the whole pull lies past its bounds (eq. 18 at
    ``p = 0``, solved here by dense linear algebra); None where the KKT matrix is singular."""
    n, m = problem.n, problem.m
    H = problem.M + problem.Lambda
    K = np.block([[H, problem.J.T], [problem.J, np.zeros((m, m))]])
    rhs = np.concatenate([problem.f + problem.Lambda @ (problem.q_ref - problem.q0), np.zeros(m)])
    if np.linalg.cond(K) > 1e8:
        return None
    x = np.linalg.solve(K, rhs)
    lower, upper = problem.step_bounds()[:2]
    dq, lam = x[:n], x[n:]
    return float(max(np.max(dq - upper), np.max(lower - dq),
                     np.max(lam - problem.lam_max), np.max(problem.lam_min - lam)))  # fmt: skip


@st.composite
def planar_problems(draw: st.DrawFn) -> Problem:
    n = draw(st.integers(3, 5))
    floats = st.floats(-1.5, 1.5, allow_nan=False)
    q0 = np.array(draw(st.lists(floats, min_size=n, max_size=n)))
    lengths = np.array(draw(st.lists(st.floats(0.3, 1.5), min_size=n, max_size=n)))
    rate = draw(st.floats(0.01, 0.2))
    lam_bound = draw(st.sampled_from([np.inf, 0.05, 0.5]))
    return Problem(
        J=planar_jacobian(q0, lengths),
        dw=np.array(draw(st.lists(st.floats(-0.2, 0.2), min_size=2, max_size=2))),
        q0=q0, q_min=np.full(n, -1.6), q_max=np.full(n, 1.6), dq_min=np.full(n, -rate),
        dq_max=np.full(n, rate), Lambda=np.full(n, draw(st.floats(0.01, 5.0))),
        q_ref=np.array(draw(st.lists(floats, min_size=n, max_size=n))),
        lam_min=np.full(2, -lam_bound), lam_max=np.full(2, lam_bound),
    )  # fmt: skip


#: A draw that failed once: the arm stretched along an axis, J's first row 1e-10.
STRETCHED = Problem(
    J=np.array([[-1e-10, -1e-10, -1e-10], [3.0, 2.0, 1.0]]), dw=np.zeros(2),
    q0=np.array([0.0, 0.0, 1e-10]), q_min=np.full(3, -1.6), q_max=np.full(3, 1.6),
    dq_min=np.full(3, -0.125), dq_max=np.full(3, 0.125), Lambda=np.full(3, 1.0),
    q_ref=np.array([0.0, 0.0, 1.0]), lam_min=np.full(2, -np.inf), lam_max=np.full(2, np.inf),
)  # fmt: skip


@settings(max_examples=150, deadline=None)
@given(planar_problems())
@example(STRETCHED)
def test_compiled_and_numpy_agree_and_a_pull_that_fits_is_whole(problem: Problem) -> None:
    numpy_result, compiled = lp2(problem), lp2(problem, path="compiled")
    assert numpy_result.status == compiled.status
    # numpy's SVD and the compiled Jacobi SVD round apart by about cond(J) times the
    # machine epsilon on LP2's singular path (an arm stretched along an axis: a J row of
    # 1e-10, cond(J) 2e10, the two pull scales 5e-7 apart, as test_parity's xfails)
    rounding = 1e-15 * float(np.linalg.cond(problem.J))
    assert abs(numpy_result.pull_scale - compiled.pull_scale) <= 1e-9 + rounding
    assert 0.0 <= compiled.pull_scale <= 1.0
    if not compiled.moved:
        assert compiled.pull_scale == numpy_result.pull_scale == 1.0
        return
    violation = full_pull_violation(problem)
    if violation is None:
        return
    if violation <= -1e-9:  # fits with room to spare: the paper's LP2, pull whole
        assert numpy_result.pull_scale == compiled.pull_scale == 1.0
    elif violation >= 1e-9:  # does not fit: scaled
        assert compiled.pull_scale < 1.0


def test_the_simulate_csv_has_a_pull_scale_column(tmp_path) -> None:
    model = planar_arm([1.0, 1.0, 1.0], q_min=-np.pi, q_max=np.pi, qd_max=1.0)
    command = ClampedTarget(np.array([1.5, 1.5, 0.0]), 0.25, 1.0)
    log = simulate(model, command, np.array([0.3, 0.6, 0.9]), 5, method="lp2",
                   dt=0.01, weights={"Lambda": np.full(3, 1.0), "q_ref": np.zeros(3)})  # fmt: skip
    path = log.to_csv(tmp_path / "run.csv")
    lines = path.read_text().splitlines()
    assert lines[0].split(",")[-1] == "pull_scale"
    column = [float(line.split(",")[-1]) for line in lines[1:]]
    np.testing.assert_allclose(column, log.pull_scale, rtol=1e-11)
    assert all(0.0 <= s <= 1.0 for s in column)
