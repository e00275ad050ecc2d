"""Reproduce the paper's section 4: the runs, figures 3-10, their CSV logs and a summary.

``lpik reproduce`` writes, into one output directory, the runs of
:mod:`lpik.paper.runs` as CSV logs and the figures drawn from them
(:data:`~lpik.paper.runs.FIGURES`), the summary of :mod:`lpik.paper.report`,
and, beyond the paper, the 3-D runs of :func:`reproduce_3d` and the
collision-avoidance runs and Figs. 11-12 of :mod:`lpik.paper.collision_runs`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lpik.control.log import RunMetrics, SimulationLog
from lpik.paper.collision_runs import reproduce_collision
from lpik.paper.report import summary_markdown
from lpik.paper.runs import FIGURES, BoundChoice, Progress, run_all
from lpik.paper.scenarios import SCENARIOS, get_scenario
from lpik.paper.setup import PAPER_COMMAND
from lpik.version import __version__


@dataclass(frozen=True, eq=False)
class Reproduction:
    """What :func:`reproduce` computed and wrote.

    Attributes:
        out_dir: The output directory.
        logs: The runs of :func:`~lpik.paper.runs.run_all` by name.
        choice: The multiplier bound and its derivation.
        sweep: Metrics of the edge-singularity run for each swept bound.
        files: Every file written.
    """

    out_dir: Path
    logs: dict[str, SimulationLog]
    choice: BoundChoice
    sweep: dict[float, RunMetrics]
    files: list[Path] = field(default_factory=list)


def write_figures(out_dir: Path, logs: dict[str, SimulationLog], choice: BoundChoice) -> list[Path]:
    """Draw Figs. 3-10 from the runs into ``out_dir``."""
    files = {name: out_dir / name for name in FIGURES}
    return [
        *_pull_in_figures(files, logs),
        *_edge_singularity_figures(files, logs, choice),
        _saturation_figure(files, logs),
    ]


def _joint1_range() -> tuple[float, float]:
    """The range the figures mark for joint 1: 0 to its upper end-stop in the pull-in run."""
    return (0, get_scenario("pull-in").paper.q_max[0])


def _pull_in_figures(files: dict[str, Path], logs: dict[str, SimulationLog]) -> list[Path]:
    """Figs. 3-6: the pull-in under LP1 (solved on its own and warm-started) and LP2."""
    from lpik.paper import figures as plots

    pull = get_scenario("pull-in")
    arm = pull.setup().model
    lp1, lp2, warm = logs["pull-in-lp1"], logs["pull-in-lp2"], logs["pull-in-lp1-warm-start"]
    return [
        plots.xy_figure(
            lp1,
            arm,
            files["fig3-lp1-xy.png"],
            title="Fig. 3 - pull-in under LP1",
            target=pull.paper.target,
        ),  # fmt: skip
        plots.joint_motion_figure(
            [("a) LP1", lp1), ("a') LP1, warm-started", warm), ("b) LP2", lp2)],
            files["fig4-joint-motion.png"],
            title="Fig. 4 - joint motion while pulling in (joint 1 limited to 95 deg)",
            q_limit=_joint1_range(),
        ),
        plots.xy_figure(
            lp2,
            arm,
            files["fig5-lp2-xy.png"],
            title="Fig. 5 - pull-in under LP2",
            target=pull.paper.target,
        ),  # fmt: skip
        plots.dexterity_figure(
            lp2,
            files["fig6-dexterity.png"],
            q_limit=_joint1_range(),
            title="Fig. 6 - affine dexterity under LP2 (pull-in)",
        ),  # fmt: skip
    ]


def _edge_singularity_figures(
    files: dict[str, Path], logs: dict[str, SimulationLog], choice: BoundChoice
) -> list[Path]:
    """Figs. 7-9: the edge singularity under LP2 with unbounded and with bounded multipliers."""
    from lpik.paper import figures as plots

    edge = get_scenario("edge-singularity")
    free, bounded = logs["edge-singularity-lp2-unbounded"], logs["edge-singularity-lp2-bounded"]
    lam = np.nanmax(np.abs(np.concatenate([free.lam, bounded.lam])), axis=1)
    lam_ylim = (float(np.nanmin(lam[lam > 0])) / 2, float(np.nanmax(lam)) * 2)
    return [
        plots.xy_figure(
            free,
            edge.setup().model,
            files["fig7-edge-singularity-xy.png"],
            target=edge.paper.target,
            reach=edge.paper.reach,
            title="Fig. 7 - displacement to the edge singularity (LP2, unbounded multipliers)",
        ),  # fmt: skip
        plots.singularity_figure(
            free,
            files["fig8-unbounded-multipliers.png"],
            title="Fig. 8 - LP2 near the edge singularity, unbounded multipliers",
            lambda_ylim=lam_ylim,
        ),
        plots.singularity_figure(
            bounded,
            files["fig9-bounded-multipliers.png"],
            title=rf"Fig. 9 - LP2 near the edge singularity, $|\lambda_i| \leq {choice.bound:g}$",
            lambda_bound=choice.bound,
            lambda_ylim=lam_ylim,
        ),
    ]


def _saturation_figure(files: dict[str, Path], logs: dict[str, SimulationLog]) -> Path:
    """Fig. 10 (beyond the paper): pulling in under LP2 and LP2 with saturation."""
    from lpik.paper import figures as plots

    lp2, lp2s = logs["pull-in-lp2"], logs["pull-in-lp2s"]
    return plots.joint_motion_figure(
        [("a) LP2", lp2), ("b) LP2 with saturation in the null space", lp2s)],
        files["fig10-saturation.png"],
        title="Fig. 10 - pulling in: joint 1 held at 95 deg, the other joints carry on",
        q_limit=_joint1_range(),
    )


def reproduce(out_dir: str | Path, progress: Progress | None = None) -> Reproduction:
    """Run everything and write the figures, the CSV logs and ``summary.md`` to ``out_dir``.

    Raises:
        ValueError: When ``out_dir`` cannot be created or written.
        MissingBackendError: When matplotlib is not installed.
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out: cannot create {str(out)!r}: {exc.strerror or exc}") from None
    logs, choice, sweep = run_all(progress)
    say = progress or (lambda _: None)
    files = [log.to_csv(out / f"{name}.csv") for name, log in logs.items()]
    say("figures")
    files += write_figures(out, logs, choice)
    files += reproduce_3d(out, "panda", progress=say)
    files += reproduce_collision(out, progress=say)
    summary = out / "summary.md"
    summary.write_text(summary_markdown(logs, choice, sweep, version=__version__), "utf-8")
    files.append(summary)
    return Reproduction(out_dir=out, logs=logs, choice=choice, sweep=sweep, files=files)


def reproduce_3d(
    out_dir: str | Path,
    robot: str = "panda",
    method: str = "lp2",
    progress: Progress | None = None,
) -> list[Path]:
    """Run both 3-D scenarios on one arm; write their CSV logs and one figure each.

    Part of ``lpik reproduce``: files ``<scenario>-3d-<robot>-<method>.csv`` and
    ``fig3d-<scenario>-<robot>.png`` in ``out_dir``.

    Args:
        out_dir: Existing output directory.
        robot: Bundled robot name.
        method: Method of both runs.
        progress: Called with a short stage description before each run.

    Returns:
        The files written.
    """
    from lpik.paper.run_figures import tool_path_figure

    out = Path(out_dir)
    files: list[Path] = []
    for name, scenario in SCENARIOS.items():
        if scenario.arm is None:
            continue
        if progress is not None:
            progress(f"{name}, {robot} (3-D), {method}")
        setup = scenario.setup(robot)
        log = setup.run(method, **PAPER_COMMAND)
        files.append(log.to_csv(out / f"{name}-3d-{robot}-{method}.csv"))
        target = setup.target
        files.append(
            tool_path_figure(
                log,
                out / f"fig3d-{name}-{robot}.png",
                model=setup.model,
                target=target[:3, 3] if target.ndim == 2 else target,
                title=f"3-D {name} on the {robot} ({method})",
            )
        )
    return files
