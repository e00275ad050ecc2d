"""Figures from simulation logs: the paper's Figs. 3-9, a run overview and an animation.

matplotlib is optional (``pip install "lpik[plot]"``) and imported only inside
the functions here, so that the rest of lpik starts fast without it. Figures
are drawn with the object-oriented API on an Agg canvas: no pyplot state, no
display needed.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from lpik.exceptions import MissingBackendError
from lpik.simulate import SimulationLog

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: Resolution of saved figures [dots per inch]; 7 in wide -> 1050 px.
DPI = 150
#: Arm outlines drawn on an x-y figure.
ARM_POSES = 9
LAMBDA_LABEL = r"max$_i\,|\lambda_i|$ [rad$^2$/m]"
#: matplotlib settings of every figure: text readable when a figure is shown at README width.
STYLE: dict[str, Any] = {
    "font.size": 11,
    "axes.titlesize": 11,
    "axes.labelsize": 11,
    "legend.fontsize": 9,
    "legend.framealpha": 0.9,
    "lines.solid_capstyle": "butt",
}

F = TypeVar("F", bound=Callable[..., Path])


def _styled(fn: F) -> F:
    """Run a figure function inside ``matplotlib.rc_context(STYLE)``."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Path:
        try:
            import matplotlib
        except ImportError:
            raise MissingBackendError("figures", "plot") from None
        with matplotlib.rc_context(STYLE):
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def require_backend(*, animation: bool = False) -> None:
    """Raise :class:`~lpik.exceptions.MissingBackendError` unless figures can be drawn.

    Args:
        animation: Also require pillow (GIFs).
    """
    try:
        import matplotlib  # noqa: F401

        if animation:
            import PIL  # noqa: F401
    except ImportError:
        raise MissingBackendError("animations" if animation else "figures", "plot") from None


def _new_figure(width: float, height: float) -> Figure:
    """A figure on an Agg canvas; ``MissingBackendError`` when matplotlib is absent."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise MissingBackendError("figures", "plot") from None
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig: Figure, path: str | Path) -> Path:
    out = Path(path)
    try:
        fig.savefig(out, dpi=DPI)
    except OSError as exc:
        raise ValueError(f"cannot write figure {str(out)!r}: {exc.strerror or exc}") from None
    return out


def _deg(values: Any) -> Any:
    return np.rad2deg(values)


def draw_arm_motion(
    ax: Axes,
    log: SimulationLog,
    model: Any,
    *,
    target: Sequence[float] | None = None,
    poses: int = ARM_POSES,
) -> None:
    """Arm outlines at equal intervals, the end-effector path, start, end and target.

    Args:
        ax: Axes to draw on.
        log: The run.
        model: Its task model; the arm is drawn when it has ``joint_positions(q)``.
        target: The commanded target (x, y) [m], marked when given.
        poses: Number of arm outlines, first and last included.
    """
    q_all = np.vstack([log.q, log.q_end])
    path = np.vstack([log.position, log.position_end])
    draw = getattr(model, "joint_positions", None)
    if draw is not None:
        idx = np.unique(np.linspace(0, len(q_all) - 1, max(2, poses)).round().astype(int))
        shades = np.linspace(0.75, 0.15, idx.size)
        for j, (k, shade) in enumerate(zip(idx, shades)):
            pts = draw(q_all[k])
            label = f"arm every {(idx[1] - idx[0]) * log.dt:.2g} s" if j == 1 else None
            ax.plot(pts[:, 0], pts[:, 1], "-o", color=str(shade), lw=1.4, ms=3, label=label)
        ax.plot(*draw(q_all[0]).T, "-o", color="tab:blue", lw=2, ms=4, label="start (t = 0)")
        t_end = len(q_all) * log.dt - log.dt
        ax.plot(*draw(q_all[-1]).T, "-o", color="black", lw=2, ms=4, label=f"end (t = {t_end:g} s)")
        ax.plot([0], [0], "ks", ms=7)
    ax.plot(path[:, 0], path[:, 1], color="tab:red", lw=2, label="end-effector path")
    if target is not None:
        ax.plot(*target[:2], "x", color="tab:red", ms=10, mew=2, label="target")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)


@_styled
def xy_figure(
    log: SimulationLog,
    model: Any,
    path: str | Path,
    *,
    title: str,
    target: Sequence[float] | None = None,
    reach: float | None = None,
) -> Path:
    """x-y motion of the arm (Figs. 3, 5, 7), optionally with the workspace boundary."""
    fig = _new_figure(7.0, 5.0)
    ax = fig.add_subplot()
    if reach is not None:
        end = np.arctan2(log.position_end[1], log.position_end[0])
        ang = np.linspace(end - 0.35, end + 0.35, 100)
        ax.plot(reach * np.cos(ang), reach * np.sin(ang), "--", color="tab:purple", lw=1.2,
                label=f"reach {reach:g} m (edge singularity)")  # fmt: skip
    draw_arm_motion(ax, log, model, target=target)
    ax.set_title(title)
    ax.legend(loc="best")
    return _save(fig, path)


def _joint_axes(ax_q: Axes, ax_v: Axes, log: SimulationLog) -> None:
    """Joint angles [deg] and applied joint velocities [rad/s] over time."""
    v = log.joint_velocities()
    for i in range(log.q.shape[1]):
        ax_q.plot(log.t, _deg(log.q[:, i]), lw=1.3, label=f"q{i + 1}")
        ax_v.plot(log.t, v[:, i], lw=0.9, label=f"q{i + 1}")
    ax_q.set_ylabel("joint angle [deg]")
    ax_v.set_ylabel("joint velocity [rad/s]")
    ax_v.set_xlabel("t [s]")
    for ax in (ax_q, ax_v):
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, log.steps * log.dt)


@_styled
def joint_motion_figure(
    runs: Sequence[tuple[str, SimulationLog]],
    path: str | Path,
    *,
    title: str,
    q_limit: tuple[int, float] | None = None,
) -> Path:
    """Joint motion of several runs side by side (Fig. 4: a) LP1, b) LP2).

    Args:
        runs: ``(panel title, log)`` pairs, one column each.
        path: Output PNG.
        title: Figure title.
        q_limit: ``(joint index, limit [rad])`` drawn as a dashed line.
    """
    fig = _new_figure(3.6 * len(runs) + 1.0, 6.2)
    axes = fig.subplots(2, len(runs), sharex="col", sharey="row", squeeze=False)
    for col, (name, log) in enumerate(runs):
        ax_q, ax_v = axes[0, col], axes[1, col]
        _joint_axes(ax_q, ax_v, log)
        ax_q.set_title(f"{name}\njitter {log.jitter():.4g} rad/s")
        if q_limit is not None:
            i, value = q_limit
            ax_q.axhline(_deg(value), color="tab:red", ls="--", lw=1,
                         label=f"q{i + 1} limit {_deg(value):g} deg")  # fmt: skip
        if col:
            ax_q.set_ylabel("")
            ax_v.set_ylabel("")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels))
    fig.suptitle(title)
    return _save(fig, path)


@_styled
def dexterity_figure(
    log: SimulationLog, path: str | Path, *, title: str, q_limit: tuple[int, float] | None = None
) -> Path:
    """Affine dexterity over time, with the binding limit shaded (Fig. 6)."""
    fig = _new_figure(7.0, 5.0)
    ax_p, ax_q = fig.subplots(2, 1, sharex=True, height_ratios=[3, 2])
    ax_p.plot(log.t, log.p, color="black", lw=1.8, label="affine dexterity p")
    _shade_binding(ax_p, log)
    ax_p.set_ylabel("p [-]")
    ax_p.set_ylim(-0.05, 1.1)
    ax_p.legend(loc="best")
    i = 0 if q_limit is None else q_limit[0]
    ax_q.plot(log.t, _deg(log.q[:, i]), color="tab:blue", lw=1.5, label=f"q{i + 1}")
    if q_limit is not None:
        ax_q.axhline(_deg(q_limit[1]), color="tab:red", ls="--", lw=1,
                     label=f"q{i + 1} limit {_deg(q_limit[1]):g} deg")  # fmt: skip
    ax_q.set_ylabel("joint angle [deg]")
    ax_q.set_xlabel("t [s]")
    ax_q.legend(loc="best")
    for ax in (ax_p, ax_q):
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, log.steps * log.dt)
    ax_p.set_title(title)
    return _save(fig, path)


def _shade_binding(ax: Axes, log: SimulationLog) -> None:
    """Shade the time spans where one limit binds, labelled with its name (most frequent first)."""
    names, counts = np.unique(log.binding[log.binding != ""], return_counts=True)
    colors = ["tab:orange", "tab:green", "tab:purple", "tab:brown"]
    for color, name in zip(colors, names[np.argsort(-counts)][: len(colors)]):
        on = log.binding == name
        ax.fill_between(log.t, 0, 1, where=on, step="post", color=color, alpha=0.25,
                        transform=ax.get_xaxis_transform(), label=f"binding: {name}")  # fmt: skip


@_styled
def singularity_figure(
    log: SimulationLog,
    path: str | Path,
    *,
    title: str,
    lambda_bound: float | None = None,
    lambda_ylim: tuple[float, float] | None = None,
) -> Path:
    """Dexterity, joint motion and multipliers near the edge singularity (Figs. 8, 9)."""
    fig = _new_figure(7.5, 8.5)
    ax_p, ax_q, ax_v, ax_l = fig.subplots(4, 1, sharex=True, height_ratios=[2, 3, 3, 2])
    ax_p.plot(log.t, log.p, color="black", lw=1.5)
    ax_p.set_ylabel("dexterity p [-]")
    ax_p.set_ylim(-0.05, 1.1)
    _joint_axes(ax_q, ax_v, log)
    ax_q.legend(loc="best", ncol=2)
    lam = np.nanmax(np.abs(log.lam), axis=1) if np.isfinite(log.lam).any() else None
    if lam is not None:
        ax_l.semilogy(log.t, lam, color="tab:purple", lw=1.3, label=r"max$_i\,|\lambda_i|$")
    if lambda_bound is not None:
        ax_l.axhline(lambda_bound, color="tab:red", ls="--", lw=1,
                     label=rf"bound $|\lambda_i| \leq {lambda_bound:g}$")  # fmt: skip
    if lambda_ylim is not None:
        ax_l.set_ylim(*lambda_ylim)
    ax_l.set_ylabel(LAMBDA_LABEL)
    ax_l.set_xlabel("t [s]")
    ax_l.legend(loc="best")
    for ax in (ax_p, ax_q, ax_v, ax_l):
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, log.steps * log.dt)
    ax_v.set_xlabel("")
    fig.suptitle(f"{title}\njitter {log.jitter():.4g} rad/s, final p = {log.p[-1]:.3g}")
    return _save(fig, path)


@_styled
def run_overview(
    log: SimulationLog, model: Any, path: str | Path, *, target: Sequence[float] | None = None
) -> Path:
    """One run at a glance (``lpik simulate --plot``): x-y, joints, dexterity, multipliers."""
    fig = _new_figure(11.0, 7.5)
    grid = fig.subplots(2, 2)
    draw_arm_motion(grid[0, 0], log, model, target=target)
    grid[0, 0].legend(loc="best")
    for i in range(log.q.shape[1]):
        grid[0, 1].plot(log.t, _deg(log.q[:, i]), lw=1.3, label=f"q{i + 1}")
    grid[0, 1].set_ylabel("joint angle [deg]")
    grid[0, 1].legend(loc="best")
    grid[1, 0].plot(log.t, log.p, color="black", lw=1.5, label="p")
    _shade_binding(grid[1, 0], log)
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
    return _save(fig, path)


@_styled
def animate(
    log: SimulationLog,
    model: Any,
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
        model: Its planar model (needs ``joint_positions(q)``).
        path: Output ``.gif``.
        frames: Largest number of frames.
        fps: Frames per second of the GIF.
        target: Target (x, y) [m] to mark.

    Raises:
        ValueError: When the model cannot be drawn or the file cannot be written.
        MissingBackendError: When matplotlib or pillow is missing.
    """
    draw = getattr(model, "joint_positions", None)
    if draw is None:
        raise ValueError(f"--animate: cannot draw model {getattr(model, 'name', model)!r}")
    try:
        from PIL import Image
    except ImportError:
        raise MissingBackendError("animations", "plot") from None
    fig = _new_figure(5.0, 4.0)
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
