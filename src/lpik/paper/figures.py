"""The paper's figures 3-9, drawn from simulation logs of the planar arm.

Style, canvas and the arm's outline come from :mod:`lpik.paper.style`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lpik.control.log import SimulationLog
from lpik.paper.style import (
    ARM_POSES,
    LAMBDA_LABEL,
    arm_points,
    new_figure,
    save,
    styled,
)
from lpik.robots.base import TaskModel

if TYPE_CHECKING:
    from matplotlib.axes import Axes


def draw_arm_motion(
    ax: Axes,
    log: SimulationLog,
    model: TaskModel,
    *,
    target: Sequence[float] | None = None,
    poses: int = ARM_POSES,
) -> None:
    """Arm outlines at equal intervals, the end-effector path, start, end and target.

    Args:
        ax: Axes to draw on.
        log: The run.
        model: Its task model; the arm is drawn when it is a serial chain.
        target: The commanded target (x, y) [m], marked when given.
        poses: Number of arm outlines, first and last included.
    """
    q_all = np.vstack([log.q, log.q_end])
    path = np.vstack([log.position, log.position_end])
    if arm_points(model, q_all[0]) is not None:

        def draw(q: Any) -> Any:
            return arm_points(model, q)

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


@styled
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
    fig = new_figure(7.0, 5.0)
    ax = fig.add_subplot()
    if reach is not None:
        end = np.arctan2(log.position_end[1], log.position_end[0])
        ang = np.linspace(end - 0.35, end + 0.35, 100)
        ax.plot(reach * np.cos(ang), reach * np.sin(ang), "--", color="tab:purple", lw=1.2,
                label=f"reach {reach:g} m (edge singularity)")  # fmt: skip
    draw_arm_motion(ax, log, model, target=target)
    ax.set_title(title)
    ax.legend(loc="best")
    return save(fig, path)


def _joint_axes(ax_q: Axes, ax_v: Axes, log: SimulationLog) -> None:
    """Joint angles [deg] and applied joint velocities [rad/s] over time."""
    v = log.joint_velocities()
    for i in range(log.q.shape[1]):
        ax_q.plot(log.t, np.rad2deg(log.q[:, i]), lw=1.3, label=f"q{i + 1}")
        ax_v.plot(log.t, v[:, i], lw=0.9, label=f"q{i + 1}")
    ax_q.set_ylabel("joint angle [deg]")
    ax_v.set_ylabel("joint velocity [rad/s]")
    ax_v.set_xlabel("t [s]")
    for ax in (ax_q, ax_v):
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, log.steps * log.dt)


@styled
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
    fig = new_figure(3.6 * len(runs) + 1.0, 6.2)
    axes = fig.subplots(2, len(runs), sharex="col", sharey="row", squeeze=False)
    for col, (name, log) in enumerate(runs):
        ax_q, ax_v = axes[0, col], axes[1, col]
        _joint_axes(ax_q, ax_v, log)
        ax_q.set_title(f"{name}\njitter {log.jitter():.4g} rad/s")
        if q_limit is not None:
            i, value = q_limit
            ax_q.axhline(np.rad2deg(value), color="tab:red", ls="--", lw=1,
                         label=f"q{i + 1} limit {np.rad2deg(value):g} deg")  # fmt: skip
        if col:
            ax_q.set_ylabel("")
            ax_v.set_ylabel("")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels))
    fig.suptitle(title)
    return save(fig, path)


@styled
def dexterity_figure(
    log: SimulationLog, path: str | Path, *, title: str, q_limit: tuple[int, float] | None = None
) -> Path:
    """Affine dexterity over time, with the binding limit shaded (Fig. 6)."""
    fig = new_figure(7.0, 5.0)
    ax_p, ax_q = fig.subplots(2, 1, sharex=True, height_ratios=[3, 2])
    ax_p.plot(log.t, log.p, color="black", lw=1.8, label="affine dexterity p")
    shade_binding(ax_p, log)
    ax_p.set_ylabel("p [-]")
    ax_p.set_ylim(-0.05, 1.1)
    ax_p.legend(loc="best")
    i = 0 if q_limit is None else q_limit[0]
    ax_q.plot(log.t, np.rad2deg(log.q[:, i]), color="tab:blue", lw=1.5, label=f"q{i + 1}")
    if q_limit is not None:
        ax_q.axhline(np.rad2deg(q_limit[1]), color="tab:red", ls="--", lw=1,
                     label=f"q{i + 1} limit {np.rad2deg(q_limit[1]):g} deg")  # fmt: skip
    ax_q.set_ylabel("joint angle [deg]")
    ax_q.set_xlabel("t [s]")
    ax_q.legend(loc="best")
    for ax in (ax_p, ax_q):
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0.0, log.steps * log.dt)
    ax_p.set_title(title)
    return save(fig, path)


def shade_binding(ax: Axes, log: SimulationLog) -> None:
    """Shade the time spans where one limit binds, labelled with its name (most frequent first)."""
    named = np.array([b is not None for b in log.binding], dtype=bool)
    names, counts = np.unique(log.binding[named].astype(str), return_counts=True)
    colors = ["tab:orange", "tab:green", "tab:purple", "tab:brown"]
    for color, name in zip(colors, names[np.argsort(-counts)][: len(colors)]):
        on = log.binding == name
        ax.fill_between(log.t, 0, 1, where=on, step="post", color=color, alpha=0.25,
                        transform=ax.get_xaxis_transform(), label=f"binding: {name}")  # fmt: skip


@styled
def singularity_figure(
    log: SimulationLog,
    path: str | Path,
    *,
    title: str,
    lambda_bound: float | None = None,
    lambda_ylim: tuple[float, float] | None = None,
) -> Path:
    """Dexterity, joint motion and multipliers near the edge singularity (Figs. 8, 9)."""
    fig = new_figure(7.5, 8.5)
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
    return save(fig, path)
