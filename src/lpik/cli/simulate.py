"""``lpik simulate SCENARIO [--robot NAME] --method METHOD --out RUN.csv``: one closed-loop run.

One path for every robot: :meth:`lpik.paper.scenarios.Scenario.setup` gives the
run, :mod:`lpik.paper.run_figures` draws it.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lpik.control.log import SimulationLog
    from lpik.paper.scenarios import Setup


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik simulate`` (light: the methods are imported only when it runs)."""
    from lpik.paper.scenarios import PLANAR, SCENARIOS

    parser = sub.add_parser(
        "simulate",
        help="run a scenario in closed loop and write the log as CSV",
        description="Run one of the paper's scenarios in closed loop, on the paper's planar arm "
        "or a bundled 3-D arm. The CSV has one row per step: t, q1..qn [rad], x, y[, z] [m], "
        "p, lam1..lamm (the state before the step, the step's dexterity and multipliers), "
        "then status, binding, path, clamped, solve_time_us. Scenarios: "
        + "; ".join(f"{s.name}: {s.description}" for s in SCENARIOS.values())
        + ".",
    )
    parser.add_argument("scenario", metavar="SCENARIO", help=f"one of {', '.join(SCENARIOS)}")
    parser.add_argument(
        "--robot",
        metavar="NAME",
        default=PLANAR,
        help=f"'{PLANAR}' (the paper's 4-link arm, default) or a bundled 3-D arm (lpik robots)",
    )
    parser.add_argument(
        "--method",
        default="lp2",
        help="pinv, weighted, robust, lp1, l1, lp2 or nlp (default lp2; lpik.methods lists them)",
    )
    parser.add_argument("--out", metavar="RUN.csv", help="write the log as CSV")
    parser.add_argument(
        "--lambda-bound",
        type=float,
        metavar="B",
        help="bound every Lagrange multiplier: -B <= lam_i <= B (lp2, sec. 3.2)",
    )
    parser.add_argument("--steps", type=int, metavar="N", help="number of steps")
    parser.add_argument("--dt", type=float, metavar="DT", help="control period [s]")
    parser.add_argument("--plot", metavar="FIG.png", help="draw an overview figure of the run")
    parser.add_argument("--animate", metavar="RUN.gif", help="write an animated GIF of the run")
    parser.add_argument(
        "--frames", type=int, default=60, metavar="F", help="GIF frames (default 60)"
    )
    parser.add_argument(
        "--cold-start",
        action="store_true",
        help="solve every step's LP on its own instead of warm-starting HiGHS across steps",
    )
    parser.set_defaults(handler=run)


def _writable(option: str, path: str | None) -> Path | None:
    """``path`` as a Path when a file can be written there; ``ValueError`` naming ``option``."""
    if path is None:
        return None
    out = Path(path)
    parent = out.parent if str(out.parent) else Path(".")
    if out.is_dir():
        raise ValueError(f"{option}: {path!r} is a directory")
    if not parent.is_dir():
        raise ValueError(f"{option}: cannot write {path!r}: directory {str(parent)!r} not found")
    if not os.access(parent, os.W_OK) or (out.exists() and not os.access(out, os.W_OK)):
        raise ValueError(f"{option}: cannot write {path!r}: permission denied")
    return out


def _check_options(args: argparse.Namespace) -> None:
    """Validate numbers and names before the run starts (one line, exit 2 on failure)."""
    from lpik.methods.registry import METHODS, get_method

    spec = get_method(args.method, field="--method")
    if args.steps is not None and args.steps <= 0:
        raise ValueError(f"--steps: must be > 0, got {args.steps}")
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise ValueError(f"--dt: must be a finite number > 0 [s], got {args.dt}")
    if args.lambda_bound is not None:
        if not (math.isfinite(args.lambda_bound) and args.lambda_bound > 0):
            raise ValueError(
                f"--lambda-bound: must be a finite number > 0, got {args.lambda_bound}"
            )
        if not spec.bounds_multipliers:
            bounded = [name for name, s in METHODS.items() if s.bounds_multipliers]
            raise ValueError(
                f"--lambda-bound: method {args.method!r} does not bound its multipliers; "
                f"use {', '.join(bounded)}"
            )
    if args.frames < 2:
        raise ValueError(f"--frames: must be >= 2, got {args.frames}")


def run_options(args: argparse.Namespace) -> dict[str, object]:
    """The keyword arguments every scenario's ``run`` takes from the command line."""
    return {
        "lambda_bound": args.lambda_bound,
        "steps": args.steps,
        "dt": args.dt,
        "warm_start": not args.cold_start,
    }


def run(args: argparse.Namespace) -> int:
    """Run the scenario; write the CSV, figure and animation that were asked for."""
    from lpik.cli.progress import LazyProgress
    from lpik.paper.scenarios import PLANAR, get_scenario

    _check_options(args)
    out = _writable("--out", args.out)
    fig = _writable("--plot", args.plot)
    gif = _writable("--animate", args.animate)
    setup = get_scenario(args.scenario).setup(args.robot)
    if gif is not None and args.robot != PLANAR:
        raise ValueError("--animate: draws the planar arm only; use --plot for 3-D runs")
    if fig is not None or gif is not None:
        from lpik.paper.style import require_backend

        require_backend(animation=gif is not None)  # fail before the run, not after it
    with LazyProgress(f"{setup.name} {args.method}") as progress:
        log = setup.run(args.method, progress=progress, **run_options(args))
    written = [] if out is None else [log.to_csv(out)]
    written += _draw(args, setup, log, fig, gif)
    m = log.metrics()
    position = ", ".join(f"{v:.4f}" for v in m.final_position)
    print(
        f"{log.name}, {log.method}: {m.steps} steps, final p = {m.final_p:.4g} "
        f"(binding: {log.binding[-1] or 'none'}), end effector at ({position}) m, "
        f"jitter {m.jitter:.4g} rad/s, statuses "
        + ", ".join(f"{k} {v}" for k, v in m.statuses.items())
    )
    for path in written:
        print(f"wrote {path}")
    return 0


def _draw(
    args: argparse.Namespace, setup: Setup, log: SimulationLog, fig: Path | None, gif: Path | None
) -> list[Path]:
    """The figure and animation asked for: x-y overview (planar) or 3-D tool path."""
    from lpik.paper import run_figures

    written = []
    target = setup.target
    if fig is not None and setup.model.position_dims == 2:
        written.append(run_figures.run_overview(log, setup.model, fig, target=target))
    elif fig is not None:
        goal = target[:3, 3] if target.ndim == 2 else target
        title = f"{setup.name} ({args.method})"
        written.append(
            run_figures.tool_path_figure(log, fig, model=setup.model, target=goal, title=title)
        )
    if gif is not None:
        written.append(
            run_figures.animate(log, setup.model, gif, frames=args.frames, target=target)
        )
    return written
