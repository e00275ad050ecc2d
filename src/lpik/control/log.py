"""The record of a closed-loop run: one row per step, its summary numbers and its CSV.

Row ``k`` of a :class:`SimulationLog` holds the state *before* step ``k`` and
that step's outcome. The CSV columns are ``t, q1..qn, x, y[, z], p,
lam1..lamm`` (positions in the task's plane or space), then ``status,
binding, path, clamped, solve_time_us``, and for a run with a scene
``min_distance, closest`` (the smallest signed distance before the step [m] and its pair),
and last, where the run recorded it, ``pull_scale`` (the share of sec. 3.1's pull
each step took: :attr:`lpik.result.Result.pull_scale`).
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from lpik.result import RECOVERING
from lpik.types import FloatArray


@dataclass(frozen=True, eq=False)
class RunMetrics:
    """Numbers that summarise one run (see :meth:`SimulationLog.metrics`).

    Attributes:
        steps: Number of steps.
        jitter: Total variation of the joint velocities [rad/s]: the sum over
            steps and joints of ``|qdot(k+1) - qdot(k)|``.
        max_q: Largest value of each joint over the run, final state included, shape (n,) [rad].
        final_p: Affine dexterity of the last step.
        final_position: End-effector position after the last step [m].
        max_abs_lambda: Largest ``|lam_i|`` over the run (NaN when the method has none).
        median_solve_time: Median solve time of a step [s].
        p99_solve_time: 99th percentile of the solve time [s].
        max_solve_time: The slowest step's solve time [s].
        statuses: How many steps ended with each status.
        recovery_steps: Steps taken from a state outside its limits (status
            ``recovering``): how long recovery took.
    """

    steps: int
    jitter: float
    max_q: FloatArray
    final_p: float
    final_position: FloatArray
    max_abs_lambda: float
    median_solve_time: float
    p99_solve_time: float
    max_solve_time: float
    statuses: Mapping[str, int]
    recovery_steps: int


@dataclass(frozen=True, eq=False)
class SimulationLog:
    """Everything one closed-loop run recorded, one row per step.

    Row ``k`` holds the state *before* step ``k`` and that step's outcome
    (the ``lpik simulate`` CSV). The state after the last step is
    ``q_end`` / ``position_end``.

    Attributes:
        method: Name of the method that ran.
        dt: Control period [s].
        t: Time of each step, shape (N,) [s].
        q: Joint coordinates before each step, shape (N, n) [rad or m].
        position: End-effector position before each step, shape (N, 2 or 3) [m].
        p: Affine dexterity of each step, shape (N,).
        lam: Lagrange multipliers of each step, shape (N, m); NaN when the
            method has none or the step was a safe step.
        status: Status word of each step, shape (N,).
        binding: Binding (or broken) limit of each step, a :class:`~lpik.labels.Binding`
            or ``None`` when none (the CSV writes an empty field), shape (N,).
        path: How each step was computed (``"ratio-test"``, ``"highs"``, ...), shape (N,).
        clamped: True where a classical step was clamped to the end-stops, shape (N,).
        solve_time: Wall time of each step's method [s], shape (N,).
        q_end: Joint coordinates after the last step, shape (n,).
        position_end: End-effector position after the last step [m].
        joint_names: One name per joint.
        name: Name of the run (e.g. the scenario's).
        warm_start: Whether the LP solver was warm-started across steps.
        min_distance: Smallest signed distance between the robot and the obstacles (and
            between its links) before each step, shape (N,) [m]; None without a scene.
        closest: The pair at that distance, shape (N,); None without a scene.
        pull_scale: The share of sec. 3.1's pull each step took
            (:attr:`lpik.result.Result.pull_scale`: 1 where the whole pull fits, and for
            safe steps), shape (N,); None where the run did not record it.
    """

    method: str
    dt: float
    t: FloatArray
    q: FloatArray
    position: FloatArray
    p: FloatArray
    lam: FloatArray
    status: NDArray[np.str_]
    binding: NDArray[np.object_]
    path: NDArray[np.str_]
    clamped: NDArray[np.bool_]
    solve_time: FloatArray
    q_end: FloatArray
    position_end: FloatArray
    joint_names: tuple[str, ...]
    name: str = ""
    warm_start: bool = True
    min_distance: FloatArray | None = None
    closest: NDArray[np.str_] | None = None
    pull_scale: FloatArray | None = None

    def __post_init__(self) -> None:
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False  # a log is a value: its arrays are read-only

    @property
    def steps(self) -> int:
        """Number of steps."""
        return int(self.t.size)

    def joint_velocities(self) -> FloatArray:
        """Applied joint velocity of each step, ``(q(k+1) - q(k)) / dt``, shape (N, n) [rad/s]."""
        q_all = np.vstack([self.q, self.q_end])
        return np.diff(q_all, axis=0) / self.dt

    def jitter(self) -> float:
        """Total variation of the joint velocities: ``sum_k sum_i |qdot_i(k+1) - qdot_i(k)|``.

        Returns:
            The jitter [rad/s]; 0 for a run of one step.
        """
        return float(np.abs(np.diff(self.joint_velocities(), axis=0)).sum())

    def metrics(self) -> RunMetrics:
        """The run's summary numbers (jitter, extremes, final state, solve times, recovery)."""
        lam = np.abs(self.lam)
        has_lam = bool(np.isfinite(lam).any())
        values, counts = np.unique(self.status, return_counts=True)
        return RunMetrics(
            steps=self.steps,
            jitter=self.jitter(),
            max_q=np.vstack([self.q, self.q_end]).max(axis=0),
            final_p=float(self.p[-1]) if self.steps else float("nan"),
            final_position=self.position_end.copy(),
            max_abs_lambda=float(np.nanmax(lam)) if has_lam else float("nan"),
            median_solve_time=float(np.median(self.solve_time)) if self.steps else 0.0,
            p99_solve_time=float(np.percentile(self.solve_time, 99)) if self.steps else 0.0,
            max_solve_time=float(self.solve_time.max()) if self.steps else 0.0,
            statuses={str(v): int(c) for v, c in zip(values, counts)},
            recovery_steps=int(np.count_nonzero(self.status == RECOVERING)),
        )

    def header(self) -> list[str]:
        """CSV header: ``t, q1..qn, x, y[, z], p, lam1..lamm`` then the extra columns."""
        n, m = self.q.shape[1], self.lam.shape[1]
        coords = ["x", "y", "z"][: self.position.shape[1]]
        return [
            "t",
            *(f"q{i + 1}" for i in range(n)),
            *coords,
            "p",
            *(f"lam{i + 1}" for i in range(m)),
            "status",
            "binding",
            "path",
            "clamped",
            "solve_time_us",
            *(("min_distance", "closest") if self.min_distance is not None else ()),
            *(("pull_scale",) if self.pull_scale is not None else ()),
        ]

    def _distance_cells(self, k: int) -> list[str]:
        if self.min_distance is None or self.closest is None:
            return []
        return [f"{self.min_distance[k]:.12g}", str(self.closest[k])]

    def _pull_cells(self, k: int) -> list[str]:
        return [] if self.pull_scale is None else [f"{self.pull_scale[k]:.12g}"]

    def to_csv(self, path: str | Path) -> Path:
        """Write the log as CSV, one row per step (the ``lpik simulate`` contract).

        Numbers are written with 12 significant digits; missing multipliers as ``nan``.

        Raises:
            ValueError: When the file cannot be written (names the path).
        """
        out = Path(path)
        try:
            handle = out.open("w", newline="", encoding="utf-8")
        except OSError as exc:
            raise ValueError(f"csv: cannot write {str(out)!r}: {exc.strerror or exc}") from None
        with handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(self.header())
            for k in range(self.steps):
                numbers = [self.t[k], *self.q[k], *self.position[k], self.p[k], *self.lam[k]]
                writer.writerow(
                    [
                        *(f"{v:.12g}" for v in numbers),
                        self.status[k],
                        self.binding[k] or "",
                        self.path[k],
                        int(self.clamped[k]),
                        f"{self.solve_time[k] * 1e6:.1f}",
                        *self._distance_cells(k),
                        *self._pull_cells(k),
                    ]
                )
        return out
