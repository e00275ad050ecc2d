"""``lpik simulate SCENARIO --robot NAME``: the 3-D scenarios on a bundled arm.

Called by :mod:`lpik.cli.simulate` when ``--robot`` is given; shares its
options. The CSV has the columns ``t, q1..qn, x, y, z, p, lam1..lamm`` and
then the same extra columns as the planar runs; ``--plot`` draws the tool's
path in 3-D with the arm (:func:`lpik.plots3d.tool_path_figure`).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def run_3d(args: argparse.Namespace, out: Path | None, fig: Path | None) -> int:
    """Run ``args.scenario`` on ``args.robot``; write the CSV and figure asked for.

    Args:
        args: The parsed ``lpik simulate`` options (already checked).
        out: CSV path, or None.
        fig: Figure path, or None.

    Raises:
        ValueError: Unknown robot or scenario, or ``--animate`` (not drawn in 3-D).
    """
    from lpik.cli.progress import LazyProgress
    from lpik.robots.registry import get_spec
    from lpik.scenarios3d import get_scenario_3d

    scenario = get_scenario_3d(args.scenario)
    get_spec(args.robot)
    if getattr(args, "animate", None):
        raise ValueError("--animate: not available for 3-D runs (--robot); use --plot")
    if fig is not None:
        from lpik.plots import require_backend

        require_backend()
    with LazyProgress(f"{scenario.name} {args.robot} {args.method}") as progress:
        log = scenario.run(
            args.robot,
            args.method,
            lambda_bound=args.lambda_bound,
            steps=args.steps,
            dt=args.dt,
            warm_start=not args.cold_start,
            progress=progress,
        )
    written = []
    if out is not None:
        written.append(log.to_csv(out))
    if fig is not None:
        from lpik.plots3d import tool_path_figure
        from lpik.robots.registry import load_chain

        target = scenario.target(args.robot)
        written.append(
            tool_path_figure(
                log,
                fig,
                chain=load_chain(args.robot),
                target=target[:3, 3] if target.ndim == 2 else target,
                title=f"{scenario.name} on {args.robot} ({args.method})",
            )
        )
    m = log.metrics()
    position = ", ".join(f"{v:.4f}" for v in m.final_position)
    binding = log.binding[-1] or "none"
    print(
        f"{log.name}, {log.method}: {m.steps} steps, final p = {m.final_p:.4g} "
        f"(binding: {binding}), tool at ({position}) m, jitter {m.jitter:.4g} rad/s, "
        "statuses " + ", ".join(f"{k} {v}" for k, v in m.statuses.items())
    )
    for path in written:
        print(f"wrote {path}")
    return 0
