"""Figures of one run of any robot: overview, planar animation and 3-D tool path.

``lpik simulate --plot`` draws the overview (planar) or the tool path (3-D);
``--animate`` the animation.

Style, canvas and the arm's outline come from :mod:`lpik.paper.style`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lpik.control.log import SimulationLog
from lpik.exceptions import MissingBackendError
from lpik.paper.figures import draw_arm_motion, shade_binding
from lpik.paper.style import LAMBDA_LABEL, STYLE, arm_points, new_figure, save, styled
from lpik.robots.base import TaskModel

#: Arm outlines drawn on the 3-D path.
ARM_POSES_3D = 6


@styled
def run_overview(
    log: SimulationLog, model: TaskModel, path: str | Path, *, target: Sequence[float] | None = None
) -> Path:
    """One run at a glance (``lpik simulate --plot``): x-y, joints, dexterity, multipliers."""
    fig = new_figure(11.0, 7.5)
    grid = fig.subplots(2, 2)
    draw_arm_motion(grid[0, 0], log, model, target=target)
    grid[0, 0].legend(loc="best")
    for i in range(log.q.shape[1]):
        grid[0, 1].plot(log.t, np.rad2deg(log.q[:, i]), lw=1.3, label=f"q{i + 1}")
    grid[0, 1].set_ylabel("joint angle [deg]")
    grid[0, 1].legend(loc="best")
    grid[1, 0].plot(log.t, log.p, color="black", lw=1.5, label="p")
    shade_binding(grid[1, 0], log)
    grid[1, 0].set_ylabel("affine dexterity p [-]")
    grid[1, 0].set_ylim(-0.05, 1.1)
    grid[1, 0].legend(loc="best")
    ax_l = grid[1, 1]
    if np.isfinite(log.lam).any():
        ax_l.semilogy(log.t, np.nanmax(np.abs(log.lam), axis=1), color="tab:purple", lw=1.3)
    else:
        ax_l.text(0.5, 0.5, f"{log.method}: no multipliers", ha="center", transform=ax_l.transAxes)
    ax_l.set_ylabel(LAMBDA_LABEL)
    for ax in (grid[0, 1], grid[1, 0], ax_l):
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, log.steps * log.dt)
    m = log.metrics()
    fig.suptitle(
        f"{log.name or 'run'}, method {log.method}: jitter {m.jitter:.3g} rad/s, "
        f"final p = {m.final_p:.3g}"
    )
    return save(fig, path)


@styled
def animate(
    log: SimulationLog,
    model: TaskModel,
    path: str | Path,
    *,
    frames: int = 60,
    fps: int = 15,
    target: Sequence[float] | None = None,
) -> Path:
    """An animated GIF of the arm's motion, subsampled to at most ``frames`` frames.

    The static parts (axes, grid, target) are drawn once; each frame blits only
    the arm, the end-effector trace and the title onto that background, and
    Pillow assembles the GIF the way matplotlib's ``PillowWriter.finish`` does.
    ``PillowWriter.grab_frame`` would redraw the whole figure for every frame,
    about ten times slower.

    Args:
        log: The run.
        model: Its task model: a serial chain that moves in a plane.
        path: Output ``.gif``.
        frames: Largest number of frames.
        fps: Frames per second of the GIF.
        target: Target (x, y) [m] to mark.

    Raises:
        ValueError: When the model cannot be drawn or the file cannot be written.
        MissingBackendError: When matplotlib or pillow is missing.
    """
    if getattr(model, "position_dims", 3) != 2 or arm_points(model, log.q[0]) is None:
        raise ValueError(
            f"--animate: draws planar arms only, not {getattr(model, 'name', model)!r}; use --plot"
        )

    def draw(q: Any) -> Any:
        return arm_points(model, q)

    try:
        from PIL import Image
    except ImportError:
        raise MissingBackendError("animations", "plot") from None
    fig = new_figure(5.0, 4.0)
    fig.set_dpi(80)
    ax = fig.add_subplot()
    q_all = np.vstack([log.q, log.q_end])
    path_xy = np.vstack([log.position, log.position_end])
    idx = np.unique(np.linspace(0, len(q_all) - 1, max(2, frames)).round().astype(int))
    points = np.vstack([draw(q_all[k]) for k in idx] + [path_xy])
    if target is not None:
        points = np.vstack([points, np.asarray(target[:2], dtype=float)])
    low, high = points.min(axis=0), points.max(axis=0)
    pad = 0.08 * float((high - low).max()) + 0.1
    ax.set_xlim(low[0] - pad, high[0] + pad)
    ax.set_ylim(low[1] - pad, high[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    if target is not None:
        ax.plot(*target[:2], "x", color="tab:red", ms=9, mew=2)
    (trace,) = ax.plot([], [], color="tab:red", lw=1.5, animated=True)
    (arm,) = ax.plot([], [], "-o", color="black", lw=2, ms=4, animated=True)
    label = ax.set_title(f"{log.name} {log.method}: t = 0.00 s, p = 1.00")
    canvas = fig.canvas
    canvas.draw()
    fig.set_layout_engine("none")  # freeze the layout found for the first frame
    label.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    images = []
    for k in idx:
        canvas.restore_region(background)
        arm.set_data(*draw(q_all[k]).T)
        trace.set_data(path_xy[: k + 1, 0], path_xy[: k + 1, 1])
        p = log.p[min(k, log.steps - 1)]
        label.set_text(f"{log.name} {log.method}: t = {k * log.dt:.2f} s, p = {p:.2f}")
        for artist in (trace, arm, label):
            ax.draw_artist(artist)
        rgba = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba())
        images.append(rgba.convert("RGB").quantize(64, method=Image.Quantize.FASTOCTREE))
    out = Path(path)
    try:
        images[0].save(
            out, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0
        )
    except OSError as exc:
        raise ValueError(f"--animate: cannot write {str(out)!r}: {exc.strerror or exc}") from None
    return out


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
    model: TaskModel | None = None,
    target: np.ndarray | None = None,
    title: str = "",
    poses: int = ARM_POSES_3D,
) -> Path:
    """Tool path in 3-D with arm outlines, and the affine dexterity over time.

    Args:
        log: A run whose positions are (x, y, z) [m].
        path: PNG file to write.
        model: The run's task model (the arm is drawn when given).
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
        if model is not None and arm_points(model, log.q[0]) is not None:
            q_all = np.vstack([log.q, log.q_end])
            idx = np.unique(np.linspace(0, len(q_all) - 1, max(2, poses)).round().astype(int))
            for j, (k, shade) in enumerate(zip(idx, np.linspace(0.75, 0.1, idx.size))):
                pts = arm_points(model, q_all[k])
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
        return save(fig, path)
