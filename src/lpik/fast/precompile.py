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
from functools import partial

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

    def ready(name: str, call, kernel=None) -> None:  # noqa: ANN001 - numba dispatchers
        """Time ``call``, which readies ``kernel`` (``None``: the dispatcher ``call`` returns)."""
        misses, hits = _counts(kernel) if kernel is not None else (0, 0)
        start = time.perf_counter()
        returned = call()
        seconds = time.perf_counter() - start
        kernel = returned if kernel is None else kernel
        now_misses, now_hits = _counts(kernel)
        if now_misses > misses:
            source = "compiled"
        elif now_hits > hits:
            source = "disk cache"
        else:
            source = "in memory"
        loads.append(KernelLoad(name, seconds, source, str(kernel.stats.cache_path)))

    # A step kernel compiles (or loads) when step_kernel first asks for it.
    for kind, label in (("chain", "serial chain"), ("planar", "planar arm")):
        ready(f"fused step, {label}", partial(CK.step_kernel, kind), CK.loaded_step_kernel(kind))
    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    pose = panda.pose(q)
    chain = Lp2Controller(panda, dt=1e-3, qdd_max=10.0)
    planar = Lp2Controller(PlanarArm([1.0] * 4), dt=0.01, qdd_max=10.0)
    problem = Problem(J=panda.jacobian(q), dw=np.full(6, 1e-4), q0=q,
                      q_min=panda.q_min, q_max=panda.q_max)  # fmt: skip
    ready(
        "fused step batch, serial chain",
        lambda: chain.step_batch(q[None], pose[None], q[None]),
        CK.chain_step_batch,
    )
    ready(
        "fused step batch, planar arm",
        lambda: planar.step_batch(np.full((1, 4), 0.3), np.ones((1, 2))),
        CK.planar_step_batch,
    )
    ready("LP2 ratio test (lp2_compiled)", lambda: B.lp2_compiled(problem), K.lp2_kernel)
    ready("LP2 batch (lp2_batch)", lambda: B.lp2_batch([problem]), K.lp2_batch_kernel)
    return loads
