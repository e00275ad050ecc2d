"""``lpik simulate SCENARIO [--robot NAME] --method METHOD --out RUN.csv``: one closed-loop run.

``lpik simulate reach --robot NAME --target X,Y,Z`` moves the tool point from the
home configuration straight to a point, its orientation held (:mod:`lpik.paper.reach`).

One path for every robot: :meth:`lpik.paper.scenarios.Scenario.setup` gives the
run, :mod:`lpik.paper.run_figures` draws it.

Every output (``--out``, ``--plot``, ``--animate``) is checked before the run:
its format, that it can be written (an empty write, which ``/dev/full``
refuses), that no two options name the same file; an error names the option.
``--out -`` writes the CSV, and nothing else, on stdout: the summary goes to
stderr. A figure or animation named without an extension is written, as PNG or
GIF, under exactly that name. Names from a scene (obstacles) are printed with
control characters escaped.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from lpik.defaults import DEFAULT_METHOD, DEFAULT_MODE, DEFAULT_ON_STALL, MODES
from lpik.tolerances import MAX_DT, MAX_MAGNITUDE

if TYPE_CHECKING:
    from lpik.control.log import SimulationLog
    from lpik.paper.scenarios import Setup

#: Most steps of one run: 10,000 s of robot time at the scenarios' dt = 0.01 s
#: (1,000 s at 1 kHz). The log keeps every step in memory (about a kilobyte a
#: step on the planar arm, hence about 1 GB here) and the CSV takes about 150
#: bytes a step, so a run this long still fits a laptop.
MAX_STEPS = 1_000_000
#: Most frames of an animated GIF.
MAX_FRAMES = 1000
#: ``--out``'s name for standard output.
STDOUT = "-"
#: Figure formats that need nothing but matplotlib (pgf needs LaTeX).
NOT_PLOT_FORMATS = ("pgf",)


def _bound_value(text: str) -> float | str:
    """``--lambda-bound``'s value: a number, ``auto`` or ``none``."""
    if text in ("auto", "none"):
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number, 'auto' or 'none', got {text!r}"
        ) from None


def _stall_value(text: str) -> int | str:
    """``--on-stall``'s value: a whole number of steps or ``none``."""
    if text == "none":
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number or 'none', got {text!r}"
        ) from None


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik simulate`` (light: the methods are imported only when it runs)."""
    parser = sub.add_parser(
        "simulate",
        help="run a scenario in closed loop and write the log as CSV",
        description=_paragraph(
            "Run one of the paper's scenarios in closed loop, on the paper's planar arm or a "
            "bundled 3-D arm, and report p and the binding limit of every step."
        ),
        epilog=_epilog(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_run_arguments(parser)
    _add_output_arguments(parser)
    _add_loop_arguments(parser)
    parser.set_defaults(handler=run)


def _paragraph(text: str) -> str:
    """``text`` wrapped for the help, a ``name: ...`` paragraph with a hanging indent."""
    import textwrap

    return textwrap.fill(text, 78, subsequent_indent="  " if ": " in text[:20] else "")


def _epilog() -> str:
    """The help's closing paragraphs: scenarios, robots, CSV columns, refused combinations."""
    from lpik.methods.registry import methods_with
    from lpik.paper.scenarios import PLANAR, SCENARIOS
    from lpik.robots.registry import robot_names

    bounded, takers = methods_with("bounds_multipliers"), methods_with("takes_criterion")
    return "\n\n".join(
        [
            "scenarios:",
            *(_paragraph(s.describe()) for s in SCENARIOS.values()),
            _paragraph(
                "reach: from a bundled 3-D arm's home configuration (--robot NAME), the tool "
                "point moves straight to --target X,Y,Z [m] at v_max, its orientation held "
                "(pose task); the URDF's end-stops and velocity limits."
            ),
            _paragraph(
                "obstacles: --scene SCENE.json (a 2-D scene for the planar arm) avoids them "
                "by distance rows (--avoid rows), the paper's potential field (--avoid field) "
                "or both."
            ),
            _paragraph(
                f"robots: {PLANAR} (default), {', '.join(robot_names())}; or any arm of a URDF "
                "file: --urdf FILE --tip LINK [--base LINK], started in the middle of its "
                "end-stops."
            ),
            _paragraph(
                "CSV columns, one row per step: t, q1..qn [rad], x, y (planar) or x, y, z [m], "
                "p, lam1..lamm (the state before the step, the step's dexterity and "
                "multipliers; nan for methods without them), then status, binding (the limit "
                "that keeps p below 1, empty when none), path, clamped, solve_time_us; with "
                "--scene also min_distance [m] (the smallest signed distance before the step, "
                "self-collision included) and closest (its pair); last, pull_scale (the share "
                "of sec. 3.1's pull the step took, 1: whole or no pull)."
            ),
            _paragraph(
                f"refused combinations (exit 2, one line): --lambda-bound with a method that "
                f"does not bound its multipliers (only {bounded} do); --avoid field or both "
                f"with a method that does not take the field's force (only "
                f"{takers} do); --animate with a 3-D --robot (use --plot); "
                f"--plot or --animate without matplotlib."
            ),
        ]
    )


def _add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """The run: scenario or target, robot, method, limits, steps and period."""
    from lpik.cli.robots import add_robot_arguments
    from lpik.paper.scenarios import PLANAR, SCENARIOS

    parser.add_argument(
        "scenario",
        metavar="SCENARIO",
        help=f"one of {', '.join(SCENARIOS)}, or reach (with --target)",
    )
    parser.add_argument(
        "--target",
        metavar="X,Y,Z",
        help="reach: the point [m] the tool point moves to from the home configuration at "
        "v_max, its orientation held",
    )
    add_robot_arguments(
        parser,
        default=PLANAR,
        robot_help=f"'{PLANAR}' (the paper's 4-link arm, default) or a bundled 3-D arm "
        "(lpik robots)",
    )
    parser.add_argument(
        "--method",
        default=DEFAULT_METHOD,
        help=f"pinv, weighted, robust, lp1, l1, lp2, lp2s or nlp (default {DEFAULT_METHOD}; "
        "lpik.methods lists them)",
    )
    parser.add_argument(
        "--no-second-order",
        action="store_true",
        help="command the law alone, as the paper's runs do (default: take off each command "
        "the last step's second-order term, as every lpik controller does)",
    )
    parser.add_argument(
        "--lambda-bound",
        type=_bound_value,
        metavar="B",
        help="bound every Lagrange multiplier: -B <= lam_i <= B (lp2, lp2s; sec. 3.2); "
        "'auto' (the default): bounds chosen per step where the arm would race towards a "
        "singularity; 'none': unbounded (the paper's LP2 as stated)",
    )
    parser.add_argument(
        "--qdd-max",
        type=float,
        metavar="A",
        help="acceleration limit of every joint [rad/s^2] (default: none; the velocity limits "
        "and end-stops always hold)",
    )
    defaults = ", ".join(f"{s.name} {s.steps} steps at {s.dt:g} s" for s in SCENARIOS.values())
    parser.add_argument(
        "--steps",
        type=int,
        metavar="N",
        help=f"number of steps (at most {MAX_STEPS:,}; default the scenario's: {defaults})",
    )
    parser.add_argument(
        "--dt",
        type=float,
        metavar="DT",
        help=f"control period [s] (at most {MAX_DT:g}; default the scenario's)",
    )


def _add_output_arguments(parser: argparse.ArgumentParser) -> None:
    """The outputs of the run: the CSV, an overview plot, an animated GIF and its frames."""
    from lpik.paper.scenarios import PLANAR

    parser.add_argument(
        "--out",
        metavar="RUN.csv",
        help="write the log as CSV ('-': on stdout, the summary on stderr)",
    )
    parser.add_argument("--plot", metavar="FIG.png", help="draw an overview figure of the run")
    parser.add_argument(
        "--animate",
        metavar="RUN.gif",
        help=f"write an animated GIF of the run (the '{PLANAR}' arm only)",
    )
    parser.add_argument(
        "--frames",
        type=int,
        default=60,
        metavar="F",
        help=f"GIF frames (default 60, at most {MAX_FRAMES})",
    )


def _add_loop_arguments(parser: argparse.ArgumentParser) -> None:
    """How the loop steps: stall handling, obstacles and how to avoid them, HiGHS's start."""
    from lpik.methods.registry import methods_with

    parser.add_argument(
        "--on-stall",
        type=_stall_value,
        metavar="N",
        help="after N stalled steps in a row (no step along the command, or p near 0 and far "
        "less progress than leaving the direction), take the step of least task error within "
        "every limit (status off_direction, p = 0) while the arm stays stalled; none: never, "
        "the paper's strict steps (default "
        f"{'none' if DEFAULT_ON_STALL is None else DEFAULT_ON_STALL})",
    )
    parser.add_argument(
        "--mode",
        choices=MODES,
        default=DEFAULT_MODE,
        help=f"exact: every step keeps the commanded direction (default {DEFAULT_MODE}); "
        "progress: after each exact step with p < 1, also spend what the limits leave on the "
        "task error that remains (status off_direction)",
    )
    parser.add_argument(
        "--scene",
        metavar="SCENE.json",
        help="obstacles to avoid (JSON: obstacles, safety_distance, influence_distance; 2-D "
        "points for the planar arm), or a bundled scene by name (panda-shelf); the CSV gains "
        "min_distance and closest",
    )
    parser.add_argument(
        "--avoid",
        choices=("rows", "field", "both"),
        default="rows",
        help=f"with --scene: hard distance rows (velocity damper; {methods_with('limit_aware')}), "
        f"the paper's potential field ({methods_with('takes_criterion')}) or both (default rows)",
    )
    parser.add_argument(
        "--cold-start",
        action="store_true",
        help="solve every step's LP on its own instead of warm-starting HiGHS across steps",
    )


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
    # Open it (without truncating) before the run: the only sure test, e.g. under /proc;
    # an empty write, which changes nothing, is refused by a full device (/dev/full).
    existed = out.exists()
    try:
        with open(out, "ab") as handle:
            os.write(handle.fileno(), b"")
    except OSError as exc:
        raise ValueError(f"{option}: cannot write {path!r}: {exc.strerror or exc}") from None
    finally:
        if not existed:
            out.unlink(missing_ok=True)
    return out


def _plot_formats() -> tuple[str, ...]:
    """The extensions ``--plot`` can write (matplotlib's, those that need no other tool)."""
    from matplotlib.backend_bases import FigureCanvasBase

    known = FigureCanvasBase.get_supported_filetypes()
    return tuple(sorted(f".{k}" for k in known if k not in NOT_PLOT_FORMATS))


def _format(option: str, path: str, formats: tuple[str, ...]) -> None:
    """Refuse an extension the output cannot be written in (none is fine: PNG or GIF)."""
    suffix = Path(path).suffix.lower()
    if suffix and suffix not in formats:
        raise ValueError(
            f"{option}: cannot write {path!r} as {suffix}; use one of {', '.join(formats)} "
            "(or no extension)"
        )


def _outputs(args: argparse.Namespace) -> tuple[Path | str | None, Path | None, Path | None]:
    """``--out``, ``--plot`` and ``--animate`` checked before the run (``ValueError`` naming one).

    Returns ``--out`` (:data:`STDOUT` for ``-``), ``--plot`` and ``--animate``, or None each.
    """
    for option, value in (("--plot", args.plot), ("--animate", args.animate)):
        if value == STDOUT:
            raise ValueError(f"{option}: '-' (stdout) is for --out only; name a file")
    if args.plot is not None or args.animate is not None:
        from lpik.paper.style import require_backend

        require_backend(animation=args.animate is not None)  # fail before the run, not after it
    if args.plot is not None:
        _format("--plot", args.plot, _plot_formats())
    if args.animate is not None:
        _format("--animate", args.animate, (".gif",))
    if args.out == STDOUT:
        _check_stdout()
    out = STDOUT if args.out == STDOUT else _writable("--out", args.out)
    fig, gif = _writable("--plot", args.plot), _writable("--animate", args.animate)
    named: dict[str, str] = {}
    for option, path in (("--out", out), ("--plot", fig), ("--animate", gif)):
        if isinstance(path, Path) and _is_regular(path):
            key = os.path.realpath(path)
            if key in named:
                raise ValueError(f"{option}: {str(path)!r} is also {named[key]}'s file")
            named[key] = option
    return out, fig, gif


def _check_stdout() -> None:
    """``--out -``: refuse a closed or full stdout before the run (an empty write)."""
    if sys.stdout is None:  # the process was started with stdout closed
        raise ValueError("--out: cannot write on stdout: it is closed")
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # no descriptor (a test's capture): fine
        return
    try:
        os.write(fd, b"")
    except OSError as exc:
        raise ValueError(f"--out: cannot write on stdout: {exc.strerror or exc}") from None


def _is_regular(path: Path) -> bool:
    """Whether ``path`` is (or, missing, will be) a regular file: not a device or a pipe."""
    try:
        return stat.S_ISREG(path.stat().st_mode)
    except OSError:
        return True


def _written(option: str, path: Path, exc: Exception) -> ValueError:
    """A failed write as one line naming the option."""
    if isinstance(exc, OSError):
        reason = exc.strerror or str(exc)
    else:
        text = str(exc)
        reason = text.rsplit(": ", 1)[-1] if "cannot write" in text else text
    return ValueError(f"{option}: cannot write {str(path)!r}: {reason}")


def _deliver(option: str, path: Path, suffix: str, draw: Callable[[Path], Path]) -> Path:
    """Have ``draw`` write ``path``; exactly ``path``, also without an extension or on a device.

    Without an extension (or onto a device), ``draw`` writes a ``suffix`` file in a
    temporary folder that is then copied to ``path``.
    """
    try:
        if path.suffix and _is_regular(path):
            draw(path)
            return path
        with tempfile.TemporaryDirectory() as folder:
            made = draw(Path(folder) / f"output{suffix}")
            with open(made, "rb") as source, open(path, "wb") as target:
                shutil.copyfileobj(source, target)
    except (OSError, ValueError) as exc:
        raise _written(option, path, exc) from None
    return path


def _write_csv(log: SimulationLog, out: Path | str) -> Path | None:
    """The CSV to ``out``, or on stdout for :data:`STDOUT` (then None)."""
    if out != STDOUT:
        path = Path(out)
        try:
            return log.to_csv(path)
        except (OSError, ValueError) as exc:
            raise _written("--out", path, exc) from None
    with tempfile.TemporaryDirectory() as folder:  # one writer of the CSV: SimulationLog's
        made = log.to_csv(Path(folder) / "run.csv")
        with open(made, encoding="utf-8", newline="") as source:
            shutil.copyfileobj(source, sys.stdout)
    sys.stdout.flush()
    return None


def _safe(text: object) -> str:
    r"""``text`` for a terminal, what is not printable escaped (``\n``, ``\x1b``).

    A name from a scene file then cannot break a line or drive the terminal.
    """
    return "".join(
        c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in str(text)
    )


def _check_options(args: argparse.Namespace) -> None:
    """Validate numbers and names before the run starts (one line, exit 2 on failure)."""
    from lpik.limits import multiplier_limit
    from lpik.methods.registry import METHODS, get_method

    spec = get_method(args.method, field="--method")
    if args.steps is not None and not 0 < args.steps <= MAX_STEPS:
        raise ValueError(f"--steps: must be in 1..{MAX_STEPS:,} (MAX_STEPS), got {args.steps:,}")
    if args.dt is not None and not (math.isfinite(args.dt) and 0 < args.dt <= MAX_DT):
        raise ValueError(f"--dt: must be a number in (0, {MAX_DT:g}] [s], got {args.dt}")
    if args.lambda_bound is not None:
        value = None if args.lambda_bound == "none" else args.lambda_bound
        multiplier_limit(value, field="--lambda-bound")  # raises, naming the option
        if not spec.bounds_multipliers:
            bounded = [name for name, s in METHODS.items() if s.bounds_multipliers]
            raise ValueError(
                f"--lambda-bound: method {args.method!r} does not bound its multipliers; "
                f"use {', '.join(bounded)}"
            )
    if args.qdd_max is not None and not (
        math.isfinite(args.qdd_max) and 0 < args.qdd_max <= MAX_MAGNITUDE
    ):
        raise ValueError(
            f"--qdd-max: must be a number in (0, {MAX_MAGNITUDE:g}] [rad/s^2], got {args.qdd_max}"
        )
    if args.on_stall not in (None, "none") and not 0 < args.on_stall <= MAX_STEPS:
        raise ValueError(f"--on-stall: must be in 1..{MAX_STEPS:,} steps, got {args.on_stall:,}")
    if not 2 <= args.frames <= MAX_FRAMES:
        raise ValueError(f"--frames: must be in 2..{MAX_FRAMES}, got {args.frames}")


def run_options(args: argparse.Namespace) -> dict[str, object]:
    """The keyword arguments every scenario's ``run`` takes from the command line."""
    return {
        "lambda_bound": {None: "auto", "none": None}.get(args.lambda_bound, args.lambda_bound),
        "steps": args.steps,
        "dt": args.dt,
        "warm_start": not args.cold_start,
        "on_stall": {None: DEFAULT_ON_STALL, "none": None}.get(args.on_stall, args.on_stall),
        "mode": args.mode,
        "qdd_max": args.qdd_max,
        "second_order": not args.no_second_order,
    }


def _setup(args: argparse.Namespace) -> Setup:
    """The run: a scenario on ``--robot`` (or ``--urdf``), or ``reach`` to ``--target``."""
    from lpik.cli.robots import check_scene_fits, robot_from_arguments
    from lpik.paper.scenarios import get_scenario

    robot = robot_from_arguments(args)
    check_scene_fits(robot, args.scene)
    if args.scenario != "reach":
        if args.target is not None:
            raise ValueError("--target: only for the scenario 'reach'")
        return get_scenario(args.scenario).setup(robot)
    from lpik.paper.reach import reach_setup

    if args.target is None:
        raise ValueError("--target: reach needs the point X,Y,Z [m]")
    try:
        point = [float(v) for v in args.target.split(",")]
    except ValueError:
        raise ValueError(f"--target: must be numbers X,Y,Z [m], got {args.target!r}") from None
    return reach_setup(robot, point)


def _avoidance(args: argparse.Namespace, setup: Setup) -> object:
    """The run's collision avoidance from ``--scene`` (default the scenario's) and ``--avoid``."""
    from lpik.collision import collision_avoidance, load_scene

    scene = setup.scene if args.scene is None else load_scene(args.scene)
    if scene is None:
        return None
    return collision_avoidance(setup.model, scene, setup.q0, mechanism=args.avoid)


def run(args: argparse.Namespace) -> int:
    """Run the scenario; write the CSV, figure and animation that were asked for."""
    from lpik.cli.progress import LazyProgress

    _check_options(args)
    out, fig, gif = _outputs(args)
    setup = _setup(args)
    if gif is not None and setup.model.position_dims != 2:
        raise ValueError("--animate: draws the planar arm only; use --plot for 3-D runs")
    avoid = _avoidance(args, setup)
    on_stdout = out == STDOUT
    report: TextIO = sys.stderr if on_stdout else sys.stdout
    quiet = contextlib.redirect_stdout(sys.stderr) if on_stdout else contextlib.nullcontext()
    with LazyProgress(f"{setup.name} {args.method}") as progress, quiet:
        log = setup.run(args.method, progress=progress, scene=avoid, **run_options(args))
    written = [] if out is None else [_write_csv(log, out)]
    if fig is not None:
        draw = _figure_drawer(args, setup, log, avoid)
        written.append(_deliver("--plot", fig, ".png", draw))
    if gif is not None:
        from lpik.paper import run_figures

        def animation(path: Path) -> Path:
            return run_figures.animate(log, setup.model, path, frames=args.frames,
                                       target=setup.target)  # fmt: skip

        written.append(_deliver("--animate", gif, ".gif", animation))
    print(_summary(log), file=report)
    for path in written:
        print("wrote the CSV on stdout" if path is None else f"wrote {_safe(path)}", file=report)
    return 0


def _summary(log: SimulationLog) -> str:
    """The run in one line: steps, final p and binding, end point, jitter, statuses."""
    m = log.metrics()
    position = ", ".join(f"{v:.4f}" for v in m.final_position)
    return _safe(
        f"{log.name}, {log.method}: {m.steps} steps, final p = {m.final_p:.4g} "
        f"(binding: {log.binding[-1] or 'none'}), end effector at ({position}) m, "
        f"jitter {m.jitter:.4g} rad/s, statuses "
        + ", ".join(f"{k} {v}" for k, v in m.statuses.items())
        + _distance_summary(log)
    )


def _distance_summary(log: SimulationLog) -> str:
    """``", smallest distance ... m (pair)"`` for a run with a scene, else ``""``."""
    if log.min_distance is None or log.closest is None or not log.steps:
        return ""
    k = int(log.min_distance.argmin())
    return f", smallest distance {log.min_distance[k]:.4g} m ({log.closest[k]})"


def _figure_drawer(
    args: argparse.Namespace, setup: Setup, log: SimulationLog, avoid: Any = None
) -> Callable[[Path], Path]:
    """What draws ``--plot``'s figure into a path: x-y overview (planar) or 3-D tool path.

    With a scene, the figure is :func:`lpik.paper.collision_figures.avoidance_figure`
    (the obstacles, the smallest distance and ``p`` with the binding limit).
    """
    from lpik.paper import run_figures

    target = setup.target
    goal = target[:3, 3] if target.ndim == 2 else target
    if avoid is not None:
        from lpik.paper.collision_figures import avoidance_figure

        caption = f"{args.method}, {avoid.mechanism}"
        return lambda path: avoidance_figure(
            [(caption, log)], setup.model, avoid.scene, path, title=setup.name, target=goal
        )
    if setup.model.position_dims == 2:
        return lambda path: run_figures.run_overview(log, setup.model, path, target=target)
    title = f"{setup.name} ({args.method})"
    return lambda path: run_figures.tool_path_figure(
        log, path, model=setup.model, target=goal, title=title
    )
