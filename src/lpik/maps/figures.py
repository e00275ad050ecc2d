"""Figures of a map: a slice through it, and a base placement's scores (matplotlib).

A slice is one layer of cells across an axis. Its panels: each cell's
smallest ``p`` with a marker for the kind of limit that binds most often;
the mean ``p`` with an arrow along the weakest direction (its motion part,
where it has one, drawn in the slice's plane); and the share of orientations
reached. Cells with nothing reached are left blank; on a fine map the
markers and arrows show on every k-th cell only.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from lpik.maps.steps import BINDING_WORDS
from lpik.paper.style import new_figure, save, styled

#: Marker of each binding kind on a slice (codes of :data:`~lpik.maps.steps.BINDING_WORDS`).
BINDING_MARKERS = {"end-stop": "s", "velocity": "^", "acceleration": "v", "multiplier": "D",
                   "row": "P", "collision": "*", "singularity": "x"}  # fmt: skip
#: The colour map of p (0 red .. 1 green reads as "how much of the motion is followed").
P_COLOURS = "RdYlGn"
#: Most markers and arrows along an axis of a slice (a finer map shows every k-th cell's).
MARKS_PER_AXIS = 28
#: The colour map of the share of orientations reached.
REACH_COLOURS = "Blues"


def pick_slice(dataset: Any, axis: str, value: float | None) -> int:
    """The index along ``axis`` nearest ``value``; None: the layer with the most cells reached."""
    if axis not in ("x", "y", "z"):
        raise ValueError(f"slice: the axis must be x, y or z, got {axis!r}")
    coords = np.asarray(dataset[axis].values)
    if value is not None:
        return int(np.abs(coords - value).argmin())
    share = np.nan_to_num(np.asarray(dataset["reach_share"].values))
    others = tuple(i for i, a in enumerate("xyz") if a != axis)
    return int(share.sum(axis=others).argmax())


def _sparse(shape: tuple[int, ...]) -> Any:
    """Every k-th cell along each axis, so that at most :data:`MARKS_PER_AXIS` marks show."""
    keep = np.zeros(shape, dtype=bool)
    strides = [max(1, -(-size // MARKS_PER_AXIS)) for size in shape]
    keep[tuple(slice(None, None, s) for s in strides)] = True
    return keep


def _layer(dataset: Any, name: str, axis: str, index: int) -> Any:
    return np.asarray(dataset[name].isel({axis: index}).values)


def _edges(centres: Any, fallback: float) -> Any:
    """Cell edges around the centres."""
    if centres.size == 1:
        return np.array([centres[0] - fallback / 2, centres[0] + fallback / 2])
    step = np.diff(centres).mean()
    return np.concatenate([centres - step / 2, [centres[-1] + step / 2]])


@styled
def slice_figure(
    dataset: Any, path: str | os.PathLike[str], *, axis: str = "z", value: float | None = None
) -> Path:
    """Draw the slice of ``dataset`` across ``axis`` at ``value`` (see the module docstring)."""
    index = pick_slice(dataset, axis, value)
    across = [a for a in "xyz" if a != axis]
    u, v = (np.asarray(dataset[a].values) for a in across)
    res = float(dataset.attrs.get("resolution", 1.0))
    eu, ev = _edges(u, res), _edges(v, res)
    fig = new_figure(13.0, 4.4)
    axes = fig.subplots(1, 3, sharex=True, sharey=True)
    panels = (("p_min", "smallest p, marker: limit binding most often"),
              ("p_mean", "mean p, arrow: weakest direction"),
              ("reach_share", "share reached"))  # fmt: skip
    for ax, (name, title) in zip(axes, panels):
        layer = _layer(dataset, name, axis, index).astype(float)
        colours = REACH_COLOURS if name == "reach_share" else P_COLOURS
        shown = ax.pcolormesh(eu, ev, np.ma.masked_invalid(layer).T, cmap=colours,
                              vmin=0.0, vmax=1.0, shading="flat")  # fmt: skip
        if colours == P_COLOURS:
            mesh = shown
        ax.set_title(title)
        ax.set_xlabel(f"{across[0]} [m]")
        ax.set_aspect("equal")
    axes[0].set_ylabel(f"{across[1]} [m]")
    fig.colorbar(mesh, ax=axes, shrink=0.8)
    _binding_markers(axes[0], dataset, axis, index, u, v)
    _weakest_arrows(axes[1], dataset, axis, index, u, v, across)
    where = float(dataset[axis].values[index])
    fig.suptitle(f"{dataset.attrs.get('robot')} ({dataset.attrs.get('method')}), slice "
                 f"{axis} = {where:.3g} m")  # fmt: skip
    return save(fig, path)


def _binding_markers(ax: Any, dataset: Any, axis: str, index: int, u: Any, v: Any) -> None:
    """A marker per cell for the kind that binds most often (none: no marker)."""
    mode = _layer(dataset, "binding_mode", axis, index)
    gu, gv = np.meshgrid(u, v, indexing="ij")
    for code, word in enumerate(BINDING_WORDS):
        cells = (mode == code) & _sparse(mode.shape)
        if word in BINDING_MARKERS and cells.any():
            ax.scatter(gu[cells], gv[cells], marker=BINDING_MARKERS[word], s=10, c="k",
                       linewidths=0.6, label=word)  # fmt: skip
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)


def _weakest_arrows(ax: Any, dataset: Any, axis: str, index: int, u: Any, v: Any,
                    across: list[str]) -> None:  # fmt: skip
    """An arrow per cell along its weakest direction's motion, in the slice's plane."""
    weakest = _layer(dataset, "weakest_direction", axis, index)
    if "direction_twist" not in dataset or not (weakest >= 0).any():
        return
    twists = np.asarray(dataset["direction_twist"].values)
    columns = ["xyz".index(a) for a in across]
    picked = twists[np.maximum(weakest, 0)][..., columns]
    cells = (weakest >= 0) & (np.abs(picked).sum(axis=-1) > 0) & _sparse(weakest.shape)
    gu, gv = np.meshgrid(u, v, indexing="ij")
    stride = max(1, -(-max(weakest.shape) // MARKS_PER_AXIS))  # as _sparse keeps them
    length = 0.7 * stride * float(dataset.attrs.get("resolution", 1.0))
    ax.quiver(gu[cells], gv[cells], picked[cells, 0], picked[cells, 1], angles="xy",
              pivot="middle", scale_units="xy", scale=1.0 / length, width=0.004,
              color="k")  # fmt: skip


@styled
def placement_figure(
    dataset: Any, ranking: list[dict[str, Any]], path: str | os.PathLike[str]
) -> Path:
    """The score of every candidate base position in the best one's z layer, the best marked."""
    best = ranking[0]
    index = int(np.abs(np.asarray(dataset["z"].values) - best["z"]).argmin())
    p = np.asarray(dataset["p"].isel(z=index).values, dtype=float)[..., 0]
    score = np.where(np.isnan(p), 0.0, p).min(axis=-1)
    x, y = np.asarray(dataset["x"].values), np.asarray(dataset["y"].values)
    res = float(dataset.attrs.get("resolution", 1.0))
    fig = new_figure(6.5, 5.5)
    ax = fig.subplots()
    mesh = ax.pcolormesh(_edges(x, res), _edges(y, res), score.T, cmap=P_COLOURS, vmin=0.0,
                         vmax=1.0, shading="flat")  # fmt: skip
    fig.colorbar(mesh, ax=ax, label="score: smallest p over the task")
    tasks = np.asarray(dataset["task_position"].values)
    ax.scatter(tasks[:, 0], tasks[:, 1], marker="x", c="k", s=20, label="task poses")
    others = [r for r in ranking[1:] if abs(r["z"] - best["z"]) < 1e-12]
    if others:
        ax.scatter([r["x"] for r in others], [r["y"] for r in others], marker="o",
                   facecolors="none", edgecolors="k", label="next best")  # fmt: skip
    ax.scatter([best["x"]], [best["y"]], marker="*", s=160, c="b",
               label=f"best: score {best['score']:.3g}")  # fmt: skip
    ax.set(xlabel="base x [m]", ylabel="base y [m]", aspect="equal",
           title=f"base placement, {dataset.attrs.get('robot')}, "
           f"z = {best['z']:.3g} m")  # fmt: skip
    ax.legend(loc="upper right", fontsize=8)
    return save(fig, path)
