"""``lpik map``: a capability map of p over a region on Dask, into a Zarr store; or base placement.

``lpik map --robot NAME | --urdf FILE --tip LINK --region X0,X1,Y0,Y1,Z0,Z1
--resolution R --out DIR`` computes for every cell, tool orientation and
unit motion the p of one step and the kind of limit that binds it
(:mod:`lpik.maps`), on a local Dask cluster (``--workers N``) or an existing
one (``--scheduler tcp://HOST:PORT``), written block by block to the Zarr
store DIR. The same command on the same DIR continues an interrupted map
(and only the same map: other options are refused). ``--place TASK.csv``
scores candidate base positions over the region instead (the inverse map)
and prints the best (``--placements FILE.csv`` writes them). Bad input: one
line, exit 2.
"""

from __future__ import annotations

import argparse
from typing import Any

from lpik.cli import as_option
from lpik.defaults import DEFAULT_METHOD


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik map`` (light: Dask, Zarr and xarray are imported only when it runs)."""
    from lpik.cli.robots import add_robot_arguments
    from lpik.command import DEFAULT_V_MAX
    from lpik.maps.spec import MAP_DT, MAP_METHODS, MAP_SEEDS

    parser = sub.add_parser(
        "map",
        help="map p over a region of cells (what the arm can follow, in which direction, and "
        "why not) on Dask, or score base positions for a task",
        description="Compute a capability map: for every cell, tool orientation and unit "
        "motion, a configuration that reaches the pose and the affine dexterity p of one "
        "step, with the kind of limit that binds it; written to a Zarr store block by block "
        "(xarray.open_zarr reads it). Needs pip install 'lpik[maps]'.",
    )
    add_robot_arguments(parser, robot_help="'planar' (the paper's 4-link arm) or a bundled "
                        "3-D arm (lpik robots)")  # fmt: skip
    parser.add_argument("--region", required=True, metavar="X0,X1,Y0,Y1[,Z0,Z1]",
                        help="the box of cells [m], base frame (planar: x and y only); with "
                        "--place, where the base may go (world frame)")  # fmt: skip
    parser.add_argument("--resolution", required=True, type=float, metavar="R",
                        help="cell edge [m]")  # fmt: skip
    parser.add_argument("--orientations", type=int, default=1, metavar="N",
                        help="tool orientations per cell, evenly spread (default 1: the home "
                        "configuration's)")  # fmt: skip
    parser.add_argument("--directions", type=int, default=6, metavar="K",
                        help="unit motions per pose, evenly spread, half translations and half "
                        "rotations on a pose task (default 6)")  # fmt: skip
    parser.add_argument("--method", default=DEFAULT_METHOD, choices=MAP_METHODS,
                        help=f"lp1: what the arm can do at all; lp2s: what lpik's controller "
                        f"does (default {DEFAULT_METHOD})")  # fmt: skip
    parser.add_argument("--speed", type=float, default=DEFAULT_V_MAX, metavar="V",
                        help=f"the step is V * dt along the unit motion [m/s or rad/s] "
                        f"(default {DEFAULT_V_MAX:g})")  # fmt: skip
    parser.add_argument("--dt", type=float, default=MAP_DT, help=f"control period [s] (default "
                        f"{MAP_DT:g})")  # fmt: skip
    parser.add_argument("--seeds", type=int, default=MAP_SEEDS, metavar="S",
                        help=f"IK seeds per pose (default {MAP_SEEDS})")  # fmt: skip
    parser.add_argument("--seed", type=int, default=0, help="the seeds' random seed (default 0)")
    _add_run_arguments(parser)
    parser.set_defaults(handler=run)


def _add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """Where it runs and what it writes."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="an existing Dask scheduler (tcp://HOST:PORT); its workers must "
                       "be able to write --out")  # fmt: skip
    where.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="processes of the local Dask cluster (default: one per core)",
    )
    parser.add_argument("--chunk", type=int, metavar="C",
                        help="cells per block along each axis (default: about 1,000 poses a "
                        "block)")  # fmt: skip
    parser.add_argument("--out", required=True, metavar="DIR", help="the Zarr store")
    parser.add_argument(
        "--figure",
        metavar="FIG.png",
        help="draw a slice through the map (with --place: the scores)",
    )
    parser.add_argument("--slice", metavar="AXIS=VALUE",
                        help="the slice to draw, e.g. z=0.3 (default: z, the layer with the "
                        "most cells reached)")  # fmt: skip
    parser.add_argument("--place", metavar="TASK.csv",
                        help="score base positions over --region for the task's poses and "
                        "directions (columns x,y,z,qw,qx,qy,qz,vx,vy,vz,wx,wy,wz) and print "
                        "the best")  # fmt: skip
    parser.add_argument(
        "--placements",
        metavar="FILE.csv",
        help="with --place: write the best base positions as CSV",
    )


def _numbers(option: str, text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"{option}: must be numbers separated by commas, got {text!r}") from None


def _slice(text: str | None) -> tuple[str, float | None]:
    if text is None:
        return "z", None
    axis, _, value = text.partition("=")
    if axis.strip() not in ("x", "y", "z") or not value:
        raise ValueError(f"--slice: must be AXIS=VALUE with AXIS x, y or z, got {text!r}")
    return axis.strip(), _numbers("--slice", value)[0]


def _require_maps() -> None:
    """Refuse in one line when the maps extra is missing."""
    import importlib.util

    missing = [m for m in ("distributed", "zarr", "xarray") if importlib.util.find_spec(m) is None]
    if missing:
        raise ValueError(f"map: needs {', '.join(missing)}: pip install 'lpik[maps]'")


def run(args: argparse.Namespace) -> int:
    """Compute (or continue) the map or the placement; print what it found."""
    from lpik.cli.robots import robot_from_arguments

    _require_maps()
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers: must be a whole number >= 1, got {args.workers}")
    region = _numbers("--region", args.region)
    axis, value = _slice(args.slice)
    if args.figure is not None:
        from lpik.paper.style import require_backend

        require_backend()
    robot = robot_from_arguments(args)
    options = _options(args)
    try:
        run = _compute(args, robot, region, options)
    except ValueError as exc:  # the API names its arguments; the command line, its options
        raise ValueError(_as_option(str(exc))) from None
    except OSError as exc:  # the store cannot be made where --out says
        if exc.filename is None or not str(exc.filename).startswith(str(args.out)):
            raise
        raise OSError(f"--out: cannot write {args.out!r}: {exc.strerror or exc}") from None
    return _report(args, run, axis, value)


def _options(args: argparse.Namespace) -> dict[str, Any]:
    from lpik.cli.progress import LazyProgress

    return {
        "method": args.method, "speed": args.speed, "dt": args.dt, "seeds": args.seeds,
        "seed": args.seed, "scheduler": args.scheduler, "workers": args.workers,
        "chunk": args.chunk, "progress": LazyProgress("map"), "out": args.out,
        "on_start": _started,
    }  # fmt: skip


def _started(run: Any) -> None:
    resumed = f", {run.resumed} of {run.blocks} blocks already written" if run.resumed else ""
    print(f"lpik map: {run.blocks} blocks on {run.workers} Dask workers{resumed}", flush=True)
    if run.dashboard:
        print(f"lpik map: dashboard {run.dashboard}", flush=True)


def _compute(args: argparse.Namespace, robot: Any, region: Any, options: dict[str, Any]) -> Any:
    progress = options["progress"]
    with progress:
        if args.place is not None:
            from lpik.maps.placement import place_base

            return place_base(robot, args.place, region, args.resolution, **options)
        from lpik.maps import run_map

        return run_map(robot, region, args.resolution, orientations=args.orientations,
                       directions=args.directions, **options)  # fmt: skip


#: The API's argument names, as the command line spells its options.
_OPTION_NAMES = (
    *("region", "resolution", "orientations", "directions", "method", "speed", "dt", "seeds"),
    *("seed", "scheduler", "workers", "chunk", "out", "task", "robot"),
)


def _as_option(message: str) -> str:
    return as_option(message, _OPTION_NAMES, {"task": "place"})


def _report(args: argparse.Namespace, run: Any, axis: str, value: float | None) -> int:
    """Print the map's summary; draw the figure and write the placements asked for."""
    import numpy as np

    from lpik.maps import open_map
    from lpik.maps.steps import BINDING_WORDS

    dataset = open_map(run.path, dask=False)
    share = np.nan_to_num(np.asarray(dataset["reach_share"].values))
    reached = int((share > 0).sum())
    what = "candidate base positions" if args.place else "cells"
    print(f"lpik map: {reached:,} of {share.size:,} {what} reached, {run.solves:,} steps solved "
          f"in {run.wall_s:.1f} s")  # fmt: skip
    if reached == 0:
        print("lpik map: the arm reaches no pose over the region: the map is empty")
    else:
        p_min = np.asarray(dataset["p_min"].values)
        mode = np.asarray(dataset["binding_mode"].values)
        counts = np.bincount(mode[mode > 0].astype(int), minlength=len(BINDING_WORDS))
        binds = BINDING_WORDS[int(counts.argmax())] if counts.any() else "none"
        print(f"lpik map: smallest p over a cell: median {np.nanmedian(p_min):.3g}, lowest "
              f"{np.nanmin(p_min):.3g}; binding most often: {binds}")  # fmt: skip
    if args.place is not None and reached:
        _placements(args, dataset)
    elif args.figure is not None and reached:
        from lpik.maps.figures import slice_figure

        print(f"lpik map: wrote {slice_figure(dataset, args.figure, axis=axis, value=value)}")
    print(f"lpik map: wrote {run.path} ({dataset.attrs.get('status')})")
    return 0


def _placements(args: argparse.Namespace, dataset: Any) -> None:
    from lpik.maps.placement import rank_placements, write_placements

    ranking = rank_placements(dataset)
    best = ranking[0]
    print(f"lpik map: best base position ({best['x']:.4g}, {best['y']:.4g}, {best['z']:.4g}) m, "
          f"smallest p over the task {best['score']:.3g}")  # fmt: skip
    print("rank  x [m]  y [m]  z [m]  score  reached  p_mean  weakest_row")
    for r in ranking:
        print(f"{r['rank']:>4} {r['x']:>6.3g} {r['y']:>6.3g} {r['z']:>6.3g} {r['score']:>6.3g} "
              f"{r['reached']:>8.3g} {r['p_mean']:>7.3g} {r['weakest_row']:>12}")  # fmt: skip
    if args.placements is not None:
        print(f"lpik map: wrote {write_placements(ranking, args.placements)}")
    if args.figure is not None:
        from lpik.maps.figures import placement_figure

        print(f"lpik map: wrote {placement_figure(dataset, ranking, args.figure)}")
