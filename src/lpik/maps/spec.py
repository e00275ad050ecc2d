"""A map's options as one validated value: the grid, the sets of poses and steps, the sizes.

The cells of an axis from ``lo`` to ``hi`` at resolution ``R`` are
``ceil((hi - lo) / R)`` cells of width ``R`` from ``lo`` on, their centres at
``lo + (k + 1/2) R`` (the last may reach past ``hi`` by less than ``R``); an
axis with ``lo = hi`` is one cell centred at ``lo``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from lpik.command import DEFAULT_V_MAX
from lpik.defaults import DEFAULT_METHOD
from lpik.tolerances import MAX_DT, MAX_MAGNITUDE
from lpik.types import FloatArray
from lpik.version import __version__

#: The methods a map takes: LP1 (what the arm can do at all) and LP2 with or without saturation.
MAP_METHODS = ("lp1", "lp2", "lp2s")

#: The control period of a map's step [s]: the 10 ms of the paper's runs.
MAP_DT = 0.01
#: IK seeds per pose by default: the arm's home configuration and 15 random
#: ones. From 16, the Panda's poses of random configurations were reached in
#: 93 to 100 % of samples (``benchmarks/bench_maps.py``, docs/maps.md); seeds
#: after the first that reaches a pose cost nothing, an unreachable pose all 16.
MAP_SEEDS = 16
#: (cell, orientation) pairs per block by default: about a second of work on one core.
POSES_PER_BLOCK = 1024
#: Most cells along one axis (a larger grid is refused before any work).
MAX_CELLS_PER_AXIS = 100_000
#: Fewest blocks of a map that has the cells for them, so that several workers share it.
MIN_BLOCKS = 16
#: Most blocks of one map (a finer grid needs larger blocks, ``chunk``).
MAX_BLOCKS = 1_000_000
#: Bytes a map stores per (cell, orientation, direction): p (float32) and the binding code (int8).
BYTES_PER_STEP = 5


@dataclass(frozen=True)
class MapSpec:
    """What a map is of, everything but the arm (validated on construction).

    Attributes:
        region: ``(xmin, xmax, ymin, ymax, zmin, zmax)`` [m] in the base frame.
        resolution: Edge of a cell [m].
        orientations: Tool orientations per cell (:mod:`lpik.maps.spread`).
        directions: Unit motions per pose (:mod:`lpik.maps.spread`).
        method: ``"lp1"``, ``"lp2"`` or ``"lp2s"`` (:mod:`lpik.maps.steps`).
        speed: The step is ``speed * dt * direction_twist`` [m/s, rad/s].
        dt: Control period of the step [s].
        seeds: IK seeds per pose (:mod:`lpik.maps.ik`).
        seed: The random seeds' seed; a cell's seeds come from it and the cell's index.

    Raises:
        ValueError: Naming the option that is wrong.
    """

    region: tuple[float, float, float, float, float, float]
    resolution: float
    orientations: int = 1
    directions: int = 6
    method: str = DEFAULT_METHOD
    speed: float = DEFAULT_V_MAX
    dt: float = MAP_DT
    seeds: int = MAP_SEEDS
    seed: int = 0

    def __post_init__(self) -> None:
        region = tuple(_number("region", v) for v in self.region)
        if len(region) != 6:
            raise ValueError(f"region: must be xmin,xmax,ymin,ymax,zmin,zmax [m], got {region}")
        for axis, k in zip("xyz", range(0, 6, 2)):
            if region[k] > region[k + 1]:
                raise ValueError(f"region: {axis}min {region[k]:g} exceeds {axis}max "
                                 f"{region[k + 1]:g}")  # fmt: skip
        object.__setattr__(self, "region", region)
        for name, top in (("resolution", MAX_MAGNITUDE), ("speed", MAX_MAGNITUDE), ("dt", MAX_DT)):
            if not 0 < _number(name, getattr(self, name)) <= top:
                raise ValueError(f"{name}: must be > 0 (at most {top:g}), got "
                                 f"{getattr(self, name)!r}")  # fmt: skip
        for axis, k in zip("xyz", range(0, 6, 2)):  # before any cell is counted in integers
            cells = (region[k + 1] - region[k]) / float(self.resolution)
            if cells > MAX_CELLS_PER_AXIS:
                raise ValueError(f"resolution: {cells:.3g} cells along {axis}, more than "
                                 f"{MAX_CELLS_PER_AXIS:,}; use a coarser resolution or a "
                                 f"smaller region")  # fmt: skip
        for name in ("orientations", "directions", "seeds"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise ValueError(f"{name}: must be a whole number >= 1, got "
                                 f"{getattr(self, name)!r}")  # fmt: skip
        if not (isinstance(self.seed, int) and self.seed >= 0):
            raise ValueError(f"seed: must be a whole number >= 0, got {self.seed!r}")
        if self.method not in MAP_METHODS:
            raise ValueError(f"method: a map takes {', '.join(MAP_METHODS)}, got {self.method!r}")

    @property
    def shape(self) -> tuple[int, int, int]:
        """Cells along x, y and z."""
        return tuple(_cells(self.region[k], self.region[k + 1], self.resolution)
                     for k in (0, 2, 4))  # type: ignore[return-value]  # fmt: skip

    @property
    def cells(self) -> int:
        """Cells in all."""
        return math.prod(self.shape)

    def axes(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The cell centres along x, y and z [m]."""
        return tuple(_centres(self.region[k], self.region[k + 1], self.resolution, count)
                     for k, count in zip((0, 2, 4), self.shape))  # type: ignore[return-value]  # fmt: skip

    def attributes(self) -> dict[str, object]:
        """The options as the map's attributes (with lpik's version)."""
        values = asdict(self)
        values["region"] = list(self.region)
        return {**values, "lpik_version": __version__}

    @classmethod
    def from_attributes(cls, attrs: dict[str, object]) -> MapSpec:
        """The spec a map's attributes describe."""
        names = {f.name for f in fields(cls)}
        values = {k: v for k, v in attrs.items() if k in names}
        values["region"] = tuple(values["region"])  # type: ignore[arg-type]
        return cls(**values)  # type: ignore[arg-type]

    def chunk_shape(self, chunk: int | None) -> tuple[int, int, int]:
        """Cells per block along x, y, z: ``chunk`` each, or sized to :data:`POSES_PER_BLOCK`."""
        shape = self.shape
        if chunk is None:
            cells = max(1, POSES_PER_BLOCK // self.orientations)
            spread = max(1, sum(count > 1 for count in shape))
            chunk = max(1, int(math.floor(cells ** (1.0 / spread) + 1e-9)))
            while chunk > 1 and self._blocks(chunk) < MIN_BLOCKS:
                chunk -= 1
            while self._blocks(chunk) > MAX_BLOCKS:
                chunk *= 2
        elif not (isinstance(chunk, int) and chunk >= 1):
            raise ValueError(f"chunk: must be a whole number >= 1 (cells per block edge), got "
                             f"{chunk!r}")  # fmt: skip
        return tuple(min(chunk, count) for count in shape)  # type: ignore[return-value]

    def _blocks(self, chunk: int) -> int:
        return math.prod(-(-s // min(chunk, s)) for s in self.shape)

    def disk_bytes(self, joints: int) -> int:
        """Bytes of the map, uncompressed: what it may take on disk at most."""
        per_pose = self.directions * BYTES_PER_STEP + joints * 8 + 1
        return self.cells * (self.orientations * per_pose + 16)

    def solves(self) -> int:
        """LP solves of the whole map (every pose reached)."""
        return self.cells * self.orientations * self.directions


def _number(name: str, value: object) -> float:
    try:
        number = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be numbers, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name}: must be finite, got {value!r}")
    return number


def _cells(lo: float, hi: float, resolution: float) -> int:
    return max(1, math.ceil((hi - lo) / resolution - 1e-9))


def _centres(lo: float, hi: float, resolution: float, count: int) -> FloatArray:
    if hi == lo:
        return np.array([lo])
    return lo + (np.arange(count) + 0.5) * resolution
