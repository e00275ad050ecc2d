"""The rows stage: a stop that breaks a row is moved within the rows
(lpik.collision.recovery.stop_within_rows, kept_within_rows), checked against linprog's HiGHS
on random rows and bounds, and on a Panda braking towards the shelf's top on both engines."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from collision_cases import lp_paths
from core_reference import LINPROG_OPTIONS
from core_strategies import examples
from lpik.collision import load_scene
from lpik.collision.recovery import stop_within_rows
from lpik.control.stepper import Stepper
from lpik.robots.registry import load_robot
from lpik.tolerances import FEASIBILITY_TOL, MOTION_WEIGHT

fast = pytest.importorskip("lpik.fast.progress")
from lpik.control.controller import Lp2Controller  # noqa: E402

#: Each path's LPs: the least-error LP and the largest-share LP.
PATHS = lp_paths()
TOL = 1e-9


@st.composite
def braking_steps(draw):
    """Bounds (some joints braking: their band excludes 0), the stop ``0`` clipped to them,
    and rows, some of which the stop breaks, from a seed."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n, r = draw(st.integers(2, 7)), draw(st.integers(1, 6))
    lower, upper = -rng.uniform(0.0, 1e-4, n), rng.uniform(0.0, 1e-4, n)
    for i in rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False):
        start = rng.uniform(-2e-3, 2e-3)  # a joint moving: its acceleration band
        lower[i], upper[i] = start, start + rng.uniform(0.0, 4e-5)
    stop = np.clip(0.0, lower, upper)
    G = rng.normal(size=(r, n)) * rng.uniform(0.1, 1.0)
    g = G @ stop - rng.uniform(-2e-5, 3e-5, r)  # rows the stop breaks (g below G stop) or keeps
    return stop, lower, upper, G, g


def nearest_within(dq, lower, upper, G, g):  # type: ignore[no-untyped-def]
    """linprog's optimum of ``|x - dq|_1 + MOTION_WEIGHT |x|_1`` within the bounds and rows
    (x = dq + a - b, |x| <= t), or None where no x keeps them."""
    n = dq.size
    eye, zero = np.eye(n), np.zeros((n, n))
    c = np.concatenate([np.ones(2 * n), np.full(n, MOTION_WEIGHT)])
    A = np.block([[G, -G, np.zeros((G.shape[0], n))], [eye, -eye, -eye], [-eye, eye, -eye]])
    b = np.concatenate([g - G @ dq, -dq, dq])
    bounds = [(0, None)] * (3 * n)
    A_lim = np.block([[eye, -eye, zero], [-eye, eye, zero]])
    res = linprog(c, A_ub=np.vstack([A, A_lim]), b_ub=np.concatenate([b, upper - dq, dq - lower]),
                  bounds=bounds, method="highs", options=LINPROG_OPTIONS)  # fmt: skip
    return None if res.status != 0 else res.fun


def least_worst_excess(dq, lower, upper, G, g) -> float:  # type: ignore[no-untyped-def]
    """linprog's least ``t`` with ``G x <= g + t`` on the rows ``dq`` breaks, the others held
    as ``dq`` keeps them (within the check's tolerance), within the bounds."""
    excess = G @ dq - g
    broken = excess > FEASIBILITY_TOL * np.maximum(1.0, np.abs(g))
    n = dq.size
    res = linprog(np.append(np.zeros(n), 1.0), A_ub=np.hstack([G, -broken[:, None].astype(float)]),
                  b_ub=g + np.where(broken, 0.0, np.maximum(excess, 0.0)),
                  bounds=[*zip(lower, upper), (0.0, None)], method="highs",
                  options=LINPROG_OPTIONS)  # fmt: skip
    assert res.status == 0
    return float(res.x[-1])


def cost(x, dq) -> float:  # type: ignore[no-untyped-def]
    return float(np.abs(x - dq).sum() + MOTION_WEIGHT * np.abs(x).sum())


@pytest.mark.parametrize("path", list(PATHS))
@settings(max_examples=examples(150), deadline=None)
@given(braking_steps())
def test_a_stop_that_breaks_a_row_becomes_the_nearest_step_within_the_rows(path, case) -> None:
    """The stop stands where it keeps the rows; else the step is within the bounds, keeps the
    rows where any step does (at linprog's least cost), and else breaks none by more than
    linprog's least worst excess."""
    stop, lower, upper, G, g = case
    least_error, largest_share = PATHS[path]
    step = stop_within_rows(stop, lower, upper, G, g, least_error, largest_share)
    excess = G @ stop - g
    if np.all(excess <= 1e-7):
        assert step is None
        return
    best = nearest_within(stop, lower, upper, G, g)
    if best is not None:
        assert step is not None and np.all(G @ step <= g + 1e-7)
        assert np.all(step >= lower - TOL) and np.all(step <= upper + TOL)
        assert cost(step, stop) == pytest.approx(best, rel=1e-6, abs=1e-12)
        return
    worst = least_worst_excess(stop, lower, upper, G, g)
    if step is None:  # no step within the bounds breaks the rows by less than the stop
        assert worst >= excess.max() - 1e-9
        return
    assert np.all(step >= lower - TOL) and np.all(step <= upper + TOL)
    assert worst <= excess.max()
    assert np.max(G @ step - g) <= worst + FEASIBILITY_TOL  # the rows' check (rows_kept)


#: A Panda under the shelf's top, link 7 closing on it, its command through the board: states
#: of the shelf scene's closed loop with the command unclamped (seed 1, steps 5,346 and 5,358).
RIDING_THE_DAMPER = (
    [-2.2752859225341453, -0.6323101257378474, 1.8244512648266107, -0.8420663576235405,
     0.3854039959465288, 2.241612882155611, 1.8551038000447162],
    [-2.2762510026118936, -0.6326266181698734, 1.8247073022727336, -0.8408721616960707,
     0.38564697487095245, 2.240818543248843, 1.8552029294963108],
    [[0.6743559157734234, -7.235165456089264e-05, 0.738406455569442, 0.2338494671412978],
     [-0.5382564212682498, -0.6846222666092533, 0.4915001292230806, -0.036475069056403374],
     [0.50549394044329, -0.7288980359611669, -0.46171801930081635, 0.3174367726607754]],
)  # fmt: skip
PAST_THE_DAMPER = (
    [-2.2636481604430347, -0.6288648840517072, 1.8216554036501487, -0.8558995278800725,
     0.3824413743900929, 2.250749809598123, 1.8538008988284345],
    [-2.264578935408459, -0.6290995788052239, 1.8218459830022586, -0.8548007595320081,
     0.3826491082640665, 2.2500391575600722, 1.853870332625224],
    [[0.6730889712587615, -0.0011509991254647519, 0.7395606208897518, 0.23306288632036368],
     [-0.5390735922513784, -0.6853725474454586, 0.4895550360738996, -0.03633485046733893],
     [0.5063110693111664, -0.7281916961962251, -0.46193717612230306, 0.3162785287433482]],
)  # fmt: skip


@pytest.mark.parametrize("state", [RIDING_THE_DAMPER, PAST_THE_DAMPER], ids=["kept", "share"])
def test_a_panda_braking_towards_the_shelf_keeps_its_rows_on_both_engines(state) -> None:
    """No exact step (the strict step, on_stall=None): the braking stop would carry link 7
    towards the shelf's top faster than its row allows. The step keeps the rows where a step
    within the acceleration bands does, else breaks them by less than the stop; the compiled
    controller's step is the stepper's."""
    q0, q_prev, rows = (np.array(a, dtype=np.float64) for a in state)
    target = np.vstack([rows, [0.0, 0.0, 0.0, 1.0]])
    panda = load_robot("panda")
    options = dict(dt=0.001, qdd_max=10.0, v_max=1e6, w_max=1e6, on_stall=None,
                   scene=load_scene("panda-shelf"))  # fmt: skip
    stepper = Stepper(panda, **options)
    problem = stepper.problem(q0, target, q_prev)
    lower, upper = problem.step_bounds()[:2]
    G, g = problem.G, problem.h - problem.G @ problem.q0
    stop = np.clip(0.0, lower, upper)
    numpy_step = stepper.step(q0, target, q_prev)
    compiled = Lp2Controller(panda, compile="now", **options).step(q0, target, q_prev)
    assert numpy_step.status == compiled.status == "infeasible" and numpy_step.p == 0.0
    assert np.max(G @ stop - g) > 5e-6  # the stop alone: link 7 past its row
    for step in (numpy_step, compiled):
        assert np.all(step.dq >= lower - TOL) and np.all(step.dq <= upper + TOL)
    excess = np.max(G @ numpy_step.dq - g)
    if state is RIDING_THE_DAMPER:
        assert excess <= 1e-12
    else:
        assert 0.0 < excess < np.max(G @ stop - g)
    np.testing.assert_allclose(compiled.q, numpy_step.q, rtol=0, atol=1e-12)
