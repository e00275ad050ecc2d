"""Measure capability maps (``lpik map``) and write the measured part of docs/maps.md.

    .venv/bin/python benchmarks/bench_maps.py [--quick]

Measures, on this machine: the rates of the parts of one block (the IK of a
pose, the batch kernel's LP solves, on one thread), the IK against scipy's
bounded least squares on the same poses, the time of Panda maps of growing
size on a local Dask cluster of 1 and 2 worker processes, where the time of
a map went (IK, LP, writing the store, Dask), and projects from these rates
the time of a 1 cm Panda map with 50 orientations and 26 directions on 8,
64 and 512 workers. It also draws the paper's planar arm's 2-D map
(docs/maps-planar.png). The text between the markers of docs/maps.md is
replaced; the rest of the page is left as it is.
"""

from __future__ import annotations

import argparse
import datetime
import logging
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "maps.md"
FIGURE = ROOT / "docs" / "maps-planar.png"
BEGIN, END = "<!-- bench_maps: begin -->", "<!-- bench_maps: end -->"
#: The projected map: the Panda's reach (0.855 m) around its shoulder, at 1 cm.
PANDA_REGION = (-0.86, 0.86, -0.86, 0.86, -0.53, 1.19)
PROJECTED = {"resolution": 0.01, "orientations": 50, "directions": 26}
#: The measured maps: Panda, 16 orientations, 26 directions, 0.1 m cells, growing boxes,
#: blocks of 4 x 4 x 4 cells (1,024 poses, the default block's size).
MEASURED = {"orientations": 16, "directions": 26, "seeds": 16, "chunk": 4}


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import dask
    import numba
    import xarray
    import zarr

    return (
        f"{cpu}, {os.cpu_count()} cores, {platform.platform()}, Python "
        f"{platform.python_version()} (numpy {np.__version__}, numba {numba.__version__}, "
        f"dask {dask.__version__}, zarr {zarr.__version__}, xarray {xarray.__version__})"
    )


def sample_blocks(count: int, seed: int = 1):
    """Blocks of 8 cells drawn at random from the projected Panda map's region (one thread)."""
    import numba

    from lpik.maps.api import map_job
    from lpik.maps.block import solve_block
    from lpik.maps.robot import map_robot
    from lpik.maps.spec import MapSpec

    numba.set_num_threads(1)
    spec = MapSpec(PANDA_REGION, **PROJECTED)
    job = map_job(map_robot("panda"), spec, chunk=2)
    rng = np.random.default_rng(seed)
    blocks = [tuple(int(rng.integers(0, b)) for b in job.blocks) for _ in range(count)]
    solve_block(job, blocks[0])  # compiled and warm
    seconds = {"ik": 0.0, "lp": 0.0}
    poses = reached = solves = 0
    for block in blocks:
        result = solve_block(job, block)
        for key in seconds:
            seconds[key] += result.seconds[key]
        poses += result.q[..., 0].size
        reached += int((~np.isnan(result.q[..., 0])).sum())
        solves += result.solves
    cells = sum(int(np.prod([s.stop - s.start for s in job.block_slices(b)])) for b in blocks)
    return {"cells": cells, "poses": poses, "reached": reached, "solves": solves, **seconds,
            "spec": spec}  # fmt: skip


def kernel_rate(seconds: float = 2.0) -> float:
    """LP solves per second of the batch kernel alone (lp2s), one thread, Panda pose steps."""
    import numba

    from lpik.maps.api import map_job
    from lpik.maps.robot import map_robot
    from lpik.maps.spec import MapSpec
    from lpik.maps.steps import lp2_steps, step_limits

    numba.set_num_threads(1)
    robot = map_robot("panda")
    job = map_job(robot, MapSpec((0, 0, 0, 0, 0, 0), 0.1, 1, 26))
    rng = np.random.default_rng(0)
    q = rng.uniform(robot.model.q_min, robot.model.q_max, (400, robot.n))
    J = np.stack([robot.model.jacobian(x) for x in q])
    dw = np.broadcast_to(0.005 * job.twists[0], (400, 26, 6)).copy()
    bounds = step_limits(robot.model, q, 0.01)
    lp2_steps(J, dw, q, bounds, "lp2s")
    count, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        lp2_steps(J, dw, q, bounds, "lp2s")
        count += 400 * 26
    return count / (time.perf_counter() - start)


def scipy_ik(poses: int = 30) -> tuple[float, float, float, float]:
    """Seconds per pose and share reached: lpik's IK and scipy's bounded least squares, 16 seeds."""
    from scipy.optimize import least_squares

    from lpik.maps import ik
    from lpik.maps.robot import map_robot
    from lpik.robots.tasks import pose_difference

    robot = map_robot("panda")
    chain, model = robot.chain, robot.model
    rng = np.random.default_rng(2)
    targets = np.array([chain.fk(q) for q in rng.uniform(model.q_min, model.q_max, (poses, 7))])
    seeds = rng.uniform(model.q_min, model.q_max, (poses, 16, 7))
    out = np.empty((poses, 7))
    tol = np.array([ik.POSITION_TOL, ik.ROTATION_TOL])
    args = (*robot.chain_arrays(), np.arange(6), model.q_min, model.q_max)
    ik.solve_targets(*args, targets[:1], seeds[:1], tol, out[:1])
    start = time.perf_counter()
    ik.solve_targets(*args, targets, seeds, tol, out)
    ours = (time.perf_counter() - start) / poses
    ours_reached = float((~np.isnan(out[:, 0])).mean())
    start, found = time.perf_counter(), 0
    for target, starts in zip(targets, seeds):
        for seed in starts:
            fit = least_squares(
                lambda q, t=target: pose_difference(t, chain.fk(q)),
                seed,
                jac=lambda q: model.jacobian(q),
                bounds=(model.q_min, model.q_max),
            )
            if np.abs(fit.fun).max() < ik.POSITION_TOL:
                found += 1
                break
    return ours, ours_reached, (time.perf_counter() - start) / poses, found / poses


def timed_maps(sizes: list[int], workers: list[int]) -> list[dict]:
    """Panda maps of ``size``^3 cells of 0.1 m on local clusters of each worker count."""
    import distributed

    from lpik.maps import run_map

    rows = []
    for count in workers:
        cluster = distributed.LocalCluster(
            n_workers=count,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )
        with cluster, distributed.Client(cluster) as client:
            client.run(_warm)
            for size in sizes:
                folder = Path(tempfile.mkdtemp(prefix="bench-maps-"))
                half = 0.1 * size / 2
                region = (0.5 - half, 0.5 + half, -half, half, 0.4 - half, 0.4 + half)
                run = run_map("panda", region, 0.1, out=folder / "m", scheduler=client,
                              **MEASURED)  # fmt: skip
                rows.append({"workers": count, "cells": size**3, "run": run})
                shutil.rmtree(folder)
    return rows


def _warm() -> None:
    """Load the compiled kernels on a worker before it is timed."""
    from lpik.maps.api import map_job
    from lpik.maps.block import solve_block
    from lpik.maps.robot import map_robot
    from lpik.maps.spec import MapSpec

    job = map_job(map_robot("panda"), MapSpec((0.5, 0.5, 0, 0, 0.4, 0.4), 0.1, 2, 26, seeds=4))
    solve_block(job, (0, 0, 0))


def planar_figure() -> None:
    """The paper's planar arm's 2-D map, 0.1 m cells, 16 directions, at 2 m/s."""
    from lpik.maps import build_map
    from lpik.maps.figures import slice_figure

    with tempfile.TemporaryDirectory() as folder:
        ds = build_map("planar", (-4.2, 4.2, -4.2, 4.2), 0.1, directions=16, speed=2.0,
                       out=Path(folder) / "planar", workers=2)  # fmt: skip
        slice_figure(ds, FIGURE)


def report(sample: dict, kernel: float, iks: tuple, rows: list[dict], elapsed: float) -> str:
    spec = sample["spec"]
    ik_pose = sample["ik"] / sample["poses"]
    lp_solve = sample["lp"] / max(1, sample["solves"])
    cell = (sample["ik"] + sample["lp"]) / sample["cells"]
    one = {r["cells"]: r["run"] for r in rows if r["workers"] == 1}
    two = {r["cells"]: r["run"] for r in rows if r["workers"] == 2}
    lines = [
        f"Measured by `python benchmarks/bench_maps.py` on "
        f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d} in {elapsed:.0f} s: "
        f"{machine()}. The machine is shared: times are within tens of per cent.",
        "",
        "### The parts of a block, one thread",
        "",
        "| part | rate |",
        "|---|---:|",
        f"| IK of one pose (Panda, 16 seeds, random cells and orientations of the projected map; "
        f"{sample['reached'] / sample['poses']:.0%} reached) | {ik_pose * 1e6:,.0f} us |",
        f"| LP of one step in the map (lp2s, with building the batch and decoding the binding) "
        f"| {lp_solve * 1e6:,.2f} us ({1 / lp_solve:,.0f} solves/s) |",
        f"| the batch kernel alone (`lp2_batch` on prepared arrays, lp2s) | "
        f"{1e6 / kernel:,.2f} us ({kernel:,.0f} solves/s) |",
        f"| lpik's IK on poses of random reachable configurations, 16 seeds | "
        f"{iks[0] * 1e6:,.0f} us, {iks[1]:.0%} reached |",
        f"| scipy `least_squares` (trf, bounds) on the same poses and seeds | "
        f"{iks[2] * 1e3:,.0f} ms, {iks[3]:.0%} reached |",
        "",
        "### Maps on a local cluster",
        "",
        "Panda, 0.1 m cells, 16 orientations, 26 directions (lp2s), blocks of 4 x 4 x 4 cells "
        "(1,024 poses), worker processes started and warm before the clock starts; the shares "
        "are of the 2-worker run's worker-seconds (Dask: what no block accounts for):",
        "",
        "| cells | steps | 1 worker [s] | 2 workers [s] | speed-up | solves/s/worker "
        "(2 workers) | IK | LP | I/O | Dask |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for cells in sorted(one):
        a, b = one[cells], two[cells]
        total = b.compute_wall_s * b.workers
        share = {k: b.seconds[k] / total for k in ("ik", "lp", "io")}
        lines.append(
            f"| {cells:,} | {cells * 16 * 26:,} | {a.compute_wall_s:.2f} | {b.compute_wall_s:.2f} "
            f"| {a.compute_wall_s / b.compute_wall_s:.2f} | "
            f"{b.solves / b.compute_wall_s / b.workers:,.0f} | {share['ik']:.0%} | "
            f"{share['lp']:.0%} | {share['io']:.0%} | {b.overhead_s() / total:.0%} |"
        )
    largest = max(two)
    efficiency = one[largest].compute_wall_s / two[largest].compute_wall_s / 2
    lines += projection(spec, cell, efficiency, sample)
    return "\n".join(lines)


def projection(spec, cell: float, efficiency: float, sample: dict) -> list[str]:
    lines = [
        "",
        "### Projection: a 1 cm Panda map, 50 orientations, 26 directions",
        "",
        f"The region {', '.join(f'{v:g}' for v in spec.region)} m (the Panda's 0.855 m reach "
        f"around its shoulder) at 1 cm is {spec.cells:,} cells, {spec.solves():,} steps "
        f"(up to {spec.disk_bytes(7) / 1e9:,.0f} GB uncompressed). Measured on "
        f"{sample['cells']} random cells of it: {cell:.3f} s per cell on one thread "
        f"({sample['reached'] / sample['poses']:.0%} of the poses reached; IK "
        f"{sample['ik'] / (sample['ik'] + sample['lp']):.0%} of the time). Projected with the "
        f"2-worker efficiency measured above ({efficiency:.0%}) held at any count:",
        "",
        "| workers | hours |",
        "|---:|---:|",
    ]
    for workers in (8, 64, 512):
        hours = spec.cells * cell / (workers * efficiency) / 3600
        lines.append(f"| {workers} | {hours:,.1f} |")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples, smaller maps")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    sample = sample_blocks(4 if args.quick else 12)
    kernel = kernel_rate(1.0 if args.quick else 3.0)
    iks = scipy_ik(10 if args.quick else 60)
    rows = timed_maps([4, 8] if args.quick else [4, 8, 12], [1, 2])
    planar_figure()
    text = report(sample, kernel, iks, rows, time.perf_counter() - start)
    page = PAGE.read_text(encoding="utf-8")
    head, _, rest = page.partition(BEGIN)
    _, _, tail = rest.partition(END)
    PAGE.write_text(f"{head}{BEGIN}\n{text}\n{END}{tail}", encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
