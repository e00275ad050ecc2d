"""The compiled LP2 path (lpik.fast) against the pure-numpy ratio test and the HiGHS LP."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st_h

pytest.importorskip("numba")

from core_reference import plausible_last  # noqa: E402
from core_strategies import examples  # noqa: E402
from lpik import tolerances  # noqa: E402
from lpik.check import task_residual  # noqa: E402
from lpik.exceptions import MissingBackendError  # noqa: E402
from lpik.fast import BatchArrays, layout, lp2_batch  # noqa: E402
from lpik.fast import arrays as fast_arrays  # noqa: E402
from lpik.fast import lp2_kernel as K  # noqa: E402
from lpik.fast.batch import BATCH_KERNELS  # noqa: E402
from lpik.highs import HighsSolver  # noqa: E402
from lpik.methods.lp2 import PATHS, affine_solution, lp2  # noqa: E402
from lpik.methods.lp2s import lp2s  # noqa: E402
from lpik.problem import Problem  # noqa: E402
from lpik.result import (  # noqa: E402
    INFEASIBLE,
    OFF_DIRECTION,
    OPTIMAL,
    RECOVERING,
    SOLVER_ERROR,
)
from lpik.robots.base import TaskModel  # noqa: E402
from lpik.robots.planar import planar_arm  # noqa: E402
from lpik.tolerances import EQUALITY_RTOL, STALL_P  # noqa: E402

#: Instances held to the HiGHS path (10,000 under the default profile; 100,000 under
#: ``thorough``), a fixed seed: each kind of case below is reached on a share of them.
N_RANDOM = examples(10000)

#: The tolerances the LP2 kernel reads; each must be lpik.tolerances' own object.
KERNEL_TOLERANCES = (
    "MAX_SCHUR_CONDITION",
    "SLACK_TOL",
    "RATE_TOL",
    "INTERVAL_TOL",
    "FULL_P",
    "FEASIBILITY_TOL",
    "EQUALITY_RTOL",
)


@pytest.mark.parametrize("name", KERNEL_TOLERANCES)
def test_kernel_tolerances_are_lpik_tolerances(name: str) -> None:
    """The kernel imports every tolerance from lpik.tolerances (no copied values); its answer's
    own check is lpik.check.loop_check, compiled."""
    from lpik import check
    from lpik.methods import ratio

    module = check if name in ("FEASIBILITY_TOL", "EQUALITY_RTOL") else K
    module = ratio if name == "SLACK_TOL" else module  # the ratio test's per-entry helpers
    assert getattr(module, name) is getattr(tolerances, name)


def test_the_layout_describes_the_buffer_once() -> None:
    """Blocks lie in the order of their header slots; the out blocks form one range."""
    assert [b.slot for b in layout.BLOCKS] == list(range(layout.REVOLUTE, layout.END))
    assert layout.HEADER == layout.END + 1
    names = [b.name for b in layout.BLOCKS]
    assert len(set(names)) == len(names)
    out = [b.name for b in layout.BLOCKS if layout.Q <= b.slot <= layout.PULL_SCALE]
    assert tuple(out) == layout.OUT_BLOCKS
    n, m, r = 7, 6, 2
    arrays = {
        b.name: np.full(layout.block_shape(b, n, m, r), float(b.slot))
        for b in layout.BLOCKS
        if b.name in layout.INPUT_BLOCKS
    }
    state = layout.pack(n, m, r, h_diag=True, dt=1e-3, v_max=0.5, w_max=1.0, **arrays)
    assert state.size == state[layout.END]
    assert tuple(state[[layout.N, layout.M, layout.R, layout.H_DIAG]]) == (n, m, r, 1.0)
    assert tuple(state[[layout.DT, layout.V_MAX, layout.W_MAX]]) == (1e-3, 0.5, 1.0)
    for block in layout.BLOCKS:
        start, stop = int(state[block.slot]), int(state[block.slot + 1])
        assert stop - start == np.prod(layout.block_shape(block, n, m, r)), block.name
        if block.name in arrays:
            assert (state[start:stop] == block.slot).all(), block.name
    fields = layout.out_fields(state)
    assert list(fields) == list(layout.OUT_BLOCKS)
    out_size = layout.out_range(state).stop - layout.out_range(state).start
    assert fields["q"] == slice(0, n) and fields["pull_scale"] == slice(out_size - 1, out_size)
    with pytest.raises(ValueError, match="block tip must be"):
        layout.pack(n, m, r, h_diag=True, dt=1e-3, v_max=0.5, w_max=1.0,
                    **{**arrays, "tip": np.eye(3)})  # fmt: skip
    with pytest.raises(ValueError, match="expected the blocks"):
        layout.pack(n, m, r, h_diag=True, dt=1e-3, v_max=0.5, w_max=1.0, tip=np.eye(4))


def test_compiled_path_without_numba_says_what_to_install(monkeypatch) -> None:
    problem = Problem(J=np.eye(2), dw=np.ones(2) * 1e-3, q0=np.zeros(2))
    assert "compiled" in PATHS
    monkeypatch.setitem(sys.modules, "numba", None)  # find_spec("numba") is None now
    for name in [m for m in sys.modules if m == "lpik.fast" or m.startswith("lpik.fast.")]:
        monkeypatch.delitem(sys.modules, name)
    with pytest.raises(MissingBackendError, match=r'pip install "lpik\[fast\]"'):
        lp2(problem, path="compiled")


def degenerate_problem(rng: np.random.Generator, n: int, m: int) -> Problem:
    """A random LP2 step, often degenerate: ties, on a bound, p = 0 or 1, binding multipliers."""
    J = rng.normal(size=(m, n))
    kind = rng.integers(0, 9)
    if kind == 0:  # a tie: two identical joints with identical bounds
        J[:, 1] = J[:, 0]
    if kind == 8:  # a singular J (dependent rows): the KKT matrix is singular, HiGHS takes it
        J[-1] = J[0] * rng.choice([1.0, -2.0])
    dw = rng.normal(size=m) * rng.choice([0.0, 1e-3, 1e-2, 0.1])
    q0 = rng.uniform(-2, 2, size=n)
    step = rng.uniform(1e-3, 2e-2, size=n)
    lower, upper = -step.copy(), step.copy()
    if kind == 0:
        lower[1], upper[1] = lower[0], upper[0]
    if kind == 1:  # start exactly on an end-stop
        j = rng.integers(n)
        (lower if rng.random() < 0.5 else upper)[j] = 0.0
    if kind == 2:  # q0 outside an end-stop by more than one step: infeasible
        lower[rng.integers(n)] = 1e-3
    kw: dict = {}
    if kind in (3, 4):  # multiplier bounds, often binding
        bound = rng.uniform(1e-4, 1e-1, size=m)
        kw.update(lam_min=-bound, lam_max=bound)
    if kind == 5:  # an extra row that q0 satisfies, sometimes tightly
        G = rng.normal(size=(1, n))
        kw.update(G=G, h=G @ q0 + rng.choice([0.0, 1e-3]))
    if kind == 6:  # smoothing term towards q_ref
        kw.update(Lambda=np.diag(rng.uniform(0, 1e-2, n)), q_ref=q0 + rng.normal(size=n) * 1e-2)
    if kind == 7:  # non-diagonal M
        A = rng.normal(size=(n, n))
        kw.update(M=A @ A.T + n * np.eye(n), f=rng.normal(size=n) * 1e-3)
    return Problem(
        J=J,
        dw=dw,
        q0=q0,
        q_min=q0 + lower,
        q_max=q0 + upper,
        dq_min=np.full(n, -0.05),
        dq_max=np.full(n, 0.05),
        **kw,
    )


def unique_minimum(problem: Problem) -> bool:
    """Whether exactly one constraint attains LP2's smallest ratio (no tie to break)."""
    aff = affine_solution(problem)
    if aff is None:
        return False
    lower, upper = problem.step_bounds()[:2]
    a = np.concatenate([aff.a_q, aff.a_l, problem.G @ aff.a_q])
    b = np.concatenate([aff.b_q, aff.b_l, problem.G @ aff.b_q])
    lo = np.concatenate([lower, problem.lam_min, np.full(problem.G.shape[0], -np.inf)])
    hi = np.concatenate([upper, problem.lam_max, problem.h - problem.G @ problem.q0])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = np.concatenate(
            [np.where(b > 0, (hi - a) / b, np.inf), np.where(b < 0, (lo - a) / b, np.inf)]
        )
    best = ratios.min()
    if not np.isfinite(best):
        return False
    return bool(np.sum(np.abs(ratios - best) <= 1e-9 * max(1.0, abs(best))) == 1)


@pytest.fixture(scope="module")
def random_batches() -> list[list[Problem]]:
    rng = np.random.default_rng(20261123)
    shapes = [(3, 2), (4, 2), (5, 3), (7, 6), (6, 3)]
    per_shape = N_RANDOM // len(shapes)
    batches = []
    for n, m in shapes:
        kinds: dict[int, list[Problem]] = {}
        for _ in range(per_shape):
            p = degenerate_problem(rng, n, m)
            kinds.setdefault(p.G.shape[0], []).append(p)
        batches.extend(kinds.values())
    return batches


def p_tolerance(problem: Problem) -> float:
    """How far two exact paths' ``p`` may differ: 1e-9, plus the rounding of LP2's KKT
    solve, about ten machine epsilons times its condition (``[[H, J^T], [J, 0]]``). A KKT
    matrix with a condition above 1e10 is singular to the kernel (the singular path's
    cases, which decide ``p`` without that solve): 1e-9 there."""
    m = problem.J.shape[0]
    kkt = np.block([[problem.M + problem.Lambda, problem.J.T], [problem.J, np.zeros((m, m))]])
    condition = np.linalg.cond(kkt)
    return 1e-9 + (1e-15 * condition if condition < 1e10 else 0.0)


#: A draw of the thorough hypothesis profile's 100,000 instances: a tie (J's first two
#: columns equal), cond(J) 1.3e4, the KKT matrix's condition 4e7; the compiled ratio test
#: and HiGHS found p = 0.1921201079 and 0.1921201061 (1.8e-9 apart, beyond a flat 1e-9).
ROUNDING_CASE = Problem(
    J=np.array([
        [1.0462512953142578, 1.0462512953142578, 1.661349333954861, 1.6195916820640537,
         1.132452288359152, -1.4520138930895516, -0.5410175561140224],
        [1.8500828033745726, 1.8500828033745726, -0.7859822179939498, 0.29459004316507575,
         -0.7724559043227681, -0.5485889734616349, 0.8906082690171595],
        [0.6410602144125228, 0.6410602144125228, -1.9275241023432004, 0.07143317038378849,
         0.18557127040721452, 0.17572547245376416, -0.005175149844424622],
        [-1.2524051867907176, -1.2524051867907176, 1.2727454508593241, -0.9246361311266647,
         0.37347949184717966, -0.654105075798211, 1.1507395853513118],
        [-0.9412133631059741, -0.9412133631059741, 1.1752098452298563, 0.7815656174558444,
         -0.8703954703615253, 0.9433807671442246, 0.13293287002162685],
        [0.5182364763618992, 0.5182364763618992, 0.7107828350317145, 1.2172341538707314,
         0.7432461414580168, -0.8506998098814548, 0.07853313205205248],
    ]),
    dw=np.array([1.1948473893474854e-03, -7.0658438720352869e-04, 7.5994358860285053e-05,
                 3.1845886643488922e-03, -4.2919917125208473e-04, 1.9074448405928940e-03]),
    q0=np.array([1.077017319693486, -1.63016080555701, -1.1709703005666152, 0.312770801996074,
                 -0.45409508303020285, -1.325063463898502, 1.5405462301436477]),
    q_min=np.array([1.0593590942663715, -1.6478190309841245, -1.179147349637561,
                    0.30731379523965885, -0.4724790474484197, -1.3415246516124186,
                    1.5329763667339595]),
    q_max=np.array([1.0946755451206005, -1.6125025801298956, -1.1627932514956694,
                    0.3182278087524891, -0.435711118611986, -1.3086022761845852,
                    1.5481160935533358]),
    dq_min=np.full(7, -0.05),
    dq_max=np.full(7, 0.05),
)  # fmt: skip


def test_p_agrees_within_the_rounding_of_an_ill_conditioned_kkt_solve() -> None:
    fast, ref = lp2(ROUNDING_CASE, path="compiled"), lp2(ROUNDING_CASE, path="highs")
    assert fast.status == ref.status == OPTIMAL and fast.binding == ref.binding
    assert abs(fast.p - ref.p) <= p_tolerance(ROUNDING_CASE)
    assert p_tolerance(ROUNDING_CASE) < 1e-7  # the condition is 4e7, not a singular K
    np.testing.assert_allclose(fast.q, ref.q, atol=1e-9, rtol=0)


def test_batch_equals_highs_on_random_degenerate_instances(random_batches) -> None:
    solver = HighsSolver()
    counts = {
        "p=0": 0,
        "p=1": 0,
        "0<p<1": 0,
        "safe step": 0,
        "singular K": 0,
        "multiplier binding": 0,
    }
    checked_bindings = 0
    total = 0
    for problems in random_batches:
        batch = lp2_batch(problems, method="lp2")
        for i, problem in enumerate(problems):
            total += 1
            fast = batch[i]
            ref = lp2(problem, path="highs", solver=solver)
            assert fast.status == ref.status, (i, fast, ref)
            singular = affine_solution(problem) is None  # the singular path's cases
            counts["singular K"] += singular
            if fast.status == INFEASIBLE or ref.lam is None:
                counts["safe step"] += 1
                np.testing.assert_allclose(fast.q, ref.q, atol=1e-12, rtol=0)  # the safe step
                continue
            assert fast.status in (OPTIMAL, RECOVERING)
            assert abs(fast.p - ref.p) <= p_tolerance(problem), (fast, ref)
            counts["p=0" if fast.p == 0 else "p=1" if fast.p == 1 else "0<p<1"] += 1
            np.testing.assert_allclose(fast.q, ref.q, atol=1e-9, rtol=0)  # q is unique
            if fast.path == "compiled" and not singular:  # lam too: K is nonsingular
                scale = max(1.0, float(np.abs(ref.lam).max()))
                np.testing.assert_allclose(fast.lam, ref.lam, atol=1e-9 * scale, rtol=0)
                if fast.binding is not None and unique_minimum(problem):
                    assert fast.binding == ref.binding, (problem, fast, ref)
                    checked_bindings += 1
            if fast.binding and fast.binding.startswith("multiplier"):
                counts["multiplier binding"] += 1
    assert total >= N_RANDOM - 10
    # The generator must really reach the degenerate cases it is meant to.
    assert all(v > N_RANDOM // 400 for v in counts.values()), counts  # 74 safe steps of 10,000
    assert checked_bindings > N_RANDOM // 20  # 4,139 of 10,000


def test_compiled_single_equals_numpy_ratio_test(random_batches) -> None:
    for problems in random_batches[:3]:
        for problem in problems[:500]:
            a = lp2(problem, path="ratio-test")
            b = lp2(problem, path="compiled")
            assert (a.status, a.binding) == (b.status, b.binding)
            assert b.path in ("compiled", "highs")
            assert abs(a.p - b.p) <= 1e-12
            np.testing.assert_allclose(a.q, b.q, atol=1e-12, rtol=0)


def test_batch_from_arrays_equals_batch_from_problems(random_batches) -> None:
    problems = random_batches[0][:300]
    from_problems = lp2_batch(problems)
    arrays = BatchArrays.from_problems(problems)
    from_arrays = lp2_batch(arrays)
    np.testing.assert_array_equal(from_problems.p, from_arrays.p)
    np.testing.assert_array_equal(from_problems.q, from_arrays.q)
    # raw arrays know bounds, not end-stops: a state outside them is not named
    for P, a, b in zip(problems, from_problems.status, from_arrays.status):
        assert a == b or (a == RECOVERING and P.recovering())


def test_batch_rejects_mixed_shapes() -> None:
    rng = np.random.default_rng(1)
    with pytest.raises(ValueError, match="problems"):
        lp2_batch([degenerate_problem(rng, 3, 2), degenerate_problem(rng, 4, 2)])
    with pytest.raises(ValueError, match="empty"):
        lp2_batch([])


def _raw_batch(**changes: object) -> dict:
    """The fields of a valid raw BatchArrays (B = 4, m = 2, n = 3, one row), with ``changes``."""
    rng = np.random.default_rng(7)
    B, m, n = 4, 2, 3
    fields = {
        "J": rng.normal(size=(B, m, n)),
        "dw": rng.normal(size=(B, m)) * 1e-2,
        "H": np.stack([np.diag([1.0, 2.0, 3.0])] * B),
        "c": rng.normal(size=(B, n)) * 1e-3,
        "lower": -np.ones((B, n)),
        "upper": np.ones((B, n)),
        "lam_min": np.full((B, m), -np.inf),
        "lam_max": np.full((B, m), np.inf),
        "G": rng.normal(size=(B, 1, n)),
        "g": np.ones((B, 1)),
        "q0": rng.normal(size=(B, n)),
    }
    fields.update(changes)
    return fields


def test_raw_batch_arrays_are_normalised_and_solved_like_problems() -> None:
    fields = _raw_batch()
    as_lists = BatchArrays(**{k: v.tolist() for k, v in fields.items()})  # lists, no h_diag
    assert as_lists.h_diag is True
    strided = BatchArrays(**{k: np.asfortranarray(v) for k, v in fields.items()}, h_diag=False)
    for arrays in (as_lists, strided):
        for name in ("J", "H", "q0", "G"):
            value = getattr(arrays, name)
            assert value.dtype == np.float64 and value.flags.c_contiguous
    full_H = fields["H"] + 0.5 * (1 - np.eye(3))  # symmetric, positive definite, not diagonal
    for arrays in (as_lists, strided, BatchArrays(**_raw_batch(H=full_H))):
        batch = lp2_batch(arrays, method="lp2")
        for i in range(4):
            one = lp2(fast_arrays.problem_at(arrays, i), path="highs")
            assert (batch.status_of(i), batch.binding_of(i)) == (one.status, one.binding)
            np.testing.assert_allclose(batch.q[i], one.q, atol=1e-9, rtol=0)
    assert BatchArrays(**_raw_batch(H=full_H)).h_diag is False


@pytest.mark.parametrize("method", ["lp2", "lp2s"])
def test_read_only_batch_arrays_take_the_kernel_already_compiled(method: str) -> None:
    fields = _raw_batch()
    expected = lp2_batch(BatchArrays(**fields), method=method)
    kernel = BATCH_KERNELS[method]
    signatures = len(kernel.signatures)
    read_only = {k: v.copy() for k, v in fields.items()}
    for value in read_only.values():
        value.flags.writeable = False
    arrays = BatchArrays(**read_only)
    assert all(getattr(arrays, k).flags.writeable for k in fields)
    batch = lp2_batch(arrays, method=method)
    assert len(kernel.signatures) == signatures  # numba compiled nothing more
    np.testing.assert_array_equal(batch.q, expected.q)
    np.testing.assert_array_equal(batch.p, expected.p)


#: Bad raw batch fields and the start of the error each must raise.
BAD_RAW_BATCHES = [
    (
        {"J": np.zeros((4, 2))},
        r"BatchArrays\.J: must have shape \(B, m, n\)",
    ),
    (
        {"J": np.zeros((0, 2, 3))},
        r"BatchArrays\.J: .*B, m, n >= 1",
    ),
    (
        {"dw": np.zeros((4, 3))},
        r"BatchArrays\.dw: must have shape \(B, m\) = \(4, 2\), got \(4, 3\)",
    ),
    (
        {"H": np.zeros((4, 2, 2))},
        r"BatchArrays\.H: must have shape \(B, n, n\) = \(4, 3, 3\)",
    ),
    (
        {"q0": np.zeros((3, 3))},
        r"BatchArrays\.q0: must have shape",
    ),
    (
        {"G": np.zeros((4, 3))},
        r"BatchArrays\.G: must have shape \(B, r, n\)",
    ),
    (
        {"g": np.zeros((4, 2))},
        r"BatchArrays\.g: must have shape \(B, r\) = \(4, 1\)",
    ),
    (
        {"c": [["a"] * 3] * 4},
        r"BatchArrays\.c: must be an array of numbers",
    ),
    (
        {"J": np.full((4, 2, 3), np.nan)},
        r"BatchArrays\.J: must be finite; item 0 has nan at \[0, 0\]",
    ),
    (
        {"dw": np.array([[0, 0]] * 3 + [[0, np.inf]])},
        r"BatchArrays\.dw: must be finite; item 3 has inf at \[1\]",
    ),
    (
        {"lower": np.full((4, 3), np.inf)},
        r"BatchArrays\.lower: must be finite or -inf; item 0",
    ),
    (
        {"upper": np.full((4, 3), -np.inf)},
        r"BatchArrays\.upper: must be finite or \+inf; item 0",
    ),
    (
        {"lam_max": np.full((4, 2), np.nan)},
        r"BatchArrays\.lam_max: must be finite or \+inf",
    ),
    (
        {"upper": np.full((4, 3), -2.0)},
        r"BatchArrays\.lower: item 0: lower\[0\] = -1 exceeds upper\[0\] = -2",
    ),
    (
        {"lam_min": np.ones((4, 2)), "lam_max": np.zeros((4, 2))},
        r"BatchArrays\.lam_min: item 0",
    ),
    (
        {"H": np.stack([np.eye(3)] * 3 + [np.triu(np.ones((3, 3)))])},
        r"BatchArrays\.H: must be symmetric; item 3",
    ),
    (
        {"H": np.stack([np.eye(3) + 0.1] * 4), "h_diag": True},
        r"BatchArrays\.h_diag: is True but H of item 0",
    ),
    (
        {"h_diag": "yes"},
        r"BatchArrays\.h_diag: must be True, False or None",
    ),
]


@pytest.mark.parametrize(("changes", "message"), BAD_RAW_BATCHES)
def test_raw_batch_arrays_reject_bad_input(changes: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        BatchArrays(**_raw_batch(**changes))


def test_raw_batch_with_an_indefinite_H_names_the_item() -> None:
    H = np.stack([np.diag([1.0, 2.0, 3.0])] * 2 + [np.diag([1.0, -2.0, 3.0])] * 2)
    for h_diag in (True, False):
        arrays = BatchArrays(**_raw_batch(H=H, h_diag=h_diag))
        with pytest.raises(ValueError, match=r"BatchArrays\.H: item 2: must be positive definite"):
            lp2_batch(arrays)


def test_batch_rejects_what_is_not_a_problem() -> None:
    rng = np.random.default_rng(2)
    with pytest.raises(ValueError, match=r"problems: item 1 is a dict, not a Problem"):
        lp2_batch([degenerate_problem(rng, 3, 2), {}])
    with pytest.raises(ValueError, match=r"problems: must be a sequence of Problems or a Batch"):
        lp2_batch(3)
    problem = degenerate_problem(rng, 3, 2)
    assert len(lp2_batch(problem for _ in range(3))) == 3  # any iterable of Problems


def _closed_loop_matches(controller, q, target, steps: int) -> dict[str, int]:
    """Run the compiled controller and, on every step, the numpy layers; they must agree.

    The controller takes the strict step (``on_stall=None``, the default): ``lp2``/``lp2s``
    on its problem is the method its kernel compiles. The opt-in stall stage is held equal
    to the numpy Stepper in tests/test_progress_compiled.py.
    """
    seen = {"compiled": 0, "binding": 0, "infeasible": 0}
    q_prev = None
    reference = lp2s if controller.method == "lp2s" else lp2
    # lp2s re-solves pass after pass: each pass's rounding adds up (1e-11 rad seen); under
    # acceleration limits p is the share of a change of the motion, dw - J last
    # (lpik.continuation), whose two terms nearly cancel while the arm cruises (3e-12 seen)
    tol = 1e-9 if controller.method == "lp2s" else 1e-10
    for _ in range(steps):
        fast = controller.step(q, target, q_prev)
        problem = controller.problem(q, target, q_prev)
        ref = reference(problem, path="ratio-test")
        assert (fast.status, fast.binding) == (ref.status, ref.binding)
        assert abs(fast.p - ref.p) <= tol
        np.testing.assert_allclose(fast.q, ref.q, atol=tol, rtol=0)
        if fast.lam is not None:
            np.testing.assert_allclose(fast.lam, ref.lam, atol=100 * tol, rtol=100 * tol)
            # (the two paths' second-order terms of the command, and their continued
            # motions, differ by rounding)
            assert abs(fast.residual - task_residual(problem, fast.dq, fast.p)) <= 1e-12
        seen["compiled"] += fast.path == "compiled"
        seen["binding"] += fast.binding is not None
        seen["infeasible"] += fast.status == INFEASIBLE
        q_prev, q = q, fast.q
    return seen


@pytest.mark.parametrize("saturate", [False, True])
def test_controller_equals_numpy_layers_planar(saturate: bool) -> None:
    from lpik.control.controller import Lp2Controller

    arm = planar_arm([1, 1, 1, 1], q_min=np.deg2rad([-180, -180, -180, -180]),
                     q_max=np.deg2rad([95, 180, 180, 180]), qd_max=1.0)  # fmt: skip
    controller = Lp2Controller(arm, dt=0.01, v_max=0.5, qdd_max=30.0, lambda_bound=0.5,
                               saturate=saturate, on_stall=None)  # fmt: skip
    seen = _closed_loop_matches(controller, np.deg2rad([60.0, -30, -30, -30]),
                                np.array([0.2, 0.866, 0.0]), 400)  # fmt: skip
    assert seen["compiled"] == 400 and (saturate or seen["binding"] > 50)


@pytest.mark.parametrize("saturate", [False, True])
def test_controller_equals_numpy_layers_planar_pose(saturate: bool) -> None:
    """The planar pose task (rows x, y, rz) through the chain step, toward a 4 x 4 pose."""
    from lpik.control.controller import Lp2Controller

    arm = planar_arm([1, 1, 1, 1], q_min=np.deg2rad([-180, -180, -180, -180]),
                     q_max=np.deg2rad([95, 180, 180, 180]), qd_max=1.0, task="pose")  # fmt: skip
    controller = Lp2Controller(arm, dt=0.01, v_max=0.5, w_max=1.0, qdd_max=30.0, saturate=saturate,
                               on_stall=None)  # fmt: skip
    target = _planar_pose(0.2, 0.866, np.pi / 2)
    seen = _closed_loop_matches(controller, np.deg2rad([60.0, -30, -30, -30]), target, 400)
    assert seen["compiled"] == 400 and (saturate or seen["binding"] > 50)


def _planar_pose(x: float, y: float, angle: float) -> np.ndarray:
    """The 4 x 4 pose of a planar tool at (x, y, 0), turned by ``angle`` about z."""
    c, s = np.cos(angle), np.sin(angle)
    pose = np.eye(4)
    pose[:2, :2] = [[c, -s], [s, c]]
    pose[:2, 3] = x, y
    return pose


@pytest.mark.parametrize("saturate", [False, True])
def test_controller_equals_numpy_layers_panda(saturate: bool) -> None:
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    target = panda.pose(q)
    target[:3, 3] += [0.3, -0.2, -0.2]
    controller = Lp2Controller(panda, dt=0.001, v_max=0.5, w_max=1.0, qdd_max=10.0,
                               Lambda=np.full(7, 1e-4), saturate=saturate,
                               on_stall=None)  # fmt: skip
    seen = _closed_loop_matches(controller, q, target, 600)
    assert seen["compiled"] == 600 and seen["binding"] > 10


def test_controller_rejects_bad_input() -> None:
    from lpik.control.controller import Lp2Controller

    controller = Lp2Controller(planar_arm([1, 1, 1]), dt=0.01)
    q, goal = np.array([0.1, 0.2, 0.3]), np.array([1.0, 1.0, 0.0])
    shapes = r"target: must be xyz \(3,\), a rotation \(3, 3\) or a pose \(4, 4\), got "
    bad = [
        ((np.zeros(2), goal), "q0: must have length 3"),
        (([0.1, 0.2], goal), "q0: must have length 3"),
        ((q, np.array([1.0, 1.0])), shapes + r"\(2,\)"),
        ((q, np.ones((2, 2))), shapes + r"\(2, 2\)"),
        ((np.array([0.1, np.nan, 0.2]), goal), "q0: contains NaN"),
        ((q, np.array([np.inf, 1.0, 0.0])), "target: contains NaN"),
        ((q, goal, np.array([0.1, 0.2, np.nan])), "q_prev: contains NaN"),
        ((q, goal, np.zeros(4)), "q_prev: must have length 3"),
        (("abc", goal), "q0: must be 3 numbers"),
        ((q, {"x": 1}), "target: must be numbers"),
    ]
    for args, message in bad:
        with pytest.raises(ValueError, match=message):
            controller.step(*args)
    with pytest.raises(ValueError, match="dt"):
        Lp2Controller(planar_arm([1, 1, 1]), dt=0.0)
    with pytest.raises(ValueError, match="model: expected a task model"):
        Lp2Controller(object(), dt=0.01)
    pose = Lp2Controller(_panda("pose"), dt=0.001)
    for target in (np.ones((2, 2)), np.ones(4), np.eye(4)[:3], np.full((4, 4), np.nan)):
        with pytest.raises(ValueError, match="target"):
            pose.step(np.zeros(7), target)


def _panda(task: str) -> TaskModel:
    from lpik.robots.registry import load_robot

    return load_robot("panda", task=task)


def test_controller_converts_other_inputs_to_the_same_step() -> None:
    """Lists, integers, strided and read-only arrays take the converting path: same answers."""
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration

    model = _panda("pose")
    controller = Lp2Controller(model, dt=0.001, qdd_max=10.0)
    q = home_configuration("panda")
    target = model.pose(q)
    target[:3, 3] += [0.05, -0.02, 0.03]
    prev = q - 1e-4
    ref = controller.step(q.copy(), target.copy(), prev.copy())
    assert ref.path == "compiled"
    frozen = q.copy()
    frozen.flags.writeable = False
    strided = np.repeat(q, 2)[::2]
    for args in (
        (list(q), target.tolist(), list(prev)),
        (frozen, target, prev),
        (strided, np.asfortranarray(target), prev),
        (tuple(q), target.astype(np.longdouble), prev.tolist()),
    ):
        got = controller.step(*args)
        np.testing.assert_array_equal(got.q, ref.q)
        assert (got.p, got.status, got.binding) == (ref.p, ref.status, ref.binding)
    whole = np.array([0, 0, 0, -2, 0, 2, 1])  # integers
    by_int = controller.step(whole, target)
    by_float = controller.step(whole.astype(float), target)
    assert by_int.status == by_float.status == OPTIMAL
    np.testing.assert_array_equal(by_int.q, by_float.q)
    # From rest the acceleration limits leave p below STALL_P: the step is held by an
    # acceleration limit, not stalled, so the stall stage (on_stall=1, the default) keeps
    # the direction; the strict step is the same step
    strict = Lp2Controller(model, dt=0.001, qdd_max=10.0, on_stall=None)
    assert by_int.p < STALL_P and by_int.binding.kind == "acceleration"
    np.testing.assert_array_equal(strict.step(whole, target).q, by_int.q)
    # xyz, a rotation and a pose address the same compiled step of a position task.
    position = Lp2Controller(_panda("position"), dt=0.001)
    by_xyz = position.step(q, np.ascontiguousarray(target[:3, 3]))
    by_pose = position.step(q, target)
    np.testing.assert_array_equal(by_xyz.q, by_pose.q)
    orientation = Lp2Controller(_panda("orientation"), dt=0.001)
    by_rotation = orientation.step(q, np.ascontiguousarray(target[:3, :3]))
    np.testing.assert_array_equal(by_rotation.q, orientation.step(q, target).q)


@pytest.mark.parametrize("saturate", [False, True])
def test_controller_labels_every_kind_of_binding_limit_as_the_numpy_layers(saturate: bool) -> None:
    """Random states of a planar arm bound by end-stops, velocity and acceleration
    limits, multiplier bounds and an extra row: the fused step names the same limit."""
    from lpik.control.controller import Lp2Controller

    rng = np.random.default_rng(7)
    qd_max = np.array([0.5, 0.8, 1.0, 1.2])
    arm = planar_arm([1.0, 0.8, 0.6, 0.4], q_min=np.full(4, -2.0), q_max=np.full(4, 2.0),
                     qd_max=qd_max)  # fmt: skip
    controller = Lp2Controller(
        arm, dt=0.05, v_max=2.0, qdd_max=np.array([4.0, 6.0, 8.0, 10.0]), lambda_bound=0.05,
        G=np.array([[1.0, 1.0, 0.0, 0.0]]), h=np.array([1.5]), row_labels=("elbow row",),
        saturate=saturate, on_stall=None,  # the strict step: lp2/lp2s's compiled twin
    )  # fmt: skip
    reference, tol = (lp2s, 1e-9) if saturate else (lp2, 1e-12)
    kinds: dict[str, int] = {}
    for _ in range(3000):
        q0 = rng.uniform(-2.0, 2.0, 4)
        q0[1] = min(q0[1], 1.5 - q0[0])  # start on the feasible side of the row
        # A last step within the velocity limits (else the numpy layers reject the bounds).
        prev = q0 - rng.uniform(-1.0, 1.0, 4) * qd_max * 0.05 * rng.integers(0, 2)
        target = arm.pose(q0) + np.append(rng.normal(0.0, 0.2, 2), 0.0)  # xyz, z = 0
        fast = controller.step(q0, target, prev)
        problem = controller.problem(q0, target, prev)
        # a stop that breaks the row, moved within it: the rows stage of both engines
        ref = controller.stepper.within_rows(problem, reference(problem, path="ratio-test"), prev)
        assert (fast.status, fast.binding) == (ref.status, ref.binding), (q0, prev, target)
        assert abs(fast.p - ref.p) <= tol
        np.testing.assert_allclose(fast.q, ref.q, atol=tol, rtol=0)
        for kind in ("end-stop", "velocity", "acceleration", "multiplier", "row"):
            if fast.binding and kind in fast.binding:
                kinds[kind] = kinds.get(kind, 0) + 1
        kinds[fast.status] = kinds.get(fast.status, 0) + 1
    assert {"end-stop", "velocity", "acceleration", "multiplier", "row"} <= set(kinds), kinds
    assert {OPTIMAL, INFEASIBLE} <= set(kinds), kinds


@pytest.mark.parametrize(("speed", "taken"), [(1.05, 1.0), (2.0, 0.0)])
def test_controller_takes_a_speed_beyond_its_limit_at_the_limit_or_at_rest(
    speed: float, taken: float
) -> None:
    """A last step faster than the velocity limit is a fault of the state (lpik.bands):
    within one step of acceleration past the limit (1.1 rad/s here) the joint is taken
    to move at its limit, beyond it at rest; the step is within one step of
    acceleration of that, and both paths say so."""
    from lpik.control.controller import Lp2Controller

    arm = planar_arm([1.0, 1.0, 1.0], qd_max=1.0)
    controller = Lp2Controller(arm, dt=0.01, qdd_max=10.0)
    q = np.array([0.3, 0.4, 0.5])
    prev = q - np.array([speed * 0.01, 0.0, 0.0])  # against a limit of 1 rad/s
    target = np.array([1.5, 1.5, 0.0])
    result = controller.step(q, target, prev)
    assert (result.status, result.binding) == (RECOVERING, "joint 1 upper velocity limit")
    decel = 10.0 * 0.01**2  # one step of the acceleration limit
    assert taken * 0.01 - decel - 1e-15 <= result.dq[0] <= taken * 0.01 + decel + 1e-15
    if taken:  # towards this target: full deceleration from the limit
        assert result.dq[0] == pytest.approx(0.01 - decel)
    ref = lp2s(controller.problem(q, target, prev), path="ratio-test")
    assert (ref.status, ref.binding) == (result.status, result.binding)
    np.testing.assert_allclose(result.q, ref.q, atol=1e-12, rtol=0)


def test_step_into_gives_the_steps_answers_without_a_result() -> None:
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration

    model = _panda("pose")
    controller = Lp2Controller(model, dt=0.001, qdd_max=10.0)
    twin = Lp2Controller(model, dt=0.001, qdd_max=10.0)
    q = home_configuration("panda")
    target = model.pose(q)
    target[:3, 3] += [0.3, -0.2, -0.2]
    out = np.empty(7)
    assert twin.last_status is None and twin.last_binding is None
    prev = None
    seen = set()
    for _ in range(300):
        ref = controller.step(q, target, prev)
        p = twin.step_into(q, target, prev, out=out)
        np.testing.assert_array_equal(out, ref.q)
        assert (p, twin.last_status, twin.last_binding) == (ref.p, ref.status, ref.binding)
        seen.add(ref.status)
        prev, q = q, out.copy()
    assert OPTIMAL in seen
    # A speed far beyond its limit: joint 1 is taken at rest (lpik.bands.rate_band).
    far = np.array([0.3, 0.4, 0.5, -1.0, 0.1, 1.0, 0.2])
    beyond = far - np.array([0.01, 0, 0, 0, 0, 0, 0])  # 10 rad/s: beyond reach in one step
    p = twin.step_into(far, target, beyond, out=out)
    ref = controller.step(far, target, beyond)
    assert (p, twin.last_status, twin.last_binding) == (ref.p, ref.status, ref.binding)
    np.testing.assert_array_equal(out, ref.q)
    assert ref.status == RECOVERING and ref.binding == "panda_joint1 upper velocity limit"
    assert abs(out[0] - far[0]) <= 10.0 * 0.001**2 * (1 + 1e-9)
    for bad in (np.empty(6), np.empty((2, 7)), np.empty(7, dtype=np.float32), [0.0] * 7):
        with pytest.raises(ValueError, match="out: must be a float64 array of shape"):
            twin.step_into(q, target, out=bad)


def _assert_rows_equal_steps(controller, batch, q0, targets, q_prev) -> None:
    """Every row of ``batch`` equals the controller's single step on that row.

    Rows are independent states: a row whose ``q_prev`` is the last row's ``q0`` would
    look to :meth:`step` like the next step of a loop and get the last row's target
    motion fed forward (lpik.command.TargetMotion); ``step_batch`` forgets it between
    rows, and so does the reference here.
    """
    for b in range(len(batch)):
        controller.reset()
        ref = controller.step(q0[b], targets[b], None if q_prev is None else q_prev[b])
        assert (batch.status_of(b), batch.binding_of(b)) == (ref.status, ref.binding), b
        assert abs(batch.p[b] - ref.p) <= 1e-12
        np.testing.assert_allclose(batch.q[b], ref.q, atol=1e-12, rtol=0)
        np.testing.assert_allclose(batch.dq[b], ref.dq, atol=1e-12, rtol=0)
        if ref.lam is None:
            assert np.isnan(batch.lam[b]).all()
        else:
            np.testing.assert_allclose(batch.lam[b], ref.lam, atol=1e-10, rtol=1e-10)
        item = batch[b]
        assert (item.status, item.binding, item.p) == (ref.status, ref.binding, batch.p[b])


def test_step_batch_equals_steps_panda() -> None:
    from lpik.control.controller import Lp2Controller

    model = _panda("pose")
    controller = Lp2Controller(model, dt=0.001, qdd_max=10.0, lambda_bound=2.0,
                               Lambda=np.full(7, 1e-4), on_stall=1)  # fmt: skip
    rng = np.random.default_rng(11)
    B = 400
    span = model.q_max - model.q_min
    q0 = model.q_min + span * rng.uniform(0.02, 0.98, size=(B, 7))
    # at rest, moving within reach, and moving fast (solved around the motion: lpik.continuation)
    speed = rng.choice([0.0, 1e-5, 1e-4, 1e-3], size=(B, 1))
    q_prev = q0 - speed * rng.normal(size=(B, 7))
    poses = np.stack([model.pose(q) for q in q0])
    poses[:, :3, 3] += rng.normal(size=(B, 3)) * rng.choice([0.0, 1e-4, 1e-2], size=(B, 1))
    batch = controller.step_batch(q0, poses, q_prev)
    _assert_rows_equal_steps(controller, batch, q0, poses, q_prev)
    statuses = set(batch.status)
    assert {OPTIMAL, INFEASIBLE, RECOVERING, OFF_DIRECTION} >= statuses >= {OPTIMAL}
    assert (batch.p == 1).any() and ((batch.p > 0) & (batch.p < 1)).any()
    # at rest (q_prev None), lists in
    at_rest = controller.step_batch(q0[:50].tolist(), poses[:50].tolist())
    _assert_rows_equal_steps(controller, at_rest, q0[:50], poses[:50], None)
    with pytest.raises(ValueError, match="^target: .* not xyz"):  # no rotation is made up
        controller.step_batch(q0[:50], poses[:50, :3, 3])


def test_step_batch_equals_steps_planar_with_singular_rows() -> None:
    from lpik.control.controller import Lp2Controller

    arm = planar_arm([1, 1, 1, 1], q_min=np.deg2rad([-180, -180, -180, -180]),
                     q_max=np.deg2rad([95, 180, 180, 180]), qd_max=1.0)  # fmt: skip
    controller = Lp2Controller(arm, dt=0.01, v_max=0.5, qdd_max=30.0, lambda_bound=0.5,
                               on_stall=1)  # rows with the stall stage, too  # fmt: skip
    rng = np.random.default_rng(5)
    B = 300
    q0 = rng.uniform(-1.5, 1.5, size=(B, 4))
    q0[:5] = 0.0  # stretched out: J is singular, the compiled singular path takes these rows
    q_prev = q0 - rng.normal(size=(B, 4)) * rng.choice([0.0, 1e-3, 1e-1], size=(B, 1))
    q_prev[:5] = 0.0  # at rest there
    targets = np.column_stack([rng.uniform(-2.0, 2.0, size=(B, 2)), np.zeros(B)])  # xyz
    batch = controller.step_batch(q0, targets, q_prev)
    _assert_rows_equal_steps(controller, batch, q0, targets, q_prev)
    assert set(batch.path) == {"compiled"}
    # the singular rows, against the general LP: the strict step (no stall stage) is lp2's twin
    strict = Lp2Controller(arm, dt=0.01, v_max=0.5, qdd_max=30.0, lambda_bound=0.5, on_stall=None)
    singular = strict.step_batch(q0[:5], targets[:5], q_prev[:5])
    assert set(singular.path) == {"compiled"}
    for b in range(5):
        reference = lp2(strict.problem(q0[b], targets[b], q_prev[b]), path="highs")
        assert (singular[b].status, singular[b].binding) == (reference.status, reference.binding)
        assert abs(singular.p[b] - reference.p) <= 1e-9
    assert OPTIMAL in set(batch.status) and {INFEASIBLE, RECOVERING} & set(batch.status)


def test_step_batch_rejects_bad_input() -> None:
    from lpik.control.controller import Lp2Controller

    controller = Lp2Controller(planar_arm([1, 1, 1]), dt=0.01)
    q, goal = np.full((4, 3), 0.2), np.ones((4, 3))
    nan_row = q.copy()
    nan_row[2, 1] = np.nan
    bad = [
        ((np.zeros(3), goal), r"q0: must have shape \(B, 3\) with B >= 1, got \(3,\)"),
        ((np.zeros((0, 3)), goal[:0]), r"q0: must have shape \(B, 3\) with B >= 1"),
        ((q, goal[:3]), r"targets: must have 4 rows \(one per row of q0\), got 3"),
        ((q, np.ones((4, 2))), r"targets: must have shape \(B, 3\) or \(B, 3, 3\) or \(B, 4, 4\)"),
        ((q, goal, np.zeros((4, 2))), r"q_prev: must have shape \(B, 3\)"),
        ((nan_row, goal), r"q0: row 2 contains NaN or inf"),
        ((q, goal, nan_row), r"q_prev: row 2 contains NaN or inf"),
        ((q, [["a", "b", "c"]] * 4), r"targets: must be numbers"),
    ]
    for args, message in bad:
        with pytest.raises(ValueError, match=message):
            controller.step_batch(*args)
    chain = Lp2Controller(_panda("pose"), dt=0.001)
    with pytest.raises(ValueError, match=r"targets: must have shape \(B, 3\) or \(B, 3, 3\) or"):
        chain.step_batch(np.zeros((2, 7)), np.zeros((2, 4)))


@st_h.composite
def fused_states(draw: st_h.DrawFn) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray | None]:
    """A random planar arm with end-stops, velocity and acceleration limits, and one state."""
    from lpik.control.controller import Lp2Controller

    n = draw(st_h.integers(3, 6))
    floats = lambda lo, hi: st_h.floats(lo, hi, allow_nan=False, allow_subnormal=False)  # noqa: E731
    lengths = [draw(floats(0.3, 1.5)) for _ in range(n)]
    centre = np.array([draw(floats(-1.0, 1.0)) for _ in range(n)])
    half = np.array([draw(floats(0.3, 2.5)) for _ in range(n)])
    task = draw(st_h.sampled_from(["position", "pose"]))
    arm = planar_arm(lengths, q_min=centre - half, q_max=centre + half,
                     qd_max=draw(floats(0.2, 2.0)), task=task)  # fmt: skip
    dt = draw(st_h.sampled_from([1e-3, 1e-2]))
    qdd = draw(st_h.sampled_from([None, 5.0, 50.0]))
    bound = draw(st_h.sampled_from([None, 0.05, 1.0]))
    on_stall = draw(st_h.sampled_from([None, 1]))  # the strict step (default) or the stall stage
    controller = Lp2Controller(arm, dt=dt, v_max=draw(floats(0.1, 1.0)), qdd_max=qdd,
                               lambda_bound=bound, on_stall=on_stall)  # fmt: skip
    q0 = centre + half * np.array([draw(floats(-1.0, 1.0)) for _ in range(n)])
    speed = draw(st_h.sampled_from([0.0, 0.1, 1.0]))  # of the previous step, in qd_max units
    q_prev = q0 - speed * dt * arm.qd_max * np.array([draw(floats(-1.0, 1.0)) for _ in range(n)])
    q_prev = None if draw(st_h.booleans()) and speed == 0.0 else q_prev
    offset = np.array([draw(floats(-0.5, 0.5)) for _ in range(arm.task_dim)])
    now = arm.pose(q0)
    if task == "position":  # xyz, z = 0
        goal = now + np.append(offset, 0.0)
    else:  # a 4 x 4 pose in the plane: x, y and the tool angle about z
        angle = np.arctan2(now[1, 0], now[0, 0])
        goal = _planar_pose(now[0, 3] + offset[0], now[1, 3] + offset[1], angle + offset[2])
    return controller, q0, goal, q_prev


@settings(max_examples=examples(300))
@given(state=fused_states())
def test_fused_step_keeps_every_hard_limit_and_moves_along_the_command(state) -> None:
    controller, q0, goal, q_prev = state
    arm, dt, n = controller.model, controller.dt, len(q0)
    res = controller.step(q0, goal, q_prev)
    event(f"{res.status}, p {'= 1' if res.p == 1 else '< 1' if res.p > 0 else '= 0'}")
    statuses = {OPTIMAL, INFEASIBLE, RECOVERING, SOLVER_ERROR, OFF_DIRECTION}
    assert res.status in statuses or res.path == "highs"
    assert 0.0 <= res.p <= 1.0
    np.testing.assert_allclose(res.q, q0 + res.dq, rtol=0, atol=1e-12)
    tol = 1e-9
    if controller.limits[-1].__class__.__name__ == "AccelerationLimits":  # always holds,
        # around the last step as the contract takes it (a fault at a limit)
        qdd = controller.limits[-1].qdd_max
        last = np.zeros(n) if q_prev is None else plausible_last(q0, q_prev, arm, qdd, dt)
        assert (np.abs(res.dq - last) <= qdd * dt * dt + tol).all()
    problem = controller.problem(q0, goal, q_prev)  # the clamped command dw and J(q0)
    if res.status == RECOVERING:  # q0 sits inside its end-stops: a speed beyond a limit
        assert problem.outside_limits and res.binding == problem.outside_limits[0]
    else:  # every limit holds
        assert (res.q >= arm.q_min - tol).all() and (res.q <= arm.q_max + tol).all()
        assert (np.abs(res.dq) <= arm.qd_max * dt + tol).all()
    lower, upper = problem.step_bounds()[:2]
    if res.status == OFF_DIRECTION:  # the stall stage (opt-in, on_stall=1): the strict
        # step stalled, and the step of least L1 task error within every bound was taken; it
        # leaves the commanded direction by design, so J dq = p dw is not asked of it
        assert res.p == 0.0 and res.lam is None
        assert (res.dq >= lower - tol).all() and (res.dq <= upper + tol).all()
    elif res.lam is None:  # the safe step: each joint comes to rest as fast as it may
        np.testing.assert_allclose(res.dq, np.clip(0.0, lower, upper), rtol=0, atol=1e-12)
        assert res.p == 0.0 and (res.binding is not None or res.status != INFEASIBLE)
        return
    else:  # J dq = p dw (eq. 12), around the current motion under acceleration limits,
        # within the library's own check (lpik.check): at a singular configuration the part
        # of a tiny second-order command that no joint can make (5e-9 m seen) is left
        assert task_residual(problem, res.dq, res.p) <= EQUALITY_RTOL
    batch = controller.step_batch(q0[None], goal[None], None if q_prev is None else q_prev[None])
    assert (batch.status_of(0), batch.binding_of(0)) == (res.status, res.binding)
    np.testing.assert_allclose(batch.q[0], res.q, rtol=0, atol=1e-12)
