"""Run a map on Dask: an embedded local cluster or an existing one, block by block, resumable.

:func:`run_job` sends every block not yet written to the workers (a few per
worker at a time, so that a map of a million blocks keeps the scheduler
light), each of which computes its block (:func:`lpik.maps.block.solve_block`)
and writes it to the store (:func:`lpik.maps.store.write_block`) itself: the
store's path must be one the workers can write (a local path for the local
cluster; a shared file system for a remote one). It reports progress per
block and where the time went (:class:`MapRun`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import logging
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from lpik.maps.block import MapJob, solve_block
from lpik.maps.store import check_size, done_blocks, finish, identity, open_or_create, write_block

#: Seconds to wait for a scheduler given by address before giving up.
CONNECT_TIMEOUT_S = 10.0
#: Blocks in flight per worker.
BLOCKS_IN_FLIGHT = 3
#: (done, total) blocks: called after each block.
Progress = Callable[[int, int], None]


@dataclass
class MapRun:
    """A run of :func:`run_job`: where the map is and where the time went.

    Attributes:
        path: The store.
        blocks: Blocks in the map; ``resumed``: those already written before this run.
        workers: Dask workers used (0: nothing was left to compute).
        wall_s: Seconds of this run, start to end (cluster start included).
        compute_wall_s: Seconds from the first block sent to the last written.
        seconds: Seconds summed over the blocks: ``ik``, ``lp``, ``io`` and ``task`` (all three).
        solves: LP solves of this run; ``poses``: IK targets solved.
        dashboard: The Dask dashboard's address, where there is one.
    """

    path: Path
    blocks: int
    resumed: int = 0
    workers: int = 0
    wall_s: float = 0.0
    compute_wall_s: float = 0.0
    seconds: dict[str, float] = field(default_factory=lambda: dict.fromkeys(
        ("ik", "lp", "io", "task"), 0.0))  # fmt: skip
    solves: int = 0
    poses: int = 0
    dashboard: str | None = None

    def overhead_s(self) -> float:
        """Worker-seconds of the compute not spent in a block: Dask's scheduling and transfers."""
        return max(0.0, self.compute_wall_s * self.workers - self.seconds["task"])


def run_block(job: MapJob, block: tuple[int, int, int], out: str) -> dict[str, Any]:
    """Compute one block and write it (a worker's task); its timings [s] and counts."""
    import numba

    numba.set_num_threads(max(1, min(job.threads, numba.config.NUMBA_NUM_THREADS)))
    start = time.perf_counter()
    result = solve_block(job, block)
    written = time.perf_counter()
    write_block(out, job, block, result)
    end = time.perf_counter()
    return {**result.seconds, "io": end - written, "task": end - start, "solves": result.solves,
            "poses": int(result.q[..., 0].size)}  # fmt: skip


@contextlib.contextmanager
def dask_client(scheduler: Any = None, workers: int | None = None) -> Iterator[Any]:
    """A Dask client: of ``scheduler`` (an address or a ``Client``), else of a local cluster.

    The local cluster has ``workers`` processes (default: one per core) of one
    thread each; it is closed on leaving.

    Raises:
        ValueError: Naming ``scheduler`` when it cannot be reached, ``workers``
            when it is not a whole number >= 1.
    """
    from distributed import Client, LocalCluster

    if scheduler is not None and not isinstance(scheduler, str):
        yield scheduler
        return
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ValueError(f"scheduler: cannot reach {scheduler!r}: {reason}") from None
        with client:
            yield client
        return
    count = (os.cpu_count() or 1) if workers is None else workers
    if not (isinstance(count, int) and count >= 1):
        raise ValueError(f"workers: must be a whole number >= 1, got {workers!r}")
    with LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR) as cluster:  # fmt: skip
        with Client(cluster) as client:
            yield client


def _has_bokeh() -> bool:
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


def run_job(
    job: MapJob,
    out: str | os.PathLike[str],
    *,
    scheduler: Any = None,
    workers: int | None = None,
    progress: Progress | None = None,
    on_start: Callable[[MapRun], None] | None = None,
    task_digest: str = "",
) -> MapRun:
    """Compute every block of ``job`` not yet in the store at ``out``, on Dask.

    Args:
        job: The map.
        out: The store's directory (created, or continued when it holds the same map).
        scheduler: A scheduler's address (``tcp://HOST:PORT``) or a
            ``distributed.Client``; None: a local cluster of ``workers``.
        workers: Processes of the local cluster (default: one per core).
        progress: Called with (done, total) blocks as they are written.
        on_start: Called once the cluster is up, with the run so far (its dashboard).
        task_digest: What a base placement's task is (a store is continued for the same only).

    Raises:
        ValueError: For a map too large (with the estimate), a store of
            another map at ``out``, an unreachable scheduler.
    """
    start = time.perf_counter()
    local_workers = (os.cpu_count() or 1) if workers is None else workers
    check_size(job, out, 1 if scheduler is not None else local_workers)
    attrs = identity(job, task_digest)
    root = open_or_create(out, job, attrs)
    job = dataclasses.replace(job, chunks=tuple(root.attrs["chunks"]))
    done = done_blocks(root)
    todo = [b for b in itertools.product(*map(range, job.blocks)) if not done[b]]
    run = MapRun(Path(out), blocks=int(done.size), resumed=int(done.sum()))
    if todo:
        with dask_client(scheduler, workers) as client:
            _compute(client, job, todo, run, progress, on_start, scheduler is None)
    finish(str(out), attrs)
    run.wall_s = time.perf_counter() - start
    return run


def _compute(client: Any, job: MapJob, todo: list[tuple[int, int, int]], run: MapRun,
             progress: Progress | None, on_start: Any, local: bool) -> None:  # fmt: skip
    """Send the blocks, a few per worker at a time; record their timings as they come."""
    from distributed import as_completed

    info = client.scheduler_info()
    run.workers = max(1, len(info.get("workers", {})))
    if "dashboard" in info.get("services", {}) and (_has_bokeh() or not local):
        run.dashboard = client.dashboard_link  # its pages need bokeh
    if local:
        job = dataclasses.replace(job, threads=max(1, (os.cpu_count() or 1) // run.workers))
    if on_start is not None:
        on_start(run)
    shared = client.scatter(job, broadcast=True)
    blocks = iter(todo)
    began = time.perf_counter()
    first = [client.submit(run_block, shared, b, str(run.path), pure=False)
             for b in itertools.islice(blocks, BLOCKS_IN_FLIGHT * run.workers)]  # fmt: skip
    queue = as_completed(first)
    try:
        for count, future in enumerate(queue, start=run.resumed + 1):
            stats = future.result()
            for key in run.seconds:
                run.seconds[key] += stats[key]
            run.solves += stats["solves"]
            run.poses += stats["poses"]
            for b in itertools.islice(blocks, 1):
                queue.add(client.submit(run_block, shared, b, str(run.path), pure=False))
            if progress is not None:
                progress(count, run.blocks)
    except BaseException:
        client.cancel(list(queue.futures))
        raise
    run.compute_wall_s = time.perf_counter() - began
