"""The capability map in one call: :func:`run_map` (the run) and :func:`build_map` (the dataset)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from lpik.command import DEFAULT_V_MAX
from lpik.defaults import DEFAULT_METHOD
from lpik.maps.block import MapJob
from lpik.maps.robot import MapRobot, map_robot
from lpik.maps.run import MapRun, Progress, run_job
from lpik.maps.spec import MAP_DT, MAP_SEEDS, MapSpec
from lpik.maps.spread import quaternion_matrix, spread_orientations, spread_twists
from lpik.maps.store import open_map


def map_job(robot: MapRobot, spec: MapSpec, chunk: int | None = None) -> MapJob:
    """The job of a capability map: ``spec``'s orientations and directions at every cell."""
    rows = tuple(robot.model.row_names)
    quats = spread_orientations(spec.orientations, rows, robot.home_rotation())
    poses = np.tile(np.eye(4), (len(quats), 1, 1))
    poses[:, :3, :3] = [quaternion_matrix(q) for q in quats]
    twists = spread_twists(spec.directions, rows)
    twists = np.broadcast_to(twists, (len(quats), *twists.shape)).copy()
    return MapJob(robot, spec, poses, twists, 1.0, spec.chunk_shape(chunk))


def full_region(robot: MapRobot, region: Sequence[float]) -> tuple[float, ...]:
    """``region`` as six numbers: a planar task's four (x, y) get z = 0..0."""
    values = tuple(region)
    if len(values) == 4 and 2 not in robot.rows:
        return (*values, 0.0, 0.0)
    if len(values) != 6:
        need = "xmin,xmax,ymin,ymax[,zmin,zmax]" if 2 not in robot.rows else (
            "xmin,xmax,ymin,ymax,zmin,zmax")  # fmt: skip
        raise ValueError(f"region: must be {need} [m], got {len(values)} numbers")
    return values


def run_map(
    robot: Any,
    region: Sequence[float],
    resolution: float,
    *,
    out: str | os.PathLike[str],
    orientations: int = 1,
    directions: int = 6,
    method: str = DEFAULT_METHOD,
    speed: float = DEFAULT_V_MAX,
    dt: float = MAP_DT,
    seeds: int = MAP_SEEDS,
    seed: int = 0,
    scheduler: Any = None,
    workers: int | None = None,
    chunk: int | None = None,
    progress: Progress | None = None,
    on_start: Any = None,
) -> MapRun:
    """Compute (or continue) a capability map into the Zarr store ``out``; see :func:`build_map`."""
    arm = map_robot(robot)
    spec = MapSpec(full_region(arm, region), resolution, orientations, directions, method,  # type: ignore[arg-type]
                   speed, dt, seeds, seed)  # fmt: skip
    return run_job(map_job(arm, spec, chunk), out, scheduler=scheduler, workers=workers,
                   progress=progress, on_start=on_start)  # fmt: skip


def build_map(robot: Any, region: Sequence[float], resolution: float, **options: Any) -> Any:
    """A capability map of ``robot`` over ``region``: an xarray ``Dataset`` read lazily from disk.

    For every cell (centres ``x``, ``y``, ``z`` [m], base frame) and tool
    orientation (``orientation_wxyz``), a configuration within the end-stops
    that reaches the pose (``q``, NaN where none was found); from it, for every
    unit motion ``direction_twist`` (vx, vy, vz, wx, wy, wz), the affine
    dexterity ``p`` (eq. 10) of one step ``speed * dt * direction_twist`` by
    ``method`` and the kind of limit that binds it (``binding``), and per cell
    ``reach_share``, ``p_mean``, ``p_min``, ``weakest_direction`` and
    ``binding_mode``. The options are the dataset's attributes.

    Args:
        robot: ``"planar"``, a bundled arm's name, an :class:`lpik.robots.arm.Arm`
            or a task model over a :class:`~lpik.robots.chain.SerialChain`.
        region: ``(xmin, xmax, ymin, ymax, zmin, zmax)`` [m] (a planar arm: 4 numbers).
        resolution: Cell edge [m].
        **options: ``out`` (the store's directory, required), ``orientations``,
            ``directions``, ``method`` (``"lp1"``, ``"lp2"``, ``"lp2s"``),
            ``speed``, ``dt``, ``seeds``, ``seed``, ``scheduler``, ``workers``,
            ``chunk``, ``progress`` (see :func:`run_map`, :class:`MapSpec`).

    Raises:
        ValueError: Naming the option that is wrong; for a map too large for
            the disk or memory (with the estimate), an ``out`` that holds another
            map, a scheduler that cannot be reached.
    """
    return open_map(run_map(robot, region, resolution, **options).path)
