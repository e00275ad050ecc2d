"""``lpik compile``: compile every kernel of the compiled path now (or load it from the cache).

A cold compile of the compiled path takes a while (the section "Compile time"
of ``docs/benchmarks.md``: tens of seconds for a first controller, a few
minutes for every kernel); the kernels are then cached on disk. Run
``lpik compile`` (or :func:`compile_kernels`) once where lpik is deployed, for
example while building a container image, so that a controller's first start
loads them from the cache instead of compiling them.

Prints one line per kernel: what it does, where it came from (``compiled``,
``disk cache`` or ``in memory``) and the seconds it took, then numba's cache
folder; while it compiles, a progress line on stderr says what it is on.
``lpik compile --json`` prints a JSON list of objects with the keys
``name``, ``source``, ``seconds`` and ``cache_path``. ``lpik compile --jobs N``
compiles the independent groups of kernels (:data:`GROUPS`) in N processes side
by side, for a build machine with cores to spare: numba compiles on one core.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import partial
from typing import Any


@dataclass(frozen=True)
class KernelLoad:
    """How one kernel came to be ready.

    Attributes:
        name: What the kernel does.
        seconds: Wall time of the call that readied it [s].
        source: ``"compiled"``, ``"disk cache"`` or ``"in memory"`` (already
            loaded in this process).
        cache_path: numba's cache folder for the kernel.
    """

    name: str
    seconds: float
    source: str
    cache_path: str


def _counts(dispatcher: Any) -> tuple[int, int]:
    """Cache misses and hits of a numba dispatcher so far."""
    stats = dispatcher.stats
    return sum(stats.cache_misses.values()), sum(stats.cache_hits.values())


def _source(dispatcher: Any, misses: int, hits: int) -> str:
    """Where a kernel came from, by its cache misses and hits since ``misses, hits``."""
    now_misses, now_hits = _counts(dispatcher)
    if now_misses > misses:
        return "compiled"
    return "disk cache" if now_hits > hits else "in memory"


def _ready(loads: list[KernelLoad], name: str, call: Callable[[], Any], kernel: Any = None) -> None:
    """Time ``call``, which readies ``kernel`` (``None``: the dispatcher ``call`` returns)."""
    misses, hits = _counts(kernel) if kernel is not None else (0, 0)
    start = time.perf_counter()
    returned = call()
    seconds = time.perf_counter() - start
    kernel = returned if kernel is None else kernel
    source = _source(kernel, misses, hits)
    loads.append(KernelLoad(name, seconds, source, str(kernel.stats.cache_path)))


def _controller_kernels() -> list[KernelLoad]:
    """The fused step, the stall stage, the fused step's batch and the bound's rule."""
    import numpy as np

    from lpik.control.controller import Lp2Controller
    from lpik.fast import progress, step
    from lpik.fast.autobound import bound_in_state
    from lpik.robots.registry import home_configuration, load_robot

    loads: list[KernelLoad] = []
    # The step kernel compiles (or loads) when step_kernel first asks for it.
    _ready(loads, "fused step (a serial chain's, or a backend's kinematics)", step.step_kernel,
           step.loaded_step_kernel())  # fmt: skip
    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    controller = Lp2Controller(panda, dt=1e-3, qdd_max=10.0, on_stall=None, compile="now")
    _ready(loads, "the stall stage's progress step (on_stall, mode=\"progress\")",
           partial(Lp2Controller, panda, dt=1e-3, qdd_max=10.0, mode="progress", compile="now"),
           progress.stall_stage)  # fmt: skip
    points = load_robot("panda", task="position")  # the batch compiles per target's shape
    on_points = Lp2Controller(points, dt=1e-3, qdd_max=10.0, on_stall=None, compile="now")

    def batches() -> None:
        controller.step_batch(q[None], panda.pose(q)[None], q[None])  # (B, 4, 4) targets
        on_points.step_batch(q[None], points.position(q)[None], q[None])  # (B, 3) targets

    _ready(loads, "fused step batch, serial chain", batches, step.chain_step_batch)
    _ready(loads, "the automatic multiplier bound's rule, after a step on the HiGHS path",
           lambda: bound_in_state(controller._state, q, np.ones(q.size)),
           bound_in_state)  # fmt: skip
    return loads


def _lp2_kernels() -> list[KernelLoad]:
    """LP2 alone (the ratio test) and batched, plain and saturating."""
    import numpy as np

    from lpik.fast import lp2_kernel, saturation
    from lpik.fast.batch import lp2_batch
    from lpik.methods.lp2 import lp2
    from lpik.problem import Problem
    from lpik.robots.registry import home_configuration, load_robot

    loads: list[KernelLoad] = []
    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    problem = Problem(J=panda.jacobian(q), dw=np.full(6, 1e-4), q0=q,
                      q_min=panda.q_min, q_max=panda.q_max)  # fmt: skip
    _ready(loads, 'LP2 ratio test (lp2, path="compiled")',
           lambda: lp2(problem, path="compiled"), lp2_kernel.lp2_kernel)  # fmt: skip
    for method, kernel in (("lp2", lp2_kernel.lp2_batch_kernel),
                           ("lp2s", saturation.lp2s_batch_kernel)):  # fmt: skip
        _ready(loads, f"LP2 batch (lp2_batch, {method})", partial(lp2_batch, [problem], method),
               kernel)  # fmt: skip
    return loads


def _scene_kernels() -> list[KernelLoad]:
    """A scene's controller: the fused step with distance rows and the recovery stage."""
    from lpik.control.warmup import STAGES
    from lpik.fast.avoiding_step import avoiding_kernel, loaded_avoiding_kernel

    loads: list[KernelLoad] = []
    _ready(loads, "fused step with distance rows (AvoidingLp2Controller)", avoiding_kernel,
           loaded_avoiding_kernel())  # fmt: skip
    for kernel, signature in STAGES["recovery"]:
        name = f"the recovery stage's {kernel.py_func.__name__} (inside a scene's d_s)"
        _ready(loads, name, partial(kernel.compile, signature), kernel)
    return loads


def _map_kernels() -> list[KernelLoad]:
    """``lpik map``'s inverse kinematics and steps (a Panda's map of one cell)."""
    from lpik.maps import ik
    from lpik.maps.api import map_job
    from lpik.maps.block import solve_block
    from lpik.maps.robot import map_robot
    from lpik.maps.spec import MapSpec
    from lpik.robots.registry import home_configuration, load_robot

    panda = load_robot("panda", task="pose")
    x, y, z = panda.pose(home_configuration("panda"))[:3, 3]
    half = 0.025
    region = (x - half, x + half, y - half, y + half, z - half, z + half)
    job = map_job(map_robot(panda), MapSpec(region, 2 * half))
    loads: list[KernelLoad] = []
    _ready(loads, "capability map's inverse kinematics and steps (lpik map)",
           partial(solve_block, job, (0, 0, 0)), ik.solve_targets)  # fmt: skip
    return loads


#: The kernels in groups that share no kernel of their own, the longest to compile first:
#: ``lpik compile --jobs N`` readies the groups in N processes side by side.
GROUPS: tuple[Callable[[], list[KernelLoad]], ...] = (
    _controller_kernels,
    _lp2_kernels,
    _scene_kernels,
    _map_kernels,
)


def compile_kernels(jobs: int = 1) -> list[KernelLoad]:
    """Ready every kernel: the fused steps, their batch and stages, LP2 alone and batched, maps.

    Args:
        jobs: Processes that compile side by side (numba compiles on one core): with
            more than one, the groups of :data:`GROUPS` are readied in child
            processes, which fill numba's disk cache; this process then holds none
            of the kernels in memory.

    Returns:
        One :class:`KernelLoad` per kernel, in the same order whatever ``jobs`` is.

    Raises:
        MissingBackendError: When numba is not installed.
        ValueError: When ``jobs`` is not a positive integer.
    """
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ValueError(f"jobs: must be a positive integer, got {jobs!r}")
    import lpik.fast  # noqa: F401  (without numba: MissingBackendError, here, not in a child)

    if jobs == 1:
        return [load for group in GROUPS for load in group()]
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")  # a fresh interpreter: no fork of numba
    with ProcessPoolExecutor(min(jobs, len(GROUPS)), mp_context=context) as pool:
        futures = [pool.submit(group) for group in GROUPS]
        return [load for future in futures for load in future.result()]


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik compile``."""
    parser = sub.add_parser(
        "compile",
        help="compile (or load from numba's disk cache) every kernel of lpik.fast now",
        description="Compile every kernel of the compiled path (fused steps, their batches, "
        "LP2 alone and batched) or load it from numba's disk cache, and report which and how "
        "long: a deployment step, so that the first controller starts without compiling.",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON list instead")
    parser.add_argument(
        "--jobs",
        type=int,
        default=1,
        metavar="N",
        help="compile in N processes side by side (numba compiles on one core; default 1)",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Ready the kernels and report them; exit status 0."""
    from lpik.cli.progress import compile_progress

    if args.jobs < 1:
        raise ValueError(f"--jobs: must be a whole number >= 1, got {args.jobs}")
    if args.jobs > 1:  # the children compile: this process has nothing to count
        print(f"lpik compile: readying the kernels in {min(args.jobs, len(GROUPS))} processes ...",
              file=sys.stderr)  # fmt: skip
    with compile_progress("lpik compile"):  # without numba: nothing to say
        loads = compile_kernels(args.jobs)  # without numba: MissingBackendError, exit 2
    if args.json:
        print(json.dumps([asdict(load) for load in loads], indent=2))
        return 0
    width = max(len(load.name) for load in loads)
    for load in loads:
        print(f"{load.name:<{width}}  {load.source:<10}  {load.seconds:7.2f} s")
    for path in dict.fromkeys(load.cache_path for load in loads):
        print(f"numba cache: {path}")
    return 0
