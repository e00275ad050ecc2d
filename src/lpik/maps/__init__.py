"""Capability maps: over a region of cells, what share ``p`` of a step the arm follows, and why.

:func:`build_map` computes, on Dask, for every cell, tool orientation and
unit motion the affine dexterity ``p`` (eq. 10) of one step and the kind of
limit that binds it, into a Zarr store read back as an xarray ``Dataset``;
:func:`open_map` reads one. :func:`place_base` scores candidate base
positions for a task (the inverse map). ``pip install "lpik[maps]"``;
``docs/maps.md`` explains the choices and the measured scaling.
"""

from lpik.maps.api import build_map, run_map
from lpik.maps.robot import MapRobot, map_robot
from lpik.maps.run import MapRun
from lpik.maps.spec import MapSpec
from lpik.maps.store import open_map

__all__ = ["MapRobot", "MapRun", "MapSpec", "build_map", "map_robot", "open_map", "run_map"]
