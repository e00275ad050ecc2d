"""Capability maps: over a region of cells, what share ``p`` of a step the arm follows, and why.

:func:`build_map` computes, on Dask, for every cell, tool orientation and
unit motion the affine dexterity ``p`` (eq. 10) of one step and the kind of
limit that binds it, into a Zarr store read back as an xarray ``Dataset``;
:func:`open_map` reads one. :func:`place_base` scores candidate base
positions for a task (the inverse map). ``pip install "lpik[maps]"``;
``docs/maps.md`` explains the choices and the measured scaling.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

#: Where each public name lives: imported on first use, so that the command line
#: (``lpik map``'s options read :mod:`lpik.maps.spec`) needs neither numba nor Dask.
_HOMES = {
    "build_map": "lpik.maps.api",
    "run_map": "lpik.maps.api",
    "MapRobot": "lpik.maps.robot",
    "map_robot": "lpik.maps.robot",
    "MapRun": "lpik.maps.run",
    "MapSpec": "lpik.maps.spec",
    "open_map": "lpik.maps.store",
}

__all__ = ["MapRobot", "MapRun", "MapSpec", "build_map", "map_robot", "open_map", "run_map"]


def __getattr__(name: str) -> Any:
    """The public name ``name``, from its module (PEP 562)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'lpik.maps' has no attribute {name!r}")
    return getattr(import_module(_HOMES[name]), name)
