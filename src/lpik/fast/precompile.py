"""Compile (or load from numba's disk cache) every kernel of :mod:`lpik.fast` now.

A cold compile of the compiled path takes tens of seconds (see the first-call
table of ``docs/benchmarks.md``); the kernels are then cached on disk. Run
:func:`compile_kernels` (or ``lpik compile``) once where lpik is deployed, for
example while building a container image, so that a controller's first start
loads them in well under a second instead of compiling them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np


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


def _counts(dispatcher) -> tuple[int, int]:  # noqa: ANN001 - a numba dispatcher
    stats = dispatcher.stats
    return sum(stats.cache_misses.values()), sum(stats.cache_hits.values())


def compile_kernels() -> list[KernelLoad]:
    """Ready every kernel: the fused chain and planar steps, their batches, LP2 alone and batched.

    Returns:
        One :class:`KernelLoad` per kernel, in the order they were readied.
    """
    from lpik.fast import batch as B
    from lpik.fast import chain_kernels as CK
    from lpik.fast import kernels as K
    from lpik.fast.controller import Lp2Controller
    from lpik.problem import Problem
    from lpik.robots.planar import PlanarArm
    from lpik.robots.registry import home_configuration, load_robot

    loads: list[KernelLoad] = []

    def ready(name: str, dispatcher, call, before: tuple[int, int] | None = None) -> None:  # noqa: ANN001
        """Time ``call``; ``dispatcher()`` is the kernel it readies (looked up afterwards)."""
        before = before or (0, 0)
        start = time.perf_counter()
        call()
        seconds = time.perf_counter() - start
        misses, hits = _counts(dispatcher())
        if misses > before[0]:
            source = "compiled"
        elif hits > before[1]:
            source = "disk cache"
        else:
            source = "in memory"
        cache = str(dispatcher().stats.cache_path)
        loads.append(KernelLoad(name, seconds, source, cache))

    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    pose = panda.pose(q)
    made: dict[str, Lp2Controller] = {}
    models = {
        "chain": (panda, 1e-3, "serial chain"),
        "planar": (PlanarArm([1.0] * 4), 0.01, "planar arm"),
    }

    def build(kind: str) -> None:
        model, dt, _ = models[kind]
        made[kind] = Lp2Controller(model, dt=dt, qdd_max=10.0)

    for kind in models:
        # A step kernel compiles (or loads) when the first controller of its kind is built.
        before = _counts(CK.step_kernel(kind)) if kind in CK._compiled_steps else None
        ready(f"fused step, {models[kind][2]}", lambda kind=kind: CK.step_kernel(kind),
              lambda kind=kind: build(kind), before)  # fmt: skip
    batches = (
        ("fused step batch, serial chain", CK.chain_step_batch,
         lambda: made["chain"].step_batch(q[None], pose[None], q[None])),
        ("fused step batch, planar arm", CK.planar_step_batch,
         lambda: made["planar"].step_batch(np.full((1, 4), 0.3), np.ones((1, 2)))),
    )  # fmt: skip
    problem = Problem(J=panda.jacobian(q), dw=np.full(6, 1e-4), q0=q,
                      q_min=panda.q_min, q_max=panda.q_max)  # fmt: skip
    for name, dispatcher, call in (
        *batches,
        ("LP2 ratio test (lp2_compiled)", K.lp2_kernel, lambda: B.lp2_compiled(problem)),
        ("LP2 batch (lp2_batch)", K.lp2_batch_kernel, lambda: B.lp2_batch([problem])),
    ):
        ready(name, lambda d=dispatcher: d, call, _counts(dispatcher))
    return loads
