"""Figure of a 3-D run: the tool's path with the arm drawn at intervals, and p over time.

matplotlib is optional (``pip install "lpik[plot]"``) and imported inside the
function; the figure is drawn on an Agg canvas with the style of
:mod:`lpik.plots`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from lpik.exceptions import MissingBackendError
from lpik.plots import DPI, STYLE
from lpik.simulate import SimulationLog

#: Arm outlines drawn on the 3-D path.
ARM_POSES = 6


def arm_points(chain: Any, q: np.ndarray) -> np.ndarray:
    """Base origin, every joint origin and the task point of a chain, shape (n + 2, 3) [m]."""
    frames = chain.joint_frames(q)
    return np.vstack([np.zeros(3), frames[:, :3, 3], chain.fk(q)[:3, 3]])


def _cube_limits(ax: Any, points: np.ndarray) -> None:
    """Equal scales on x, y, z: a cube around ``points``."""
    center = 0.5 * (points.min(axis=0) + points.max(axis=0))
    half = 0.5 * float(np.max(points.max(axis=0) - points.min(axis=0))) + 0.05
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.set_zlim(center[2] - half, center[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))


def tool_path_figure(
    log: SimulationLog,
    path: str | Path,
    *,
    chain: Any | None = None,
    target: np.ndarray | None = None,
    title: str = "",
    poses: int = ARM_POSES,
) -> Path:
    """Tool path in 3-D with arm outlines, and the affine dexterity over time.

    Args:
        log: A run whose positions are (x, y, z) [m].
        path: PNG file to write.
        chain: The arm's :class:`~lpik.robots.chain.SerialChain` (drawn when given).
        target: The commanded target position [m], marked when given.
        title: Figure title.
        poses: Number of arm outlines, first and last included.

    Raises:
        MissingBackendError: When matplotlib is not installed.
        ValueError: When the log is not 3-D or the file cannot be written.
    """
    if log.position.shape[1] != 3:
        raise ValueError(f"log: positions have {log.position.shape[1]} coordinates, expected 3")
    try:
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MissingBackendError("figures", "plot") from None
    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=(11.0, 5.0), layout="constrained")
        FigureCanvasAgg(fig)
        ax3 = fig.add_subplot(1, 2, 1, projection="3d")
        ax_p = fig.add_subplot(1, 2, 2)
        trail = np.vstack([log.position, log.position_end])
        drawn = [trail, np.zeros((1, 3))]
        if chain is not None:
            q_all = np.vstack([log.q, log.q_end])
            idx = np.unique(np.linspace(0, len(q_all) - 1, max(2, poses)).round().astype(int))
            for j, (k, shade) in enumerate(zip(idx, np.linspace(0.75, 0.1, idx.size))):
                pts = arm_points(chain, q_all[k])
                drawn.append(pts)
                label = f"arm every {(idx[1] - idx[0]) * log.dt:.2g} s" if j == 1 else None
                ax3.plot(*pts.T, "-o", color=str(shade), lw=1.3, ms=2.5, label=label)
        ax3.plot(*trail.T, color="tab:orange", lw=2.2, label="tool path")
        ax3.scatter(*trail[0], color="tab:blue", s=30, label="start")
        ax3.scatter(*trail[-1], color="tab:red", s=30, label="end")
        if target is not None:
            drawn.append(np.asarray(target, dtype=float)[None, :3])
            ax3.scatter(*np.asarray(target)[:3], marker="x", color="black", s=50, label="target")
        ax3.set_xlabel("x [m]")
        ax3.set_ylabel("y [m]")
        ax3.set_zlabel("z [m]")
        _cube_limits(ax3, np.vstack(drawn))
        ax3.view_init(elev=20.0, azim=-60.0)
        ax3.legend(loc="upper left", fontsize=8)
        ax_p.plot(log.t, log.p, color="black", lw=1.6, label="affine dexterity p")
        stalled = np.flatnonzero(log.p < 0.5)
        if stalled.size:
            k = int(stalled[0])
            ax_p.axvline(log.t[k], color="tab:red", ls="--", lw=1)
            ax_p.annotate(
                f"p < 0.5 at t = {log.t[k]:.2f} s\nbinding: {log.binding[k] or '-'}",
                xy=(log.t[k], 0.5),
                xytext=(0.02, 0.2),
                textcoords="axes fraction",
                fontsize=9,
            )
        ax_p.set_xlabel("t [s]")
        ax_p.set_ylabel("p [-]")
        ax_p.set_ylim(-0.05, 1.1)
        ax_p.set_xlim(0.0, log.steps * log.dt)
        ax_p.grid(True, alpha=0.3)
        ax_p.legend(loc="upper right")
        fig.suptitle(title or log.name)
        out = Path(path)
        try:
            fig.savefig(out, dpi=DPI)
        except OSError as exc:
            raise ValueError(f"cannot write figure {str(out)!r}: {exc.strerror or exc}") from None
    return out


def reproduce_3d(
    out_dir: str | Path,
    robot: str = "panda",
    method: str = "lp2",
    progress: Any | None = None,
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
    from lpik.robots.registry import load_chain
    from lpik.scenarios3d import SCENARIOS_3D

    out = Path(out_dir)
    chain = load_chain(robot)
    files: list[Path] = []
    for name, scenario in SCENARIOS_3D.items():
        if progress is not None:
            progress(f"{name}, {robot} (3-D), {method}")
        log = scenario.run(robot, method)
        files.append(log.to_csv(out / f"{name}-3d-{robot}-{method}.csv"))
        target = scenario.target(robot)
        files.append(
            tool_path_figure(
                log,
                out / f"fig3d-{name}-{robot}.png",
                chain=chain,
                target=target[:3, 3] if target.ndim == 2 else target,
                title=f"3-D {name} on the {robot} ({method})",
            )
        )
    return files
