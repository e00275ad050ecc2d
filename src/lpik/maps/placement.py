"""Base placement: score candidate base positions by the smallest p over a task (the inverse map).

A task is a list of tool poses in the world frame, each with a direction of
motion (a CSV, :func:`read_task`). A candidate base position ``b`` on a grid
puts each pose at ``T - b`` in the base frame (the base is moved, not
turned); the arm must reach every pose there and step along each direction.
A candidate's score is the smallest ``p`` over the task's rows, a row that
is not reached counting as ``p = 0``: the candidate that follows the whole
task best is the one whose weakest row is strongest. The same blocks, store
and Dask run as a map compute it (:mod:`lpik.maps.run`), with the task's
rows as the orientation axis and one direction each.
"""

from __future__ import annotations

import csv
import hashlib
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lpik.command import DEFAULT_V_MAX
from lpik.defaults import DEFAULT_METHOD
from lpik.maps.api import full_region
from lpik.maps.block import MapJob
from lpik.maps.robot import map_robot
from lpik.maps.run import MapRun, Progress, run_job
from lpik.maps.spec import MAP_DT, MAP_SEEDS, MapSpec
from lpik.maps.spread import TWIST_LABELS, quaternion_matrix
from lpik.types import FloatArray

#: The task CSV's columns: a position [m], an orientation (unit quaternion, optional
#: for a task without rotation rows) and a direction (vx .. wz) [m/s, rad/s per unit speed].
TASK_COLUMNS = ("x", "y", "z", "qw", "qx", "qy", "qz", *TWIST_LABELS)
#: The columns a row may leave out, with their default.
TASK_DEFAULTS = {"z": 0.0, "qw": 1.0, "qx": 0.0, "qy": 0.0, "qz": 0.0}
#: Most rows of a task.
MAX_TASK_ROWS = 10_000
#: Best placements written by default.
BEST_PLACEMENTS = 10
#: The columns of the placements CSV.
PLACEMENT_COLUMNS = ("rank", "x", "y", "z", "score", "reached", "p_mean", "weakest_row")


@dataclass(frozen=True, eq=False)
class Task:
    """A task's rows: tool poses (T, 4, 4) in the world frame and their directions (T, 6)."""

    poses: FloatArray
    twists: FloatArray

    def digest(self) -> str:
        """A digest of the rows: a placement is only ever continued for the same task."""
        data = np.concatenate([self.poses.reshape(-1), self.twists.reshape(-1)])
        return hashlib.sha256(data.tobytes()).hexdigest()[:16]


def read_task(source: str | os.PathLike[str]) -> Task:
    """The task of a CSV with a header of :data:`TASK_COLUMNS` (one row per pose and direction).

    Raises:
        ValueError: Naming ``task`` and the row or column that is wrong.
    """
    path = Path(source)
    if not path.is_file():
        raise ValueError(f"task: cannot read {str(source)!r}: no such file")
    reader = csv.DictReader(io.StringIO(path.read_text(encoding="utf-8")))
    header = [h.strip() for h in reader.fieldnames or ()]
    missing = [c for c in TASK_COLUMNS if c not in header and c not in TASK_DEFAULTS]
    unknown = [c for c in header if c not in TASK_COLUMNS]
    if missing or unknown:
        raise ValueError(f"task: {str(source)!r} needs the columns {', '.join(TASK_COLUMNS)} "
                         f"(z, qw..qz optional); missing {missing}, unknown {unknown}")  # fmt: skip
    rows = [_task_row(k + 2, {key.strip(): v for key, v in row.items()})
            for k, row in enumerate(reader)]  # fmt: skip
    if not 1 <= len(rows) <= MAX_TASK_ROWS:
        raise ValueError(f"task: needs 1..{MAX_TASK_ROWS:,} rows, got {len(rows):,}")
    return Task(np.array([r[0] for r in rows]), np.array([r[1] for r in rows]))


def _task_row(line: int, row: dict[str, str]) -> tuple[FloatArray, FloatArray]:
    """One CSV row as a pose (4, 4) and a twist (6,)."""
    values = {}
    for column in TASK_COLUMNS:
        text = (row.get(column) or "").strip()
        try:
            values[column] = float(text) if text else TASK_DEFAULTS[column]
            if not np.isfinite(values[column]):
                raise ValueError
        except (KeyError, ValueError):
            raise ValueError(f"task: line {line}, column {column}: expected a finite number, "
                             f"got {text!r}") from None  # fmt: skip
    quat = np.array([values[c] for c in ("qw", "qx", "qy", "qz")])
    if abs(np.linalg.norm(quat) - 1.0) > 1e-3:
        raise ValueError(f"task: line {line}: qw, qx, qy, qz must be a unit quaternion")
    pose = np.eye(4)
    pose[:3, :3] = quaternion_matrix(quat / np.linalg.norm(quat))
    pose[:3, 3] = [values["x"], values["y"], values["z"]]
    twist = np.array([values[c] for c in TWIST_LABELS])
    if not np.any(twist):
        raise ValueError(f"task: line {line}: the direction (vx .. wz) is zero")
    return pose, twist


def placement_job(robot: Any, task: Task, spec: MapSpec, chunk: int | None = None) -> MapJob:
    """The job of a base placement: ``task``'s rows from every candidate base cell."""
    return MapJob(robot, spec, task.poses, task.twists[:, None, :].copy(), -1.0,
                  spec.chunk_shape(chunk))  # fmt: skip


def place_base(
    robot: Any,
    task: Task | str | os.PathLike[str],
    region: Sequence[float],
    resolution: float,
    *,
    out: str | os.PathLike[str],
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
    """Score every candidate base position in ``region`` for ``task``, into the store ``out``.

    ``region`` and ``resolution`` lay the grid of candidate base positions
    (world frame); the other options are :func:`lpik.maps.run_map`'s. Read the
    ranking with :func:`rank_placements` (``open_map(out)``).
    """
    arm = map_robot(robot)
    rows = task if isinstance(task, Task) else read_task(task)
    spec = MapSpec(full_region(arm, region), resolution, len(rows.poses), 1, method, speed, dt,  # type: ignore[arg-type]
                   seeds, seed)  # fmt: skip
    return run_job(placement_job(arm, rows, spec, chunk), out, scheduler=scheduler,
                   workers=workers, progress=progress, on_start=on_start,
                   task_digest=rows.digest())  # fmt: skip


def rank_placements(dataset: Any, best: int = BEST_PLACEMENTS) -> list[dict[str, Any]]:
    """The ``best`` candidate base positions, strongest first: rows of :data:`PLACEMENT_COLUMNS`.

    ``score`` is the smallest p over the task (an unreached row: 0); ties go to
    the larger mean p, then to the first cell.
    """
    p = np.asarray(dataset["p"].values, dtype=np.float64)[..., 0]  # (x, y, z, rows)
    filled = np.where(np.isnan(p), 0.0, p)
    score = filled.min(axis=-1).reshape(-1)
    mean = filled.mean(axis=-1).reshape(-1)
    reached = (~np.isnan(p)).mean(axis=-1).reshape(-1)
    weakest = filled.argmin(axis=-1).reshape(-1)
    order = np.lexsort((np.arange(score.size), -mean, -score))[:best]
    x, y, z = (dataset[a].values for a in "xyz")
    shape = p.shape[:3]
    ranking = []
    for rank, flat in enumerate(order.tolist(), start=1):
        i, j, k = np.unravel_index(flat, shape)
        ranking.append({"rank": rank, "x": float(x[i]), "y": float(y[j]), "z": float(z[k]),
                        "score": float(score[flat]), "reached": float(reached[flat]),
                        "p_mean": float(mean[flat]),
                        "weakest_row": int(weakest[flat])})  # fmt: skip
    return ranking


def write_placements(ranking: list[dict[str, Any]], path: str | os.PathLike[str]) -> Path:
    """The ranking as CSV (:data:`PLACEMENT_COLUMNS`)."""
    path = Path(path)
    with open(path, "w", encoding="utf-8", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=PLACEMENT_COLUMNS)
        writer.writeheader()
        writer.writerows(ranking)
    return path
