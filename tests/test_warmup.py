"""The first controller starts at once (lpik.control.warmup): numpy steps, then compiled ones.

A controller built with ``compile="background"`` on a cold numba cache steps on the
numpy engine while a child process compiles its kernels, then moves to the compiled
step. The trajectory must be the one a controller compiled from its first step
takes: these tests hold the two equal across the switch, check the cold start in a
fresh process with an empty cache, and the child's failure.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytest.importorskip("numba")

from lpik.control import controller as controller_module  # noqa: E402
from lpik.control.controller import Lp2Controller  # noqa: E402
from lpik.control.warmup import compile_mode  # noqa: E402
from lpik.fast.signatures import load_cached  # noqa: E402
from lpik.fast.step import STEP_SIGNATURES, step_kernel  # noqa: E402
from lpik.paper.scenarios import get_scenario  # noqa: E402
from lpik.result import OFF_DIRECTION  # noqa: E402
from lpik.robots.registry import home_configuration, load_robot  # noqa: E402


class FakeWarmup:
    """A child that finishes after ``steps`` checks, with ``failure`` (None: it succeeded)."""

    def __init__(self, steps: int, failure: str | None = None) -> None:
        self.steps, self._failure = steps, failure

    def finished(self) -> bool:
        self.steps -= 1
        return self.steps < 0

    def failure(self) -> str | None:
        return self._failure


def _background(
    monkeypatch, steps: int, failure: str | None = None, model=None, **options
) -> Lp2Controller:
    """A background controller whose kernels "compile" for ``steps`` steps (a fake child)."""
    ready = {"now": False}
    child = FakeWarmup(steps, failure)

    def cached(axes, stages):
        return ready["now"]

    def warmup(axes, stages):
        return child

    monkeypatch.setattr(controller_module, "cached", cached)
    monkeypatch.setattr(controller_module, "warmup", warmup)
    model = load_robot("panda", task="pose") if model is None else model
    options.setdefault("dt", 0.001)
    controller = Lp2Controller(model, compile="background", **options)
    assert controller.engine == "numpy"
    if failure is None:
        original = child.finished

        def finished() -> bool:
            done = original()
            ready["now"] = done  # the child filled the cache
            return done

        child.finished = finished  # type: ignore[method-assign]
    return controller


def _circle(k: int, base: np.ndarray) -> np.ndarray:
    goal = base.copy()
    a = 2 * np.pi * k / 400
    goal[:3, 3] += [0.0, 0.08 * np.sin(a), 0.08 * (1 - np.cos(a))]
    return goal


@pytest.mark.parametrize("options", [{"qdd_max": 10.0}, {}, {"qdd_max": 10.0, "on_stall": None}])
def test_the_switch_to_the_compiled_step_keeps_the_trajectory(monkeypatch, options) -> None:
    """60 numpy steps, then compiled ones: the same trajectory as compiled from the start,
    the target's motion (fed forward under acceleration limits) carried across."""
    tiered = _background(monkeypatch, 60, **options)
    monkeypatch.undo()
    compiled = Lp2Controller(tiered.model, dt=0.001, compile="now", **options)
    q0 = home_configuration("panda")
    base = tiered.model.pose(q0)
    runs = {}
    for name, c in (("tiered", tiered), ("compiled", compiled)):
        q, prev, paths = q0.copy(), q0.copy(), []
        for k in range(150):
            res = c.step(q, _circle(k, base), prev)
            paths.append(res.path)
            prev, q = q, res.q
            assert np.isfinite(q).all()
        runs[name] = (q, paths)
    np.testing.assert_allclose(runs["tiered"][0], runs["compiled"][0], rtol=0, atol=1e-9)
    paths = runs["tiered"][1]
    assert "compiled" not in paths[:60] and set(paths[61:]) <= {"compiled"}
    assert tiered.engine == "compiled"


def test_step_into_and_step_batch_on_the_numpy_engine_answer_as_compiled(monkeypatch) -> None:
    tiered = _background(monkeypatch, 10**6, qdd_max=10.0)
    compiled = Lp2Controller(tiered.model, dt=0.001, qdd_max=10.0, compile="now")
    rng = np.random.default_rng(3)
    model = tiered.model
    Q = model.q_min + (model.q_max - model.q_min) * (0.1 + 0.8 * rng.random((12, model.n_joints)))
    prev = Q - 1e-4 * rng.standard_normal(Q.shape)
    T = np.array([_circle(40 * b, model.pose(q)) for b, q in enumerate(Q)])
    a, b = tiered.step_batch(Q, T, prev), compiled.step_batch(Q, T, prev)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.p, b.p, rtol=0, atol=1e-9)
    assert [a.status_of(i) for i in range(12)] == [b.status_of(i) for i in range(12)]
    out_a, out_b = np.empty(model.n_joints), np.empty(model.n_joints)
    for i in range(12):
        tiered.reset()
        compiled.reset()
        pa = tiered.step_into(Q[i], T[i], prev[i], out=out_a)
        pb = compiled.step_into(Q[i], T[i], prev[i], out=out_b)
        assert pa == pytest.approx(pb, abs=1e-9)
        np.testing.assert_allclose(out_a, out_b, rtol=0, atol=1e-9)
        assert tiered.last_status == compiled.last_status
    assert tiered.engine == "numpy"


def test_a_failed_compile_warns_once_and_the_numpy_engine_goes_on(monkeypatch) -> None:
    tiered = _background(monkeypatch, 2, failure="the background compile exited with status 1")
    q = home_configuration("panda")
    goal = tiered.model.pose(q)
    goal[:3, 3] += [0.02, 0.0, 0.0]
    with pytest.warns(RuntimeWarning, match="exited with status 1.*numpy engine"):
        for _ in range(4):
            q = tiered.step(q, goal).q
    assert tiered.engine == "numpy"
    res = tiered.step(q, goal)  # no second warning (pytest's filter would raise it)
    assert res.path != "compiled" and np.isfinite(res.q).all()


def test_the_stall_stage_runs_on_the_numpy_engine_too(monkeypatch) -> None:
    """pull-in on the Panda stalls (LP2 at its end-stops near a singularity): on the numpy
    engine the stepper's stall stage takes the progress step where the compiled one does."""
    setup = get_scenario("pull-in").setup("panda")
    options = {"dt": setup.dt, "v_max": setup.v_max, "w_max": setup.w_max, "saturate": False,
               "on_stall": 1, **dict(setup.weights)}  # fmt: skip
    tiered = _background(monkeypatch, 10**6, model=setup.model, **options)
    compiled = setup.controller(saturate=False, on_stall=1)
    q, prev, statuses = setup.q0.copy(), None, []
    for _ in range(setup.steps):
        a, b = tiered.step(q, setup.target, prev), compiled.step(q, setup.target, prev)
        assert a.status == b.status
        np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-9)
        statuses.append(a.status)
        prev, q = q, b.q
    assert OFF_DIRECTION in statuses and tiered.engine == "numpy"


def test_compile_mode_takes_the_argument_then_the_environment(monkeypatch) -> None:
    monkeypatch.setenv("LPIK_COMPILE", "background")
    assert compile_mode(None) == "background" and compile_mode("now") == "now"
    monkeypatch.setenv("LPIK_COMPILE", "later")
    with pytest.raises(ValueError, match="LPIK_COMPILE: must be one of background, now"):
        compile_mode(None)
    with pytest.raises(ValueError, match="compile: must be one of"):
        Lp2Controller(load_robot("panda"), dt=0.001, compile="eventually")


def test_load_cached_loads_what_the_process_has_and_never_compiles() -> None:
    kernel = step_kernel((2,))
    assert load_cached(kernel, STEP_SIGNATURES[2])
    before = list(kernel.signatures)
    from numba import types

    odd = (types.float32[::1],) * 4  # a signature nobody compiles
    assert not load_cached(kernel, odd)
    assert list(kernel.signatures) == before


COLD_START = textwrap.dedent(
    """
    import json, os
    import numpy as np
    from lpik import Lp2Controller, load_robot, home_configuration
    from lpik.control import warmup
    panda = load_robot("panda", task="pose")
    controller = Lp2Controller(panda, dt=0.001, qdd_max=10.0)
    q = home_configuration("panda")
    goal = panda.pose(q)
    goal[:3, 3] += [0.05, 0.0, 0.0]
    res = controller.step(q, goal, q)
    child = next(iter(warmup._RUNNING.values())).process
    print(json.dumps({"engine": controller.engine, "path": res.path, "p": res.p,
                      "q": res.q.tolist(), "child": child.pid, "args": child.args}))
    """
)


def test_a_cold_cache_starts_on_the_numpy_engine_with_a_child_compiling(tmp_path) -> None:
    """A fresh process with an empty numba cache: no compile before the first step."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("LPIK_COMPILE")
    done = subprocess.run([sys.executable, "-c", COLD_START], env=env, capture_output=True,
                          text=True, check=True, timeout=600)  # fmt: skip
    report = json.loads(done.stdout.strip().splitlines()[-1])
    try:
        assert report["engine"] == "numpy" and report["path"] != "compiled"
        assert report["args"][1:4] == ["-m", "lpik.control.warmup", "2"]
        assert "progress" in report["args"]  # the stall stage's LP, on by default
        panda = load_robot("panda", task="pose")
        q = home_configuration("panda")
        goal = panda.pose(q)
        goal[:3, 3] += [0.05, 0.0, 0.0]
        expected = Lp2Controller(panda, dt=0.001, qdd_max=10.0, compile="now").step(q, goal, q)
        np.testing.assert_allclose(report["q"], expected.q, rtol=0, atol=1e-12)
        assert report["p"] == pytest.approx(expected.p, abs=1e-12)
    finally:  # the child outlives its parent by design; the test does not wait for it
        try:
            os.killpg(report["child"], signal.SIGKILL)
        except ProcessLookupError:
            pass


SCENE_START = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    sys.path.insert(0, "tests")
    from collision_cases import Q0, arm, circle_scene
    from lpik import Lp2Controller
    from lpik.fast.progress import least_error_step
    planar = arm()
    tool = planar.pose(Q0)
    scene = circle_scene([tool[0] - 0.3, tool[1] + 0.06, 0.0], 0.03)  # at the last link
    controller = Lp2Controller(planar, dt=0.01, scene=scene, home=Q0, compile="background")
    built = len(least_error_step.signatures)
    res = controller.step(Q0, np.array([tool[0] - 0.2, tool[1] - 0.2, 0.0]))
    print(json.dumps({"engine": controller.engine, "built": built, "status": res.status,
                      "path": res.path, "after": len(least_error_step.signatures)}))
    """
)


def test_a_controller_with_a_scene_readies_its_recovery_lp_when_built() -> None:
    """A fresh process: the recovery stage's LP (over the distance rows) is readied when the
    controller is built, not at the first step from inside the safety distance (a 1.6 s
    step, seen on the quality suite's scenario 9 on an empty cache)."""
    done = subprocess.run([sys.executable, "-c", SCENE_START], capture_output=True, text=True,
                          check=True, timeout=600)  # fmt: skip
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["engine"] == "compiled"  # a scene always compiles when built
    assert report["status"] == "recovering" and report["path"] == "compiled"
    assert report["built"] == report["after"] == 1  # nothing left to compile in the step


BOUND_START = textwrap.dedent(
    """
    import json
    import numpy as np
    from lpik import Lp2Controller
    from lpik.fast.autobound import bound_in_state
    from lpik.robots.registry import home_configuration, load_robot
    panda = load_robot("panda")
    q = home_configuration("panda")
    controller = Lp2Controller(panda, dt=1e-3, qdd_max=10.0, compile="now")
    built = len(bound_in_state.signatures)
    target = panda.pose(q)
    target[0, 3] += 0.05
    rng = np.random.default_rng(0)
    res = controller.step(q, target, q + rng.normal(0.0, 0.05, q.size))  # a bad velocity sample
    print(json.dumps({"built": built, "status": res.status, "path": res.path,
                      "after": len(bound_in_state.signatures)}))
    """
)


def test_the_automatic_bounds_rule_is_readied_when_the_controller_is_built() -> None:
    """A fresh process: the automatic multiplier bound's rule on the fused step's state
    (lpik.fast.autobound.bound_in_state) is loaded with the fused step, not at the first
    step that needs it (an 11 ms step, seen after a bad velocity sample in a 1 kHz loop)."""
    done = subprocess.run([sys.executable, "-c", BOUND_START], capture_output=True, text=True,
                          check=True, timeout=600)  # fmt: skip
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["status"] == "recovering" and report["path"] == "compiled"
    assert report["built"] == report["after"] == 1  # nothing left to load in the step
