"""Recording a console session as an ``lpik simulate`` CSV, and reading one back to replay.

:class:`Recorder` collects one row per control step (the state *before* the
step and the step's outcome, as :class:`~lpik.control.log.SimulationLog`
holds them) and writes them with :meth:`SimulationLog.to_csv`, so that a
recording reads like any ``lpik simulate`` run. Recordings go only into the
folder the console was started with (:func:`recording_path` refuses names
that would leave it). :func:`read_replay` reads such a CSV back: the joint
coordinates, ``p`` and the binding of every step.
"""

from __future__ import annotations

import csv
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lpik.control.log import SimulationLog
from lpik.result import VIOLATES_LIMITS, Result
from lpik.types import FloatArray

#: Most steps one recording keeps (10 minutes at 1 kHz); recording stops there.
MAX_RECORD_STEPS = 600_000
#: Most rows a replayed CSV may have.
MAX_REPLAY_ROWS = 2_000_000
#: A recording's file name: letters, digits, ``-``, ``_``, ``.``; ending in ``.csv``.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,99}\.csv")


def recording_path(folder: str | Path | None, name: str | None = None) -> Path:
    """Where a recording called ``name`` goes: always directly inside ``folder``.

    Args:
        folder: The folder given on the command line (``--record-dir``); None: no recording.
        name: A file name (:data:`NAME_PATTERN`); default ``console-<date>-<time>.csv``.

    Raises:
        ValueError: Without a folder, for a folder that is not a directory, or a name
            that is not a plain file name ending in ``.csv``.
    """
    if folder is None:
        raise ValueError("record: the console was started without --record-dir")
    root = Path(folder).resolve()
    if not root.is_dir():
        raise ValueError(f"record-dir: {str(folder)!r} is not a directory")
    name = name or time.strftime("console-%Y%m%d-%H%M%S.csv")
    if not NAME_PATTERN.fullmatch(name) or ".." in name:
        raise ValueError(f"record: {name!r} is not a plain file name ending in .csv")
    path = (root / name).resolve()
    if path.parent != root:
        raise ValueError(f"record: {name!r} would leave the folder {str(root)!r}")
    return path


def recordings(folder: str | Path | None) -> list[str]:
    """The CSV files directly in ``folder`` (names, sorted); none without a folder."""
    if folder is None or not Path(folder).is_dir():
        return []
    return sorted(p.name for p in Path(folder).iterdir() if NAME_PATTERN.fullmatch(p.name))


@dataclass
class Recorder:
    """The rows of one recording, in memory until :meth:`write`.

    Attributes:
        dt: Control period [s].
        joint_names: One name per joint.
        task_dim: Number of task rows (multiplier columns).
        dims: 2 (planar) or 3: the position columns.
        distances: Whether rows carry ``min_distance`` and ``closest`` (a scene).
    """

    dt: float
    joint_names: tuple[str, ...]
    task_dim: int
    dims: int
    distances: bool = False

    def __post_init__(self) -> None:
        self.rows: list[tuple[Any, ...]] = []
        self.methods: set[str] = set()

    @property
    def full(self) -> bool:
        """Whether the recording holds :data:`MAX_RECORD_STEPS` rows."""
        return len(self.rows) >= MAX_RECORD_STEPS

    def add(
        self,
        q: FloatArray,
        position: FloatArray,
        result: Result,
        closest: tuple[float, str] | None = None,
    ) -> None:
        """One step: the state before it (``q``, tool ``position``) and its outcome."""
        if self.full:
            return
        lam = result.lam if result.moved and result.lam is not None else None
        self.methods.add(result.method)
        self.rows.append(
            (
                q.copy(),
                position[: self.dims].copy(),
                result.p if result.moved else 0.0,
                lam,
                result.status,
                result.binding,
                result.path,
                result.status == VIOLATES_LIMITS,
                result.solve_time,
                closest,
            )
        )

    def log(self, q_end: FloatArray, position_end: FloatArray) -> SimulationLog:
        """The rows as a :class:`~lpik.control.log.SimulationLog`."""
        rows, m, n = self.rows, self.task_dim, len(self.joint_names)
        steps = len(rows)
        binding = np.empty(steps, dtype=object)
        binding[:] = [r[5] for r in rows]
        lam = np.full((steps, m), np.nan)
        for k, r in enumerate(rows):
            if r[3] is not None:
                lam[k] = r[3]
        closest = [r[9] or (np.nan, "") for r in rows]
        return SimulationLog(
            method="+".join(sorted(self.methods)) or "none",
            dt=self.dt,
            t=np.arange(steps) * self.dt,
            q=np.array([r[0] for r in rows]).reshape(steps, n),
            position=np.array([r[1] for r in rows]).reshape(steps, self.dims),
            p=np.array([r[2] for r in rows], dtype=float),
            lam=lam,
            status=np.array([r[4] for r in rows], dtype=str),
            binding=binding,
            path=np.array([r[6] for r in rows], dtype=str),
            clamped=np.array([r[7] for r in rows], dtype=bool),
            solve_time=np.array([r[8] for r in rows], dtype=float),
            q_end=q_end.copy(),
            position_end=position_end[: self.dims].copy(),
            joint_names=self.joint_names,
            name="console",
            min_distance=np.array([c[0] for c in closest]) if self.distances else None,
            closest=np.array([c[1] for c in closest], dtype=str) if self.distances else None,
        )

    def write(self, path: Path, q_end: FloatArray, position_end: FloatArray) -> Path:
        """Write the recording as an ``lpik simulate`` CSV at ``path``."""
        return self.log(q_end, position_end).to_csv(path)


@dataclass(frozen=True, eq=False)
class Replay:
    """A recorded run read back: one row per step.

    Attributes:
        t: Time of each step [s].
        q: Joint coordinates before each step, (N, n).
        p: Each step's dexterity.
        binding: Each step's binding label ("" when none).
        status: Each step's status ("" when the CSV has none).
    """

    t: FloatArray
    q: FloatArray
    p: FloatArray
    binding: tuple[str, ...]
    status: tuple[str, ...]

    @property
    def steps(self) -> int:
        """Number of rows."""
        return int(self.t.size)


def read_replay(path: str | Path, n_joints: int) -> Replay:
    """Read an ``lpik simulate`` CSV (a recording, or any run of an arm with ``n_joints``).

    Raises:
        ValueError: For a file that cannot be read, misses columns, has another number
            of joints, or holds no rows or values that are not finite numbers.
    """
    name = Path(path).name
    try:
        with Path(path).open(newline="", encoding="utf-8") as handle:
            reader = csv.reader(handle)
            header = next(reader, None)
            if header is None:
                raise ValueError(f"replay: {name} is empty")
            columns = {key: k for k, key in enumerate(header)}
            want = ["t", *(f"q{i + 1}" for i in range(n_joints)), "p"]
            missing = [key for key in want if key not in columns]
            if missing or f"q{n_joints + 1}" in columns:
                raise ValueError(
                    f"replay: {name} is not a run of an arm with {n_joints} joints "
                    f"(columns t, q1..q{n_joints}, p)"
                )
            numbers, words = [], []
            for k, row in enumerate(reader):
                if k >= MAX_REPLAY_ROWS:
                    raise ValueError(f"replay: {name} has more than {MAX_REPLAY_ROWS:,} rows")
                numbers.append([float(row[columns[key]]) for key in want])
                words.append(
                    tuple(
                        row[columns[key]] if key in columns else "" for key in ("binding", "status")
                    )
                )
    except OSError as exc:
        raise ValueError(f"replay: cannot read {name}: {exc.strerror or exc}") from None
    except (IndexError, ValueError) as exc:
        if str(exc).startswith("replay:"):
            raise
        raise ValueError(f"replay: {name}: a row is short or not numbers") from None
    table = np.array(numbers, dtype=float).reshape(-1, len(want))
    if table.shape[0] == 0 or not np.isfinite(table).all():
        raise ValueError(f"replay: {name} has no rows, or values that are not finite")
    return Replay(
        t=table[:, 0],
        q=table[:, 1:-1],
        p=table[:, -1],
        binding=tuple(w[0] for w in words),
        status=tuple(w[1] for w in words),
    )
