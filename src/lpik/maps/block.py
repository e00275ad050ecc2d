"""One block of cells, computed: poses reached, the p of every step, the cells' summaries.

A block is a box of cells (a chunk of the map's arrays). Every value in it
depends on its cell alone: the IK seeds of a cell come from the map's seed
and the cell's index (:func:`cell_seeds`), each pose is solved on its own
(:mod:`lpik.maps.ik`) and each step too (:mod:`lpik.maps.steps`), so the map
is the same whichever blocks, workers or order compute it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.maps import ik
from lpik.maps.robot import MapRobot
from lpik.maps.spec import MapSpec
from lpik.maps.steps import NOT_REACHED, lp1_steps, lp2_steps, step_limits
from lpik.tolerances import FULL_P
from lpik.types import FloatArray

#: The summaries of a cell, in the order :func:`summarise` returns them.
SUMMARIES = ("reach_share", "p_mean", "p_min", "weakest_direction", "binding_mode")


@dataclass(frozen=True, eq=False)
class MapJob:
    """What every block of one map needs (sent to the workers once per block).

    Attributes:
        robot: The arm.
        spec: The options.
        poses: (O, 4, 4) the tool poses of a cell: the map's orientations at
            the cell centre (translation 0), or a task's poses (base placement).
        twists: (O, K, 6) the unit motions of each pose.
        cell_sign: +1: a cell is where the tool goes (a map); -1: a cell is
            where the base goes, and the poses are the task's (base placement).
        chunks: Cells per block along x, y, z.
        threads: Threads a worker's compiled batch may use.
    """

    robot: MapRobot
    spec: MapSpec
    poses: FloatArray
    twists: FloatArray
    cell_sign: float = 1.0
    chunks: tuple[int, int, int] = (1, 1, 1)
    threads: int = 1

    @property
    def axes(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The cell centres along x, y and z [m] (:meth:`MapSpec.axes`)."""
        return self.spec.axes()

    @property
    def blocks(self) -> tuple[int, int, int]:
        """Blocks along x, y, z."""
        return tuple(-(-s // c) for s, c in zip(self.spec.shape, self.chunks))  # type: ignore[return-value]

    def block_slices(self, block: tuple[int, int, int]) -> tuple[slice, slice, slice]:
        """The cells of ``block`` along x, y, z."""
        return tuple(slice(b * c, min((b + 1) * c, s))
                     for b, c, s in zip(block, self.chunks, self.spec.shape))  # type: ignore[return-value]  # fmt: skip


@dataclass(frozen=True, eq=False)
class BlockResult:
    """A block's arrays (cells along x, y, z first) and where its time went [s]."""

    p: FloatArray
    binding: Any
    q: FloatArray
    summaries: dict[str, Any]
    seconds: dict[str, float]
    solves: int


def cell_seeds(job: MapJob, index: tuple[int, int, int]) -> FloatArray:
    """The IK seeds (O, S, n) of the cell at ``index``: home, then random within the end-stops.

    Drawn from ``numpy.random.default_rng([seed, ix, iy, iz])``: the cell's own
    stream. A joint without an end-stop draws from -pi..pi.
    """
    robot, spec = job.robot, job.spec
    lo = np.where(np.isfinite(robot.model.q_min), robot.model.q_min, -np.pi)
    hi = np.where(np.isfinite(robot.model.q_max), robot.model.q_max, np.pi)
    rng = np.random.default_rng([spec.seed, *index])
    seeds = rng.uniform(lo, hi, (len(job.poses), spec.seeds, robot.n))
    seeds[:, 0] = np.clip(robot.home, robot.model.q_min, robot.model.q_max)
    return seeds


def block_targets(job: MapJob, slices: tuple[slice, ...]) -> tuple[FloatArray, Any]:
    """The tool poses (C, O, 4, 4) of the block's C cells, and which the arm may reach (C, O)."""
    xs, ys, zs = (axis[s] for axis, s in zip(job.axes, slices))
    centres = np.stack(np.meshgrid(xs, ys, zs, indexing="ij"), axis=-1).reshape(-1, 3)
    targets = np.broadcast_to(job.poses, (len(centres), *job.poses.shape)).copy()
    targets[:, :, :3, 3] += job.cell_sign * centres[:, None, :]
    robot = job.robot
    bound = ik.reach_bound(robot.chain_arrays(), robot.model.q_min, robot.model.q_max)
    within = np.linalg.norm(targets[:, :, :3, 3], axis=-1) <= bound * (1 + 1e-9)
    if 2 not in robot.rows:  # a planar task: the plane z = 0 only
        within &= np.abs(targets[:, :, 2, 3]) <= ik.POSITION_TOL
    return targets, within


def solve_block(job: MapJob, block: tuple[int, int, int]) -> BlockResult:
    """Compute one block (see the module docstring)."""
    start = time.perf_counter()
    robot = job.robot
    slices = job.block_slices(block)
    targets, within = block_targets(job, slices)
    C, O = within.shape  # noqa: E741 - cells, orientations
    indices = np.stack(np.meshgrid(*(np.arange(s.start, s.stop) for s in slices),
                                   indexing="ij"), axis=-1).reshape(-1, 3)  # fmt: skip
    seeds = np.stack([cell_seeds(job, tuple(int(v) for v in i)) for i in indices])
    q = np.full((C, O, robot.n), np.nan)
    todo = np.flatnonzero(within.reshape(-1))
    found = np.empty((todo.size, robot.n))
    rows = np.array(robot.rows, dtype=np.int64)
    ik.solve_targets(*robot.chain_arrays(), rows, robot.model.q_min, robot.model.q_max,
                     targets.reshape(-1, 4, 4)[todo], seeds.reshape(C * O, *seeds.shape[2:])[todo],
                     np.array([ik.POSITION_TOL, ik.ROTATION_TOL]), found)  # fmt: skip
    q.reshape(C * O, -1)[todo] = found
    solved = time.perf_counter()
    p, binding = pose_steps(job, q)
    done = time.perf_counter()
    shape = tuple(s.stop - s.start for s in slices)
    summaries = {k: v.reshape(shape) for k, v in zip(SUMMARIES, summarise(p, binding))}
    return BlockResult(
        p=p.reshape(*shape, O, -1), binding=binding.reshape(*shape, O, -1),
        q=q.reshape(*shape, O, robot.n), summaries=summaries,
        seconds={"ik": solved - start, "lp": done - solved},
        solves=int(np.isfinite(p).sum()),
    )  # fmt: skip


def pose_steps(job: MapJob, q: FloatArray) -> tuple[FloatArray, Any]:
    """The p (C, O, K) (float32) and binding codes (int8) of the steps from ``q`` (C, O, n).

    NaN and :data:`~lpik.maps.steps.NOT_REACHED` where the pose was not reached.
    """
    robot, spec = job.robot, job.spec
    C, O, n = q.shape  # noqa: E741 - cells, orientations, joints
    K = job.twists.shape[1]
    p = np.full((C, O, K), np.nan, dtype=np.float32)
    binding = np.full((C, O, K), NOT_REACHED, dtype=np.int8)
    reached = np.flatnonzero(~np.isnan(q[..., 0]).reshape(-1))
    if reached.size == 0:
        return p, binding
    qs = np.ascontiguousarray(q.reshape(C * O, n)[reached])
    J6 = np.empty((qs.shape[0], 6, n))
    ik.jacobians(*robot.chain_arrays(), qs, J6)
    J = np.ascontiguousarray(J6[:, list(robot.rows)])
    twists = job.twists[reached % O]
    dw = np.ascontiguousarray(spec.speed * spec.dt * twists[:, :, list(robot.rows)])
    if spec.method == "lp1":
        ps, codes = lp1_steps(robot.model, J, dw, qs, spec.dt)
    else:
        ps, codes = lp2_steps(J, dw, qs, step_limits(robot.model, qs, spec.dt), spec.method)
    p.reshape(C * O, K)[reached] = ps
    binding.reshape(C * O, K)[reached] = codes
    return p, binding


def summarise(p: FloatArray, binding: Any) -> tuple[Any, ...]:
    """Each cell's summaries (:data:`SUMMARIES`) from its p and binding codes (C, O, K).

    ``reach_share``: the share of orientations reached; ``p_mean``,
    ``p_min``: over the reached orientations and every direction (NaN: none
    reached); ``weakest_direction``: the direction of least mean p over the
    reached orientations (-1: none reached, or every direction followed in
    full); ``binding_mode``: the kind that binds most
    often among the steps with a binding limit (0: none binds; -1: none reached).
    """
    reached = ~np.isnan(p[:, :, 0])
    share = reached.mean(axis=1).astype(np.float32)
    any_reached = reached.any(axis=1)
    filled = np.where(np.isnan(p), 0.0, p).astype(np.float64)
    count = reached.sum(axis=1)
    per_direction = filled.sum(axis=1) / np.maximum(count, 1)[:, None]
    p_mean = np.where(any_reached, per_direction.mean(axis=1), np.nan).astype(np.float32)
    p_min = np.where(any_reached, np.where(np.isnan(p), np.inf, p).min(axis=(1, 2)), np.nan)
    short = any_reached & (per_direction.min(axis=1) < FULL_P)
    weakest = np.where(short, per_direction.argmin(axis=1), -1).astype(np.int16)
    codes = binding.reshape(len(p), -1).astype(np.int64)
    tallies = np.stack([(codes == k).sum(axis=1) for k in range(1, codes.max(initial=0) + 1)]
                       or [np.zeros(len(p), dtype=np.int64)], axis=1)  # fmt: skip
    mode = np.where(tallies.max(axis=1) > 0, tallies.argmax(axis=1) + 1, 0)
    mode = np.where(any_reached, mode, -1).astype(np.int8)
    return share, p_mean, p_min.astype(np.float32), weakest, mode
