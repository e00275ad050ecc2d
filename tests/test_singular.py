"""LP2's singular path (lpik.methods.singular): exact against HiGHS, the same compiled."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core_strategies import examples
from lpik.check import check_step
from lpik.labels import SINGULARITY
from lpik.methods.kkt import affine_solution
from lpik.methods.lp2 import lp2
from lpik.methods.singular import MAX_FACET_ROWS, MAX_FREE_MULTIPLIERS
from lpik.problem import Problem
from lpik.result import INFEASIBLE, OPTIMAL


def singular_problem(seed: int) -> Problem:
    """A step whose J (m = 6, n = 7) has rank 3 to 5 (1 to 5 under multiplier bounds: more
    than MAX_FREE_MULTIPLIERS free directions below rank 4)."""
    rng = np.random.default_rng(seed)
    n, m = 7, 6
    bounded = seed % 3 != 0
    rank = int(rng.integers(1 if bounded else 3, m))
    J = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))
    in_range = seed % 2 == 0
    dw = J @ rng.normal(size=n) * 1e-3 if in_range else rng.normal(size=m) * 1e-3
    step = rng.uniform(5e-4, 3e-3, size=n)
    kw: dict = {"dq_min": -step, "dq_max": step}
    if bounded:
        bound = rng.uniform(1e-4, 1e-2)
        kw.update(lam_min=np.full(m, -bound), lam_max=np.full(m, bound))
    if seed % 5 == 0:  # a pinned joint
        kw["dq_min"][0] = kw["dq_max"][0] = rng.uniform(-1e-4, 1e-4)
    if seed % 7 == 0:  # sec. 3.1's smoothing term
        kw.update(Lambda=np.full(n, 0.1), q_ref=rng.normal(size=n) * 0.1)
    if seed % 4 == 1:  # an extra row
        kw.update(G=rng.normal(size=(1, n)), h=[1e-3])
    return Problem(J=J, dw=dw, q0=np.zeros(n), q_min=-np.ones(n), q_max=np.ones(n), **kw)


def assert_equals_highs(problem: Problem) -> None:
    reference = lp2(problem, path="highs")
    for path in ("auto", "compiled"):
        res = lp2(problem, path=path)
        assert res.path in ("singular", "compiled"), res
        assert res.status == reference.status, (res, reference)
        assert abs(res.p - reference.p) <= 1e-7, (res, reference)
        np.testing.assert_allclose(res.q, reference.q, atol=1e-9, rtol=0)  # dq is unique
        if res.status == OPTIMAL:
            assert check_step(problem, res.dq, res.p, res.lam) is None
            if res.p < 1.0:
                assert res.binding == SINGULARITY or res.binding in reference_labels(problem)
    auto, compiled = lp2(problem), lp2(problem, path="compiled")
    assert_alike(auto, compiled)


def assert_alike(a, b, tol: float = 1e-9) -> None:
    """The numpy and the compiled singular path: the same code, with different SVDs (LAPACK,
    one-sided Jacobi); where several multiplier bounds tie, the two name either."""
    assert a.status == b.status and (a.binding is None) == (b.binding is None)
    if a.binding != b.binding:
        assert a.binding.kind == b.binding.kind == "multiplier", (a.binding, b.binding)
    # (the two SVDs' rounding, amplified where J is ill-conditioned)
    assert abs(a.p - b.p) <= tol
    np.testing.assert_allclose(a.q, b.q, atol=tol, rtol=0)


def reference_labels(problem: Problem) -> set[str]:
    lower, upper = problem.step_bounds()[2:]
    lam_lo, lam_hi = problem.multiplier_labels()
    return {*lower, *upper, *lam_lo, *lam_hi, *problem.row_labels}


@pytest.mark.parametrize("seed", range(120))
def test_the_singular_path_equals_highs(seed: int) -> None:
    pytest.importorskip("numba")
    problem = singular_problem(seed)
    assert affine_solution(problem) is None  # K is singular: the ratio test cannot answer
    assert_equals_highs(problem)


@settings(max_examples=examples(60), deadline=None)
@given(
    # J's rows are 0 or of order 1 (a row of order 1e-10 makes HiGHS's answer a tolerance's)
    heading=st.one_of(st.just(0.0), st.floats(0.01, 3.0), st.floats(-3.0, -0.01)),
    stretch=st.one_of(st.just(0.0), st.floats(0.0, 1e-7)),
    # each component 0 or above the tolerances of the paths (HiGHS's and the singular path's)
    target=st.tuples(*[st.one_of(st.just(0.0), st.floats(-0.01, 0.01))] * 2),
    bound=st.one_of(st.none(), st.floats(1e-4, 10.0)),
)
def test_the_stretched_planar_arm_equals_highs(heading, stretch, target, bound) -> None:
    """At the edge singularity (all relative angles 0) the answer is HiGHS's; within a hair
    of it a valid step of the nearby singular J (lpik.methods.singular), the same compiled."""
    pytest.importorskip("numba")
    from lpik.robots.planar import planar_arm

    arm = planar_arm([1.0, 1.0, 1.0, 1.0], qd_max=1.0)
    q0 = np.array([heading, stretch, -stretch, 0.0])
    lam = {} if bound is None else {"lam_min": [-bound] * 2, "lam_max": [bound] * 2}
    problem = Problem(J=arm.jacobian(q0), dw=np.array(target), q0=q0, dq_min=np.full(4, -0.01),
                      dq_max=np.full(4, 0.01), **lam)  # fmt: skip
    if affine_solution(problem) is not None:
        return  # regular enough for the ratio test
    # the command's part that J cannot produce (along the arm): 0, or above the tolerances
    out_of_range = abs(target[0] * np.cos(heading) + target[1] * np.sin(heading))
    if stretch == 0.0 and (out_of_range == 0.0 or out_of_range > 1e-6):
        assert_equals_highs(problem)
    else:
        assert_valid_and_compiled_alike(problem)


def assert_valid_and_compiled_alike(problem: Problem) -> None:
    res, compiled = lp2(problem), lp2(problem, path="compiled")
    assert res.path == "singular" and compiled.path == "compiled"
    assert_alike(res, compiled, tol=1e-6)  # J within 1e-7 of singular: its rounding amplified
    if res.status == OPTIMAL:
        assert 0.0 <= res.p <= 1.0 and check_step(problem, res.dq, res.p, res.lam) is None


def test_a_command_out_of_range_holds_p_at_zero_and_names_the_singularity() -> None:
    J = np.array([[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]])  # y cannot move
    problem = Problem(J=J, dw=[0.01, 0.01], q0=np.zeros(3), dq_min=-np.ones(3), dq_max=np.ones(3))
    res = lp2(problem)
    assert (res.path, res.status, res.p, res.binding) == ("singular", OPTIMAL, 0.0, SINGULARITY)
    along = lp2(Problem(J=J, dw=[0.01, 0.0], q0=np.zeros(3), dq_min=-np.ones(3),
                        dq_max=np.ones(3)))  # fmt: skip
    assert (along.path, along.p, along.binding) == ("singular", 1.0, None)
    np.testing.assert_allclose(along.dq, np.full(3, 0.01 / 3))  # the least-norm step


@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1e-160])
@pytest.mark.parametrize("method", ["lp2", "lp2s"])
def test_a_jacobian_of_vanishing_entries_cannot_move_the_task(scale: float, method: str) -> None:
    """J's entries near 1e-300: the singular path divided by a singular value's square that
    underflowed to 0 and returned a non-finite step (check_failed) with RuntimeWarnings.
    Below SINGULAR_FLOOR the value counts as 0: p = 0, the singularity named, no motion,
    and the condition bound's 0 * inf (NaN) counts as singular. Both paths, no warning."""
    import warnings

    from lpik.methods.lp2s import lp2s
    from lpik.tolerances import SINGULAR_FLOOR

    J = np.array([[scale, 0.0], [0.0, 2.0 * scale]])
    problem = Problem(J=J, dw=[0.01, 0.01], q0=np.zeros(2), dq_min=-np.ones(2),
                      dq_max=np.ones(2), Lambda=[0.1, 0.1], q_ref=[0.2, -0.2])  # fmt: skip
    for path in ("auto", "compiled"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            res = (lp2 if method == "lp2" else lp2s)(problem, path=path)
        assert res.status == OPTIMAL and np.isfinite(res.q).all(), (path, res)
        if scale < SINGULAR_FLOOR:
            assert (res.p, res.binding) == (0.0, SINGULARITY)
        else:  # tiny but a normal number: the exact step
            assert 0.0 <= res.p <= 1.0
        np.testing.assert_allclose(J @ res.dq, res.p * problem.dw, rtol=0, atol=1e-15)


def test_a_pinned_joint_whose_motion_is_out_of_range_is_infeasible() -> None:
    J = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    # joint 3 is pinned at dq = 0.01 but its motion (y) is not commanded: no p can hold it
    problem = Problem(J=J, dw=[0.01, 0.0], q0=np.zeros(3), dq_min=[-1, -1, 0.01],
                      dq_max=[1, 1, 0.01])  # fmt: skip
    for path in ("auto", "compiled"):
        res = lp2(problem, path=path)
        assert res.status == lp2(problem, path="highs").status == INFEASIBLE
        # the pinned joint would have to move down, not a singular configuration
        assert res.binding == "joint 3 lower velocity limit", path


@pytest.mark.parametrize("method", ["lp2", "lp2s"])
def test_a_joint_pinned_along_the_command_is_named_not_a_singularity(method: str) -> None:
    """Two of the Panda's joints braking at their acceleration limits (lower == upper)
    left LP2's free joints without a direction of the command: the step was told
    "singularity" far from one (the task Jacobian's sigma_min / sigma_max 0.04 to 0.14;
    128 of 40,000 steps over ten random goals). The pinned joint is named, on the side it
    would have to move, as LP1 (HiGHS) names it."""
    from lpik.methods.lp1 import lp1
    from lpik.methods.lp2s import lp2s

    solve = lp2 if method == "lp2" else lp2s
    J = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    for sign, side in ((1.0, "upper"), (-1.0, "lower")):  # x moves with joint 1 only
        problem = Problem(J=J, dw=[sign * 0.01, 0.005], q0=np.zeros(3), q_min=[0.0, -1, -1],
                          q_max=[0.0, 1, 1])  # fmt: skip
        reference = lp1(problem)
        for path in ("auto", "compiled", "highs"):
            res = solve(problem, path=path)
            assert (res.status, res.p) == (OPTIMAL, 0.0), path
            assert res.binding == reference.binding == f"joint 1 {side} end-stop", path


def test_many_free_multiplier_directions_under_finite_bounds_are_solved_without_highs() -> None:
    n, m = 5, 4  # J = 0: every multiplier direction is free
    problem = Problem(J=np.zeros((m, n)), dw=np.zeros(m), q0=np.zeros(n),
                      lam_min=np.full(m, -1.0), lam_max=np.full(m, 1.0))  # fmt: skip
    assert m > MAX_FREE_MULTIPLIERS
    res = lp2(problem)
    assert (res.path, res.p) == ("singular", 1.0)
    np.testing.assert_array_equal(res.lam, np.zeros(m))  # the multipliers nearest 0
    one_sided = problem.replace(lam_min=np.full(m, -np.inf))  # an infinite bound: HiGHS
    assert lp2(one_sided).path == "highs"
    rows = MAX_FACET_ROWS + 1  # too many multipliers to enumerate their box's vertices: HiGHS
    many = Problem(J=np.zeros((rows, n)), dw=np.zeros(rows), q0=np.zeros(n),
                   lam_min=np.full(rows, -1.0), lam_max=np.full(rows, 1.0))  # fmt: skip
    assert lp2(many).path == "highs" and lp2(many).p == 1.0
    unbounded = Problem(J=np.zeros((m, n)), dw=np.zeros(m), q0=np.zeros(n))
    assert lp2(unbounded).path == "singular" and lp2(unbounded).p == 1.0


def free_directions(seed: int) -> int:
    problem = singular_problem(seed)
    return problem.m - int(np.linalg.matrix_rank(problem.J))


#: Bounded seeds without extra rows or smoothing whose J leaves more than
#: MAX_FREE_MULTIPLIERS multiplier directions free.
WIDE_SEEDS = [s for s in range(120) if s % 3 and s % 7 and s % 4 != 1
              and free_directions(s) > MAX_FREE_MULTIPLIERS][:12]  # fmt: skip


@pytest.mark.parametrize("seed", WIDE_SEEDS)
@pytest.mark.parametrize("scale", [1e-2, 1e-4])
def test_tight_multiplier_bounds_over_many_free_directions_equal_highs(seed, scale) -> None:
    """Bounds tight enough to hold p (or leave no step) where more multiplier directions are
    free than Fourier-Motzkin eliminates: the facets of the bounds' image hold it as HiGHS."""
    pytest.importorskip("numba")
    problem = singular_problem(seed)
    problem = problem.replace(lam_min=problem.lam_min * scale, lam_max=problem.lam_max * scale)
    assert_equals_highs(problem)


def nearly_singular_problem(seed: int) -> Problem:
    """A step under acceleration-like bounds whose J's smallest singular value is 1e-10 to
    1e-6 (above SINGULAR_RTOL: a regular direction), its multipliers bounded."""
    rng = np.random.default_rng(seed)
    n, m = 7, 6
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    s = np.sort(rng.uniform(0.3, 2.0, size=m))[::-1]
    s[-1] = 10 ** -rng.uniform(6, 10)
    center, width = rng.normal(size=n) * 1e-5, rng.uniform(0, 2e-5, size=n)
    if seed % 2:
        width[rng.integers(n)] = 0.0  # a pinned joint
    bound = 10 ** -rng.uniform(1, 3)
    return Problem(J=U @ np.diag(s) @ V[:m], dw=rng.normal(size=m) * 1e-4, q0=np.zeros(n),
                   dq_min=center - width, dq_max=center + width, lam_min=np.full(m, -bound),
                   lam_max=np.full(m, bound))  # fmt: skip


def test_an_interval_closed_by_a_fast_multiplier_takes_the_step_within_tolerance() -> None:
    """Joint 2 moves y with a lever of 1e-8 and a pinned joint adds 5e-17 to y: the multiplier
    along y is (5e-17 + p e) / 1e-16, within its bound 0.01 only for p in a window 1e-14 wide
    around -5e-13, an interval of p empty by less than INTERVAL_TOL. At p = 0 the multiplier
    sits on its bound and eq. 18's rows give dq for it: J dq = p dw within its tolerance, the
    answer HiGHS gives, found without HiGHS."""
    pytest.importorskip("numba")
    J = np.array([[1.0, 0.0, 0.0], [0.0, 1e-8, 1.0]])
    problem = Problem(J=J, dw=[0.0, 1e-4], q0=np.zeros(3), dq_min=[-1e-5, -1e-5, -5e-17],
                      dq_max=[1e-5, 1e-5, -5e-17], lam_min=[-0.01, -0.01],
                      lam_max=[0.01, 0.01])  # fmt: skip
    assert_equals_highs(problem)
    res = lp2(problem)
    assert (res.status, res.p) == (OPTIMAL, 0.0)
    np.testing.assert_allclose(res.lam, [0.0, -0.01], atol=1e-15)
    np.testing.assert_allclose(res.dq, [0.0, 1e-10, -5e-17], rtol=1e-9, atol=1e-20)


@pytest.mark.parametrize("seed", range(40))
def test_a_nearly_singular_step_is_answered_without_highs(seed: int) -> None:
    """A multiplier along a direction of singular value s moves by 1/s^2 per unit of p: where
    its row closes the interval of p to a point that rounding breaks, there is no step (a
    safe stop), not a check failure handed to HiGHS. Every step HiGHS finds infeasible is;
    an optimal one has HiGHS's p. (HiGHS, within its tolerances, can find a p in a window
    of width bound s^2 / |dw| that the exact intervals miss: then only this path stops.)"""
    pytest.importorskip("numba")
    problem = nearly_singular_problem(seed)
    res, reference = lp2(problem), lp2(problem, path="highs")
    assert res.path in ("singular", "ratio-test"), res
    if reference.status == INFEASIBLE or res.status == OPTIMAL:
        assert res.status == reference.status and abs(res.p - reference.p) <= 1e-7
    if res.status == OPTIMAL:
        assert check_step(problem, res.dq, res.p, res.lam) is None
    compiled = lp2(problem, path="compiled")  # (another SVD: the conflict it names may differ)
    assert compiled.status == res.status and abs(compiled.p - res.p) <= 1e-6
    np.testing.assert_allclose(compiled.q, res.q, atol=1e-6, rtol=0)


@pytest.mark.parametrize("seed", range(60))
def test_multipliers_held_at_one_value_are_solved_without_highs(seed: int) -> None:
    """Every multiplier held (``lam_min == lam_max``: the automatic bound's floor holds them at
    0) gives ``lam``, however many free directions ``J`` leaves: the singular path answers,
    as HiGHS does, and compiled the same."""
    pytest.importorskip("numba")
    problem = singular_problem(3 * seed)  # unbounded, J of rank 3 to 5
    free = problem.m - np.linalg.matrix_rank(problem.J)
    held = np.zeros(problem.m)
    if seed % 2:  # held at a multiplier of the unbounded step: the same p
        unbounded = lp2(problem)
        if unbounded.status != OPTIMAL:
            return
        held = unbounded.lam
    problem = problem.replace(lam_min=held, lam_max=held)
    res = lp2(problem)
    assert res.path == "singular", (free, res)
    assert_equals_highs(problem)
    if res.status == OPTIMAL:
        np.testing.assert_array_equal(res.lam, held)
        if seed % 2:
            assert abs(res.p - unbounded.p) <= 1e-9


def test_the_controller_takes_the_panda_singularity_compiled() -> None:
    """The Panda stretched out (joint 4 at its singular angle, then exactly singular J):
    every step compiled, the numpy singular path's answer; HiGHS's where J is singular."""
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    model = load_robot("panda")
    q = home_configuration("panda")
    q[3] = -0.467002424  # sigma_min(J) ~ 1e-10
    rng = np.random.default_rng(3)
    for bound in (None, 0.1):
        controller = Lp2Controller(model, dt=1e-3, lambda_bound=bound, on_stall=None)
        for _ in range(20):
            target = model.pose(q)
            target[:3, 3] += rng.normal(size=3) * 0.05
            res = controller.step(q, target)
            assert res.path == "compiled"
            problem = controller.problem(q, target)
            assert affine_solution(problem) is None
            numpy = lp2(problem)
            assert (numpy.path, numpy.status, numpy.binding) == ("singular", res.status,
                                                                 res.binding)  # fmt: skip
            # J's rounding (fused kinematics against numpy's) times J's condition number
            assert abs(res.p - numpy.p) <= 1e-6
            np.testing.assert_allclose(res.q, numpy.q, atol=1e-7, rtol=0)
            # the same J made exactly singular: HiGHS's answer
            u, s, vt = np.linalg.svd(problem.J)
            s[-1] = 0.0
            exact = problem.replace(J=(u[:, :6] * s) @ vt[:6])
            assert_equals_highs(exact)


def test_the_jacobi_singular_values_alone_are_those_of_its_svd() -> None:
    """lpik.fast.jacobi.singular_values (the automatic bound's) rotates as jacobi_svd does,
    without V: the same values to the bit, and numpy's within rounding."""
    pytest.importorskip("numba")
    from lpik.fast.jacobi import jacobi_svd, singular_values

    rng = np.random.default_rng(9)
    for m, n in [(6, 7), (3, 7), (2, 4), (6, 6), (4, 2)]:
        for rank in range(1, min(m, n) + 1):
            A = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))
            s = singular_values(A)
            np.testing.assert_array_equal(s, jacobi_svd(A)[1])
            np.testing.assert_allclose(s, np.linalg.svd(A, compute_uv=False), rtol=0,
                                       atol=1e-13 * s[0])  # fmt: skip


@settings(max_examples=examples(60), deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([(6, 7), (6, 6), (3, 7), (6, 3)]),
       st.integers(1, 6), st.integers(0, 4))  # fmt: skip
def test_the_jacobi_svd_of_a_rank_deficient_matrix_stops_within_a_few_sweeps(
    seed: int, shape: tuple[int, int], rank: int, zero_columns: int
) -> None:
    """Rows at rounding level (the Jacobian over the free joints where some are pinned: zero
    columns) are not rotated: their noise is never orthogonal, and the sweeps ran to the
    limit of 60 (40 us of LP2's singular path on the UR5e). The singular values stay
    numpy's within rounding, and ``U`` and ``Vt`` still decompose ``A``."""
    pytest.importorskip("numba")
    from lpik.fast.jacobi import MAX_SWEEPS, jacobi_svd, orthogonalize

    rng = np.random.default_rng(seed)
    m, n = shape
    rank = min(rank, m, n)
    A = rng.normal(size=(m, rank)) @ rng.normal(size=(rank, n))
    A[:, rng.permutation(n)[: min(zero_columns, n - 1)]] = 0.0
    sweeps = orthogonalize(A.copy(), np.eye(m))
    assert sweeps <= 12 < MAX_SWEEPS
    U, s, Vt = jacobi_svd(A)
    np.testing.assert_allclose(s, np.linalg.svd(A, compute_uv=False), rtol=0, atol=1e-13 * s[0])
    k = s.size
    np.testing.assert_allclose((U[:, :k] * s) @ Vt[:k], A, rtol=0, atol=1e-13 * s[0])
