"""A map on disk: a Zarr store written block by block, read back with xarray.

The store is a Zarr group (format 3) whose arrays carry their dimension
names, so that ``xarray.open_zarr(DIR)`` reads it as a dataset. Every block
of cells writes its chunk of each array (one block is one chunk: no two
blocks write the same file), then its flag in ``block_done``; a map that was
interrupted is continued where a flag is missing. The options are the
group's attributes, and a store is only ever continued with the same ones
(:func:`open_or_create`).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from lpik.maps.block import SUMMARIES, BlockResult, MapJob
from lpik.maps.spread import QUATERNION_LABELS, TWIST_LABELS, matrix_quaternion
from lpik.maps.steps import BINDING_WORDS, NOT_REACHED

#: What the store says it is, by kind of job.
KINDS = {1.0: "capability map", -1.0: "base placement"}
#: The attributes that must match for a store to be continued (beyond the spec's).
IDENTITY = ("kind", "robot", "robot_fingerprint", "task_digest")
#: Share of the free disk a map may take.
DISK_SHARE = 0.9
#: Bytes of working memory per LP solve of a block (the batch's arrays and answers, rounded up).
BYTES_PER_SOLVE = 2_000

_FLAGS = {
    "flag_values": list(range(NOT_REACHED, len(BINDING_WORDS))),
    "flag_meanings": " ".join(w.replace("-", "_") for w in ("not_reached", *BINDING_WORDS)),
}
#: Each variable: dims after (x, y, z), dtype, fill value, attributes.
VARIABLES: dict[str, tuple[tuple[str, ...], str, Any, dict[str, Any]]] = {
    "p": (("orientation", "direction"), "f4", np.nan,
          {"long_name": "affine dexterity of one step (eq. 10)", "units": "1"}),
    "binding": (("orientation", "direction"), "i1", NOT_REACHED,
                {"long_name": "kind of limit that binds the step", **_FLAGS}),
    "q": (("orientation", "joint"), "f8", np.nan,
          {"long_name": "configuration that reaches the pose", "units": "rad or m"}),
    "reach_share": ((), "f4", np.nan,
                    {"long_name": "share of orientations reached (NaN: not computed yet)"}),
    "p_mean": ((), "f4", np.nan, {"long_name": "mean p over reached poses and directions"}),
    "p_min": ((), "f4", np.nan, {"long_name": "smallest p over reached poses and directions"}),
    "weakest_direction": ((), "i2", -1,
                          {"long_name": "direction of least mean p "
                                        "(-1: none reached, or all p = 1)"}),
    "binding_mode": ((), "i1", NOT_REACHED,
                     {"long_name": "most frequent binding kind", **_FLAGS}),
}  # fmt: skip


def check_size(job: MapJob, out: str | os.PathLike[str], workers: int) -> None:
    """Refuse a map too large for the disk or memory at hand, before any work, with the estimate.

    Raises:
        ValueError: Naming ``region``/``resolution`` with the estimate.
    """
    spec = job.spec
    need = spec.disk_bytes(job.robot.n)
    where = Path(out).resolve()
    while not where.exists():
        where = where.parent
    free = shutil.disk_usage(where).free
    what = (f"{spec.cells:,} cells x {spec.orientations} orientations x {spec.directions} "
            f"directions = {spec.solves():,} steps")  # fmt: skip
    if need > DISK_SHARE * free:
        raise ValueError(
            f"region: the map ({what}) needs up to {need / 1e9:,.1f} GB on disk and "
            f"{free / 1e9:,.1f} GB are free at {str(where)!r}; use a coarser resolution, a "
            f"smaller region or fewer orientations or directions"
        )
    block = int(np.prod(job.chunks)) * spec.orientations * spec.directions * BYTES_PER_SOLVE
    memory = _available_memory()
    if memory is not None and block * max(1, workers) > memory:
        raise ValueError(
            f"orientations: one block of the map ({what}) needs about {block / 1e9:,.2f} GB "
            f"of memory on each of {workers} workers and {memory / 1e9:,.1f} GB are available; "
            f"use fewer orientations or directions (or --chunk 1)"
        )


def _available_memory() -> int | None:
    """Bytes of memory available on this machine, where the system says."""
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def identity(job: MapJob, task_digest: str = "") -> dict[str, Any]:
    """The attributes that say what a store holds: the options, the arm and the kind."""
    return {
        **job.spec.attributes(),
        "kind": KINDS[job.cell_sign],
        "robot": job.robot.name,
        "robot_fingerprint": job.robot.fingerprint,
        "task_digest": task_digest,
    }


def open_or_create(path: str | os.PathLike[str], job: MapJob, attrs: dict[str, Any]) -> Any:
    """The store at ``path``: created, or opened when it holds the same map (``attrs``).

    Raises:
        ValueError: Naming ``out`` when ``path`` holds something else: another
            map's options (listed), or files that are no map.
    """
    import zarr

    path = Path(path)
    if not path.exists() or (path.is_dir() and not any(path.iterdir())):
        return _create(path, job, attrs)
    try:
        root = zarr.open_group(str(path), mode="r+")
        held = dict(root.attrs)
    except Exception:  # noqa: BLE001 - any reason it is no store: refuse it
        raise ValueError(
            f"out: {str(path)!r} exists and is not a map; choose another --out"
        ) from None
    keys = [k for k in attrs if k not in ("status", "reached_cells", "chunks")]
    differ = [f"{k} {held.get(k)!r} there, {attrs[k]!r} here" for k in keys
              if _plain(held.get(k)) != _plain(attrs[k])]  # fmt: skip
    if differ:
        raise ValueError(
            f"out: {str(path)!r} holds a map made with other options ({'; '.join(differ)}); "
            "choose another --out, or delete it to start again"
        )
    return root


def _plain(value: Any) -> Any:
    """A value as JSON gives it back (tuples as lists)."""
    return list(value) if isinstance(value, tuple) else value


def _create(path: Path, job: MapJob, attrs: dict[str, Any]) -> Any:
    """A new store with every array and coordinate of ``job``'s map, no block done."""
    import zarr

    root = zarr.open_group(str(path), mode="w")
    root.attrs.update({**attrs, "status": "incomplete", "chunks": list(job.chunks)})
    shape, chunks = job.spec.shape, job.chunks
    sizes = {"orientation": len(job.poses), "direction": job.twists.shape[1], "joint": job.robot.n}
    for name, (dims, dtype, fill, extra) in VARIABLES.items():
        array = root.create_array(
            name, shape=(*shape, *(sizes[d] for d in dims)), dtype=dtype, fill_value=fill,
            chunks=(*chunks, *(sizes[d] for d in dims)), dimension_names=("x", "y", "z", *dims),
        )  # fmt: skip
        array.attrs.update({**extra, "coordinates": _coordinates(job)})
    blocks = job.blocks
    root.create_array("block_done", shape=blocks, chunks=(1, 1, 1), dtype="i1", fill_value=0,
                      dimension_names=("block_x", "block_y", "block_z"))  # fmt: skip
    for name, dims, values, extra in _coordinate_arrays(job):
        dtype = str if values.dtype.kind == "U" else values.dtype  # variable-length UTF-8
        array = root.create_array(name, shape=values.shape, dtype=dtype, dimension_names=dims)
        array[...] = values
        array.attrs.update(extra)
    return root


def _coordinates(job: MapJob) -> str:
    """The non-index coordinates every variable carries."""
    if job.cell_sign > 0:
        return "orientation_wxyz direction_twist"
    return "orientation_wxyz task_position task_twist"


def _coordinate_arrays(job: MapJob) -> list[tuple[str, tuple[str, ...], Any, dict[str, Any]]]:
    """Name, dims, values and attributes of every coordinate array."""
    quats = np.array([matrix_quaternion(pose[:3, :3]) for pose in job.poses])
    x, y, z = job.axes
    metres = {"units": "m"}
    found = [
        ("x", ("x",), x, {**metres, "long_name": "cell centre x, base frame"}),
        ("y", ("y",), y, {**metres, "long_name": "cell centre y, base frame"}),
        ("z", ("z",), z, {**metres, "long_name": "cell centre z, base frame"}),
        ("orientation", ("orientation",), np.arange(len(job.poses)), {}),
        ("direction", ("direction",), np.arange(job.twists.shape[1]), {}),
        ("joint", ("joint",), np.array(job.robot.model.joint_names, dtype=str), {}),
        ("quaternion", ("quaternion",), np.array(QUATERNION_LABELS, dtype=str), {}),
        ("twist", ("twist",), np.array(TWIST_LABELS, dtype=str), {}),
        ("orientation_wxyz", ("orientation", "quaternion"), quats,
         {"long_name": "tool orientation, unit quaternion (w, x, y, z), base frame"}),
    ]  # fmt: skip
    twist_attrs = {"long_name": "unit motion (vx, vy, vz, wx, wy, wz) at the tool point, base "
                   "frame", "units": "m/s or rad/s per unit speed"}  # fmt: skip
    if job.cell_sign > 0:
        found.append(("direction_twist", ("direction", "twist"), job.twists[0], twist_attrs))
    else:
        found.append(("task_position", ("orientation", "xyz"), job.poses[:, :3, 3].copy(),
                      {**metres, "long_name": "task pose position, world frame"}))  # fmt: skip
        found.append(("task_twist", ("orientation", "direction", "twist"), job.twists, twist_attrs))
    return found


def done_blocks(root: Any) -> Any:
    """The flags (bx, by, bz) of the blocks already written."""
    return np.asarray(root["block_done"][...], dtype=bool)


def write_block(path: str, job: MapJob, block: tuple[int, int, int], result: BlockResult) -> None:
    """Write one block's chunk of every array, then its flag."""
    import zarr

    root = zarr.open_group(path, mode="r+")
    where = job.block_slices(block)
    values = {"p": result.p, "binding": result.binding, "q": result.q, **result.summaries}
    for name in VARIABLES:
        root[name][where] = values[name]
    root["block_done"][block] = 1


def finish(path: str, attrs: dict[str, Any]) -> None:
    """Mark the store complete, with the count of cells reached."""
    import zarr

    root = zarr.open_group(path, mode="r+")
    share = np.asarray(root["reach_share"][...])
    root.attrs.update({**attrs, "status": "complete", "reached_cells": int((share > 0).sum())})


def open_map(path: str | os.PathLike[str], *, dask: bool = True) -> Any:
    """A map on disk as an xarray ``Dataset``, read lazily.

    ``dask=True``: dask arrays over the store's chunks (what a large map
    wants: computations run chunk by chunk, on a Dask cluster where one is
    active); ``dask=False``: arrays read from disk when they are indexed
    (quicker for a slice or a small map).

    Raises:
        ValueError: When ``path`` holds no map.
    """
    import xarray as xr

    if not Path(path).is_dir():
        raise ValueError(f"map: {str(path)!r} is no map (not a directory)")
    try:
        return xr.open_zarr(str(path), consolidated=False, zarr_format=3,
                            chunks={} if dask else None)  # fmt: skip
    except Exception as exc:  # noqa: BLE001 - anything that is no store
        raise ValueError(f"map: {str(path)!r} is no map ({type(exc).__name__}: {exc})") from None


__all__ = ["SUMMARIES", "check_size", "finish", "open_map", "open_or_create", "write_block"]
