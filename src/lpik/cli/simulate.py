"""``lpik simulate SCENARIO --method METHOD --out RUN.csv``: one closed-loop run (DESIGN.md)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

#: Methods whose multipliers ``--lambda-bound`` bounds (sec. 3.2).
BOUNDED_MULTIPLIER_METHODS = ("lp2",)


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik simulate`` (light: the methods are imported only when it runs)."""
    from lpik.scenarios import SCENARIOS

    parser = sub.add_parser(
        "simulate",
        help="run a scenario in closed loop and write the log as CSV",
        description="Run one of the paper's scenarios in closed loop. The CSV has one row per "
        "step: t, q1..qn [rad], x, y [m], p, lam1..lamm (the state before the step, the "
        "step's dexterity and multipliers), then status, binding, path, clamped, "
        "solve_time_us. Scenarios: "
        + "; ".join(f"{s.name}: {s.description}" for s in SCENARIOS.values())
        + ".",
    )
    parser.add_argument("scenario", metavar="SCENARIO", help=f"one of {', '.join(SCENARIOS)}")
    parser.add_argument(  # 3-D scenarios: lpik.scenarios3d, lpik.cli.simulate3d
        "--robot",
        metavar="NAME",
        help="run the scenario on a bundled 3-D arm (see lpik robots) instead of the planar arm",
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
    from lpik.methods import ALL_METHODS

    if args.method not in ALL_METHODS:
        raise ValueError(
            f"--method: unknown method {args.method!r}; available: {', '.join(ALL_METHODS)}"
        )
    if args.steps is not None and args.steps <= 0:
        raise ValueError(f"--steps: must be > 0, got {args.steps}")
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise ValueError(f"--dt: must be a finite number > 0 [s], got {args.dt}")
    if args.lambda_bound is not None:
        if not (math.isfinite(args.lambda_bound) and args.lambda_bound > 0):
            raise ValueError(
                f"--lambda-bound: must be a finite number > 0, got {args.lambda_bound}"
            )
        if args.method not in BOUNDED_MULTIPLIER_METHODS:
            raise ValueError(
                f"--lambda-bound: method {args.method!r} does not bound its multipliers; "
                f"use {', '.join(BOUNDED_MULTIPLIER_METHODS)}"
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

    _check_options(args)
    out = _writable("--out", args.out)
    fig = _writable("--plot", args.plot)
    gif = _writable("--animate", args.animate)
    if args.robot is not None:  # 3-D scenarios: lpik.scenarios3d, lpik.cli.simulate3d
        from lpik.cli.simulate3d import prepare_3d

        label, simulate, draw = prepare_3d(args, fig, gif)
    else:
        label, simulate, draw = _prepare_planar(args, fig, gif)
    if fig is not None or gif is not None:
        from lpik.plots import require_backend

        require_backend(animation=gif is not None)  # fail before the run, not after it
    with LazyProgress(label) as progress:
        log = simulate(progress)
    written = [] if out is None else [log.to_csv(out)]
    written += draw(log)
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


def _prepare_planar(args: argparse.Namespace, fig: Path | None, gif: Path | None):  # noqa: ANN202
    """Label, run and drawing of a planar scenario (see :func:`run`)."""
    from lpik.scenarios import get_scenario

    scenario = get_scenario(args.scenario)

    def simulate(progress):  # noqa: ANN001, ANN202
        return scenario.run(args.method, progress=progress, **run_options(args))

    def draw(log) -> list[Path]:  # noqa: ANN001
        from lpik import plots

        model, target = scenario.model(), scenario.target
        written = []
        if fig is not None:
            written.append(plots.run_overview(log, model, fig, target=target))
        if gif is not None:
            written.append(plots.animate(log, model, gif, frames=args.frames, target=target))
        return written

    return f"{scenario.name} {args.method}", simulate, draw
