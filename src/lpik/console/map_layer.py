"""A capability map in the console: its cells as voxels coloured by p, the weakest direction drawn.

``lpik console --map DIR`` reads a map written by ``lpik map``
(:mod:`lpik.maps`) and shows every cell that reaches at least one
orientation as a translucent box, coloured by the cell's smallest ``p`` (red
0, yellow 0.5, green 1), with a line from its centre along its weakest
direction's motion (where that direction is a translation; a rotation is
drawn along its axis, in grey). :func:`map_voxels` reads what is drawn (no
viser needed), :func:`add_map_layer` draws it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.types import FloatArray

#: The scene's name of the layer.
LAYER = "/map"
#: Edge of a voxel, as a share of the cell, and its opacity.
VOXEL_SHARE, VOXEL_OPACITY = 0.8, 0.35
#: Length of a weakest-direction line, as a share of the cell.
ARROW_SHARE = 0.5
#: Colour of a line along a rotation's axis.
ROTATION_COLOUR = (120, 120, 120)
#: Most voxels drawn (a browser draws a few hundred thousand boxes at most).
MAX_VOXELS = 200_000

_BOX_VERTICES = np.array(
    [[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)], dtype=np.float32
)
_BOX_FACES = np.array(
    [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
     [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]],
    dtype=np.uint32,
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class MapLayer:
    """What the console draws of a map.

    Attributes:
        centres: (V, 3) centres of the cells drawn [m].
        colours: (V, 3) their colours (uint8), by the cell's smallest p.
        edge: Edge of a voxel [m].
        segments: (W, 2, 3) the weakest directions' lines.
        segment_colours: (W, 3) their colours.
        title: One line about the map (robot, method, cells).
    """

    centres: FloatArray
    colours: Any
    edge: float
    segments: FloatArray
    segment_colours: Any
    title: str


def p_colour(p: FloatArray) -> Any:
    """RGB (uint8) of p: red at 0, yellow at 0.5, green at 1."""
    p = np.clip(np.asarray(p, dtype=np.float64), 0.0, 1.0)
    red = np.where(p < 0.5, 1.0, 2.0 * (1.0 - p))
    green = np.where(p < 0.5, 2.0 * p, 1.0)
    return (np.stack([red * 220, green * 190, np.full_like(p, 40.0)], axis=-1)).astype(np.uint8)


def map_voxels(path: str | os.PathLike[str]) -> MapLayer:
    """The voxels and lines of the map in ``path`` (see the module docstring).

    Raises:
        ValueError: Naming ``--map`` when ``path`` holds no map, or one of
            more than :data:`MAX_VOXELS` reached cells.
    """
    try:
        from lpik.maps import open_map

        dataset = open_map(path, dask=False)
        share = np.asarray(dataset["reach_share"].values)
        p_min = np.asarray(dataset["p_min"].values)
    except (ValueError, ImportError, KeyError) as exc:
        raise ValueError(f"--map: {str(exc).removeprefix('map: ')}") from None
    cells = np.argwhere(np.nan_to_num(share) > 0)
    if len(cells) > MAX_VOXELS:
        raise ValueError(
            f"--map: {len(cells):,} cells reached, more than the console draws "
            f"({MAX_VOXELS:,}); map a smaller region or at a coarser resolution"
        )
    axes = [np.asarray(dataset[a].values) for a in "xyz"]
    centres = np.array([[axes[k][c[k]] for k in range(3)] for c in cells]).reshape(-1, 3)
    edge = float(dataset.attrs.get("resolution", 0.1))
    colours = p_colour(p_min[tuple(cells.T)]).reshape(-1, 3)
    segments, segment_colours = _weakest_lines(dataset, cells, centres, edge)
    title = (f"{dataset.attrs.get('robot')} map ({dataset.attrs.get('method')}): "
             f"{len(cells):,} cells reached, coloured by the smallest p")  # fmt: skip
    return MapLayer(centres, colours, edge, segments, segment_colours, title)


def _weakest_lines(dataset: Any, cells: Any, centres: FloatArray, edge: float) -> tuple[Any, Any]:
    """A line per cell along its weakest direction (motion; a rotation: its axis, grey)."""
    if "direction_twist" not in dataset or len(cells) == 0:
        return np.zeros((0, 2, 3)), np.zeros((0, 3), dtype=np.uint8)
    weakest = np.asarray(dataset["weakest_direction"].values)[tuple(cells.T)].astype(int)
    twists = np.asarray(dataset["direction_twist"].values)
    keep = weakest >= 0
    twist = twists[weakest[keep]]
    motion = np.linalg.norm(twist[:, :3], axis=1) > 0
    along = np.where(motion[:, None], twist[:, :3], twist[:, 3:])
    start = centres[keep]
    segments = np.stack([start, start + ARROW_SHARE * edge * along], axis=1)
    p_min = np.asarray(dataset["p_min"].values)[tuple(cells[keep].T)]
    colours = np.where(motion[:, None], p_colour(p_min), np.array(ROTATION_COLOUR, np.uint8))
    return segments, colours.astype(np.uint8)


def add_map_layer(scene: Any, layer: MapLayer) -> None:
    """Draw ``layer`` in a viser scene under :data:`LAYER`."""
    if len(layer.centres):
        count = len(layer.centres)
        scene.add_batched_meshes_simple(
            f"{LAYER}/voxels",
            vertices=_BOX_VERTICES,
            faces=_BOX_FACES,
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (count, 1)),
            batched_positions=layer.centres.astype(np.float32),
            batched_scales=np.full(count, VOXEL_SHARE * layer.edge, dtype=np.float32),
            batched_colors=layer.colours,
            opacity=VOXEL_OPACITY,
            cast_shadow=False,
            receive_shadow=False,
        )
    if len(layer.segments):
        ends = np.repeat(layer.segment_colours[:, None, :], 2, axis=1)  # (W, 2, 3): both ends
        scene.add_line_segments(f"{LAYER}/weakest", layer.segments.astype(np.float32), ends,
                                thickness=0.05 * layer.edge)  # fmt: skip
