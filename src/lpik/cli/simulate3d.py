"""``lpik simulate SCENARIO --robot NAME``: the 3-D scenarios on a bundled arm.

Used by :mod:`lpik.cli.simulate` when ``--robot`` is given; it shares that
command's options, run and report, and supplies only the scenario and the
figure. The CSV has the columns ``t, q1..qn, x, y, z, p, lam1..lamm`` and then
the same extra columns as the planar runs; ``--plot`` draws the tool's path in
3-D with the arm (:func:`lpik.plots3d.tool_path_figure`).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def prepare_3d(args: argparse.Namespace, fig: Path | None, gif: Path | None):  # noqa: ANN201
    """Label, run and drawing of ``args.scenario`` on ``args.robot``.

    Raises:
        ValueError: Unknown robot or scenario, or ``--animate`` (not drawn in 3-D).
    """
    from lpik.cli.simulate import run_options
    from lpik.robots.registry import get_spec
    from lpik.scenarios3d import get_scenario_3d

    scenario = get_scenario_3d(args.scenario)
    get_spec(args.robot)
    if gif is not None:
        raise ValueError("--animate: not available for 3-D runs (--robot); use --plot")

    def simulate(progress):  # noqa: ANN001, ANN202
        return scenario.run(args.robot, args.method, progress=progress, **run_options(args))

    def draw(log) -> list[Path]:  # noqa: ANN001
        if fig is None:
            return []
        from lpik.plots3d import tool_path_figure
        from lpik.robots.registry import load_chain

        target = scenario.target(args.robot)
        return [
            tool_path_figure(
                log,
                fig,
                chain=load_chain(args.robot),
                target=target[:3, 3] if target.ndim == 2 else target,
                title=f"{scenario.name} on {args.robot} ({args.method})",
            )
        ]

    return f"{scenario.name} {args.robot} {args.method}", simulate, draw
