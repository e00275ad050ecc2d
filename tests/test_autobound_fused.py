"""The automatic multiplier bound inside the fused step: the numpy rule's answers in one call.

Each fused step of the default controller is held to the step taken in pieces
as the controller took it before (its fused unbounded step, the numpy rule
:func:`lpik.methods.autobound.bound_for_step` on it, the fused step again
under that bound as a fixed one) and to the numpy layers throughout (LP2 or
lp2s on the step's problem, the rule, LP2 again on the problem with the
bound, as ``simulate`` takes it), at and near the Panda's singular
configurations (lpik_bench's singular workload) and at random ones.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.command import task_rows  # noqa: E402
from lpik.control.controller import Lp2Controller  # noqa: E402
from lpik.fast import layout  # noqa: E402
from lpik.limits import MultiplierBounds  # noqa: E402
from lpik.methods.autobound import bound_for_step  # noqa: E402
from lpik.methods.lp2 import lp2  # noqa: E402
from lpik.methods.lp2s import lp2s  # noqa: E402
from lpik.result import INFEASIBLE, RECOVERING, Result  # noqa: E402
from lpik_bench.singular import singular_workload  # noqa: E402

OPTIONS = {"dt": 1e-3, "v_max": 0.5, "w_max": 1.0, "on_stall": None}  # the method's step


@pytest.fixture(scope="module")
def states() -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    """Singular and near-singular starts (with their previous q), then random ones."""
    work = singular_workload(bases=1, seed=2)
    model = work.model
    rng = np.random.default_rng(7)
    B = 60
    span = model.q_max - model.q_min
    q = model.q_min + span * rng.uniform(0.02, 0.98, size=(B, 7))
    prev = q - rng.choice([0.0, 1e-4, 1e-3], size=(B, 1)) * rng.normal(size=(B, 7))
    targets = np.stack([model.pose(x) for x in q])
    targets[:, :3, 3] += rng.normal(size=(B, 3)) * rng.choice([1e-4, 1e-2, 0.5], size=(B, 1))
    return (model, np.vstack([work.q, q]), np.vstack([work.q_prev, prev]),
            np.concatenate([work.targets, targets]))  # fmt: skip


def options(controller: Lp2Controller) -> dict[str, Any]:
    """The keywords ``controller`` was built with (but its multiplier bound)."""
    qdd = next((lim.qdd_max for lim in controller.limits if hasattr(lim, "qdd_max")), None)
    return {**OPTIONS, "saturate": controller.method == "lp2s", "qdd_max": qdd}


def rule(controller: Lp2Controller, q: Any, free: Result) -> np.ndarray | None:
    """The numpy rule on the unbounded step ``free``."""
    model = controller.model
    return bound_for_step(controller.automatic_bound, model.jacobian, q, model.jacobian(q),
                          task_rows(model), controller.dt, free)  # fmt: skip


def stepwise(
    controller: Lp2Controller, q: Any, target: Any, prev: Any, free: Result | None = None
) -> tuple[Result, np.ndarray | None]:
    """The step in pieces: the fused unbounded step (or ``free``), the numpy rule on it, the
    fused step again under that bound as a fixed one; and the bound (None: unbounded)."""
    if free is None:
        free = Lp2Controller(controller.model, lambda_bound=None, **options(controller)).step(
            q, target, prev
        )
    bound = rule(controller, q, free)
    if bound is None:
        return free, None
    fixed = Lp2Controller(controller.model, lambda_bound=MultiplierBounds(-bound, bound),
                          **options(controller))  # fmt: skip
    return fixed.step(q, target, prev), bound


def numpy_step(controller: Lp2Controller, q: Any, target: Any, prev: Any) -> tuple[Result, bool]:
    """The step through the numpy layers, as ``simulate`` takes it; and whether it is bounded."""
    solve = lp2s if controller.method == "lp2s" else lp2
    problem = controller.problem(q, target, prev)
    free = solve(problem)
    bound = rule(controller, q, free)
    if bound is None:
        return free, False
    bounded = problem.replace(lam_min=np.maximum(problem.lam_min, -bound),
                              lam_max=np.minimum(problem.lam_max, bound))  # fmt: skip
    return solve(bounded), True


def block(controller: Lp2Controller, name: str) -> slice:
    """Where the state block ``name`` lies in the controller's state buffer."""
    slot = next(b.slot for b in layout.BLOCKS if b.name == name)
    return slice(int(controller._state[slot]), int(controller._state[slot + 1]))


@pytest.mark.parametrize("saturate", [False, True], ids=["lp2", "lp2s"])
@pytest.mark.parametrize("qdd_max", [None, 10.0], ids=["", "acc"])
def test_the_fused_step_equals_the_rule_and_lp2_under_its_bound(
    states, saturate: bool, qdd_max: float | None
) -> None:  # type: ignore[no-untyped-def]
    model, Q, P, T = states
    controller = Lp2Controller(model, saturate=saturate, qdd_max=qdd_max, **OPTIONS)
    assert controller.automatic_bound is not None  # the default
    bounded = 0
    for k in range(len(Q)):
        for prev in (None, P[k]):
            got = controller.step(Q[k], T[k], prev)
            assert got.path == "compiled"
            ref, bound = stepwise(controller, Q[k], T[k], prev)
            assert (got.status, got.binding) == (ref.status, ref.binding)
            assert abs(got.p - ref.p) <= 1e-12
            np.testing.assert_allclose(got.q, ref.q, atol=1e-12, rtol=0)
            # the numpy layers throughout: J's rounding times its condition number apart
            numpy, numpy_bounded = numpy_step(controller, Q[k], T[k], prev)
            assert (bound is not None, got.status) == (numpy_bounded, numpy.status)
            if got.status != INFEASIBLE:  # an infeasible step's conflict may be a tie (two
                # multiplier bounds at once, at a singular configuration, seen under acc. limits)
                assert got.binding == numpy.binding
            s = np.linalg.svd(model.jacobian(Q[k]), compute_uv=False)
            tol = 1e-13 * s[0] / s[-1] + 1e-10
            assert abs(got.p - numpy.p) <= tol
            np.testing.assert_allclose(got.q, numpy.q, atol=tol, rtol=0)
            bounded += bound is not None
    assert bounded >= 20, bounded  # the rule did bound steps (and kept others)


def test_the_kernel_reports_the_bound_and_restores_the_state(states) -> None:  # type: ignore[no-untyped-def]
    model, Q, P, T = states
    controller = Lp2Controller(model, **OPTIONS)
    at = block(controller, "bounded").start
    seen = set()
    for k in range(len(Q)):
        got = controller.step(Q[k], T[k], P[k])
        _, bound = stepwise(controller, Q[k], T[k], P[k])
        flag = controller._state[at]
        assert flag == (1.0 if bound is not None else 0.0 if got.moved else -1.0)
        if bound is not None:
            np.testing.assert_allclose(controller._state[block(controller, "bound")], bound,
                                       rtol=1e-9, atol=0)  # fmt: skip
        seen.add(flag)
        assert np.isinf(controller._state[block(controller, "lam_bounds")]).all()
    assert seen >= {0.0, 1.0}


def test_step_into_and_the_batch_take_the_bound_in_the_kernel(states, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """No Result for step_into, no row stepped again for the batch: the kernel decides."""
    model, Q, P, T = states
    controller, twin = Lp2Controller(model, **OPTIONS), Lp2Controller(model, **OPTIONS)
    calls = []
    step = twin.step
    monkeypatch.setattr(twin, "step", lambda *a, **k: calls.append(a) or step(*a, **k))
    out = np.empty(7)
    for k in range(len(Q)):
        ref = controller.step(Q[k], T[k], P[k])
        p = twin.step_into(Q[k], T[k], P[k], out=out)
        np.testing.assert_array_equal(out, ref.q)
        assert (p, twin.last_status, twin.last_binding) == (ref.p, ref.status, ref.binding)
    assert not calls
    batch = twin.step_batch(Q, T, P)
    assert len(calls) == int(np.sum(batch.status == RECOVERING))  # only those, one by one
    for b in range(len(Q)):
        ref = controller.step(Q[b], T[b], P[b])
        assert (batch.status_of(b), batch.binding_of(b)) == (ref.status, ref.binding)
        assert abs(batch.p[b] - ref.p) <= 1e-12
        np.testing.assert_allclose(batch.q[b], ref.q, atol=1e-12, rtol=0)


def test_a_step_on_the_highs_path_gets_the_rule_in_python(states, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    """Where HiGHS takes the unbounded step the fused step cannot apply the rule: the same
    rule, compiled, runs on HiGHS's step, then the fused step under its bound (forced here:
    the kernel's first call of a step answers "to HiGHS")."""
    from lpik.fast.lp2_kernel import SINGULAR

    model, Q, P, T = states
    # LP2's own fallback is HiGHS (lp2s falls back to its numpy passes)
    controller = Lp2Controller(model, saturate=False, **OPTIONS)
    kernel, on = controller._kernel, block(controller, "auto_bound").start
    bounded = 0
    for k in range(40):
        calls: list[int] = []

        def once(state, q0, prev, target, calls=calls):  # type: ignore[no-untyped-def]
            if calls:
                return kernel(state, q0, prev, target)
            state[on] = 0.0  # the unbounded step alone, as the kernel leaves it for HiGHS
            calls.append(kernel(state, q0, prev, target))
            state[on] = 1.0
            return SINGULAR

        monkeypatch.setattr(controller, "_kernel", once)
        got = controller.step(Q[k], T[k])
        free = lp2(controller.problem(Q[k], T[k]), path="highs")
        ref, bound = stepwise(controller, Q[k], T[k], None, free)
        assert got.path == ("highs" if bound is None else "compiled")
        assert (got.status, got.binding) == (ref.status, ref.binding)
        assert abs(got.p - ref.p) <= 1e-12
        np.testing.assert_allclose(got.q, ref.q, atol=1e-12, rtol=0)
        assert controller._state[on] == 1.0 and controller._bound is None  # restored
        bounded += bound is not None
    assert bounded > 0
