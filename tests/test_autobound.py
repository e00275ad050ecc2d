"""The automatic multiplier bound (lpik.methods.autobound): no chatter, no trap, exact elsewhere."""

from __future__ import annotations

import functools
import subprocess

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cli_documents import LPIK
from lpik.command import ClampedTarget, task_rows
from lpik.control.simulate import simulate
from lpik.limits import AutomaticMultiplierBounds, standard_limits
from lpik.methods.autobound import (
    automatic_bound,
    bound_for_step,
    clearly_regular,
    parameters,
    singular_memo,
    smallest_singular_value_grows,
)
from lpik.paper.scenarios import get_scenario
from lpik.result import Result


def jitter(log) -> float:  # type: ignore[no-untyped-def]
    return log.metrics().jitter


class TwoTargets:
    """Toward ``first`` for ``switch`` steps, then toward ``second`` (a command law)."""

    def __init__(self, first, second, switch: int) -> None:  # type: ignore[no-untyped-def]
        self.laws, self.switch, self.k = (ClampedTarget(first), ClampedTarget(second)), switch, 0

    def __call__(self, model, q, dt):  # type: ignore[no-untyped-def]
        law = self.laws[self.k >= self.switch]
        self.k += 1
        return law(model, q, dt)


def test_the_edge_singularity_without_chatter_as_the_papers_bound() -> None:
    """The paper's Figs. 8-9 run: unbounded LP2 chatters; the automatic bound, derived from
    dt and the arm alone, is as smooth as the bound the paper derived from the run."""
    setup = get_scenario("edge-singularity").setup()
    free, auto, paper = (  # the automatic bound is the default
        setup.run("lp2", lambda_bound=None, on_stall=None),
        setup.run("lp2", on_stall=None),
        setup.run("lp2", lambda_bound=0.1, on_stall=None),
    )
    assert jitter(auto) < 0.01 * jitter(free)
    assert jitter(auto) < 1.5 * jitter(paper)
    assert auto.p[-1] < 1e-3 and auto.binding[-1].kind == "multiplier"
    # it stops a step short of the singularity, as far out as the paper's bound does
    np.testing.assert_allclose(auto.position_end, paper.position_end, atol=5e-3)


@pytest.mark.parametrize("robot", ["planar", "panda"])
def test_pushed_beyond_reach_for_long_it_comes_back(robot: str) -> None:
    """A target held far out of reach, then back inside: recovered, without chatter."""
    setup = get_scenario("edge-singularity").setup(robot)
    model, q0 = setup.model, setup.q0
    home = np.asarray(model.pose(q0), dtype=float)  # a position task: x, y, z
    outside = home + home * [2.0, 2.0, 0.0]  # three times as far out, horizontally
    hold, back = (600, 400) if robot == "planar" else (1500, 1500)
    limits = [*standard_limits(model), AutomaticMultiplierBounds()]
    # lp2: the rule of sec. 3.2 alone (lp2s stalls here at joint 4's end-stop: a known bug)
    log = simulate(model, TwoTargets(outside, home, hold), q0, hold + back, dt=setup.dt,
                   limits=limits, method="lp2")  # fmt: skip
    error = np.linalg.norm(model.difference(model.pose(log.q_end), home))
    assert error < 1e-3, error
    assert log.metrics().jitter < 50.0
    assert (log.p[hold:] > 0).any() and set(log.status) <= {"optimal", "off_direction"}


def test_the_controller_follows_simulate_step_by_step() -> None:
    pytest.importorskip("numba")
    setup = get_scenario("edge-singularity").setup()
    log = setup.run("lp2", lambda_bound="auto")
    controller = setup.controller(lambda_bound="auto", saturate=False)
    assert isinstance(controller.automatic_bound, AutomaticMultiplierBounds)
    q, prev = setup.q0.copy(), None
    for k in range(setup.steps):
        np.testing.assert_allclose(q, log.q[k], rtol=0, atol=1e-9)
        res = controller.step(q, setup.target, prev)
        assert abs(res.p - log.p[k]) <= 1e-9 and res.binding == log.binding[k]
        prev, q = q, res.q
    # a batch of those states: each row as step() answers it
    targets = np.tile(np.asarray(setup.target, dtype=float), (setup.steps - 1, 1))
    batch = controller.step_batch(log.q[:-1], targets, np.vstack([log.q[:1], log.q[:-2]]))
    for b in range(0, setup.steps - 1, 37):
        res = controller.step(log.q[b], setup.target, log.q[max(b - 1, 0)])
        assert abs(batch.p[b] - res.p) <= 1e-12


def test_it_stays_out_of_the_way_where_the_command_is_followed() -> None:
    """p = 1, or far from a singularity: the unbounded step is kept (None)."""
    setup = get_scenario("pull-in").setup()
    model, limit = setup.model, AutomaticMultiplierBounds()
    q = setup.q0
    J = model.jacobian(q)
    full = Result(q=q, dq=np.zeros(q.size), p=1.0, lam=np.zeros(2), status="optimal",
                  binding=None, method="lp2")  # fmt: skip
    part = Result(q=q, dq=np.full(q.size, 1e-3), p=0.5, lam=np.zeros(2), status="optimal",
                  binding=None, method="lp2")  # fmt: skip
    rows = task_rows(model)
    assert bound_for_step(limit, model.jacobian, q, J, rows, 0.01, full) is None
    assert bound_for_step(limit, model.jacobian, q, J, rows, 0.01, part) is None  # regular J


def _rule(J, rows, dq=None, jacobian=None):  # type: ignore[no-untyped-def]
    """The rule's bounds on a step ``dq`` (none: the probe is not taken), or None."""
    J, bound = np.asarray(J, dtype=float), np.full(len(rows), np.nan)
    dq = np.zeros(J.shape[1]) if dq is None else dq
    settings = parameters(AutomaticMultiplierBounds())
    found = automatic_bound(settings, J, np.asarray(rows, float), 0.01, np.zeros(J.shape[1]), dq,
                            jacobian, bound, singular_memo())  # fmt: skip
    return bound if found else None


def test_the_bound_follows_its_formula_and_vanishes_at_the_floor() -> None:
    limit = AutomaticMultiplierBounds()
    J = np.array([[2.0, 0.0, 1.0], [0.0, 1e-2, 0.0]])
    s = np.linalg.svd(J, compute_uv=False)
    lever = np.linalg.svd(J[:1], compute_uv=False)[0]  # the position row's
    shrink = 1 - (limit.floor * s[0] / s[-1]) ** 2
    np.testing.assert_allclose(_rule(J, [0, 3]), 0.01 / limit.approach_time * shrink
                               / np.array([lever, 1.0]))  # fmt: skip
    at_floor = np.array([[2.0, 0.0], [0.0, 2e-3]])
    assert (_rule(at_floor, [0, 3]) == 0).all()
    assert _rule(np.diag([2.0, 0.2]), [0, 1]) is None  # sigma_min > activation sigma_max
    # the probe: a step that leaves the singularity keeps the unbounded step
    leaves = lambda q: np.diag([2.0, 1e-2 + q[1]])  # noqa: E731
    assert _rule(leaves([0, 0]), [0, 1], np.array([0.0, 1e-3]), leaves) is None
    assert _rule(leaves([0, 0]), [0, 1], np.array([0.0, -1e-3]), leaves) is not None


def test_the_fused_step_compiles_the_one_rule() -> None:
    """lpik.fast.autobound compiles lpik.methods.autobound.automatic_bound's own code."""
    pytest.importorskip("numba")
    from lpik.fast import autobound as compiled

    assert compiled.automatic_bound.py_func.__code__ is automatic_bound.__code__


@pytest.mark.parametrize(
    ("field", "value"), [("approach_time", 0.0), ("floor", np.nan), ("activation", 2.0)]
)
def test_bad_parameters_are_named(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        AutomaticMultiplierBounds(**{field: value})


def test_the_command_line_takes_auto_and_refuses_other_words(tmp_path) -> None:  # type: ignore[no-untyped-def]
    args = ["simulate", "edge-singularity", "--steps", "50", "--lambda-bound", "auto"]
    ok = subprocess.run([str(LPIK), *args, "--out", str(tmp_path / "run.csv")],
                        capture_output=True, text=True)  # fmt: skip
    assert ok.returncode == 0 and "edge-singularity, lp2" in ok.stdout
    bad = subprocess.run([str(LPIK), "simulate", "edge-singularity", "--lambda-bound", "often"],
                         capture_output=True, text=True)  # fmt: skip
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr.count("\n") == 1 and "--lambda-bound" in bad.stderr


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 6), st.integers(1, 8), st.integers(0, 2**32 - 1),
    st.floats(1e-3, 0.9), st.floats(-6, 1),
)  # fmt: skip
def test_the_cheap_regularity_test_never_says_regular_wrongly(m, n, seed, activation, scale):  # type: ignore[no-untyped-def]
    """clearly_regular (no SVD) implies step 1's sigma_min > activation sigma_max (of the
    min(m, n) singular values), compiled too."""
    pytest.importorskip("numba")
    from lpik.fast.autobound import clearly_regular as compiled_clearly_regular

    rng = np.random.default_rng(seed)
    J = rng.normal(size=(m, n)) * 10.0 ** rng.uniform(scale, 1, size=(m, 1))  # rows of mixed scale
    if rng.random() < 0.3 and m > 1:
        J[-1] = J[0] * (1 + 10.0 ** rng.uniform(-9, -1))  # nearly singular
    s = np.linalg.svd(J, compute_uv=False)
    regular = s[min(m, n) - 1] > activation * s[0]
    says = clearly_regular(J, activation)
    assert says == compiled_clearly_regular(J, activation)
    if says:
        assert regular


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 6), st.integers(1, 8), st.integers(0, 2**32 - 1), st.floats(-5, -0.5),
    st.floats(-12, -3), st.booleans(),
)  # fmt: skip
def test_the_probe_s_gram_test_answers_as_the_svd(m, n, seed, smallest, change, grows):  # type: ignore[no-untyped-def]
    """Step 2's probe (``sigma_min`` of the Jacobian a probe along the step away, at least
    ``J``'s?) by two Cholesky tests of the Gram matrix: the SVD's answer wherever the change
    of ``sigma_min`` lies beyond the SVD's rounding, numpy and compiled alike."""
    pytest.importorskip("numba")
    rng = np.random.default_rng(seed)
    k = min(m, n)
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    values = np.sort(rng.uniform(0.5, 2.0, k))[::-1]
    values[-1] = 10.0**smallest * values[0]
    J = (U[:, :k] * values) @ V[:, :k].T
    probe_values = values.copy()
    probe_values[-1] *= 1.0 + (1.0 if grows else -1.0) * 10.0**change
    J_probe = (U[:, :k] * probe_values) @ V[:, :k].T
    s = np.linalg.svd(J, compute_uv=False)
    s_probe = np.linalg.svd(J_probe, compute_uv=False)
    if abs(s_probe[-1] - s[-1]) <= 1e-13 * s[0]:
        return  # within the SVD's own rounding: no answer to agree on
    expected = bool(s_probe[-1] >= s[-1])
    assert smallest_singular_value_grows(J_probe, s[-1], s[0]) == expected
    assert _compiled_grows()(J_probe, s[-1], s[0]) == expected


@functools.cache
def _compiled_grows():  # type: ignore[no-untyped-def]
    """The probe's test compiled as the fused step binds it (Jacobi SVD, compiled Cholesky)."""
    from lpik.fast.autobound import _cholesky
    from lpik.fast.jacobi import singular_values
    from lpik.fast.twins import compiled_twin
    from lpik.methods import autobound

    return compiled_twin(autobound.smallest_singular_value_grows,
                         _singular_values=singular_values, **_cholesky)  # fmt: skip


def test_the_machine_epsilon_is_numpy_s() -> None:
    """tolerances.MACHINE_EPSILON, a plain literal for the kernels, is numpy's float eps."""
    from lpik.tolerances import MACHINE_EPSILON

    assert MACHINE_EPSILON == np.finfo(np.float64).eps
