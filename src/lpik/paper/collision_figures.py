"""Figures of runs with obstacles: path, smallest distance, dexterity and the binding limit.

One column per run (e.g. the potential field alone, the hard distance rows
alone, both): the motion with the obstacles (x-y with the arm drawn at
intervals for a planar arm, the tool path in 3-D otherwise), the smallest
signed distance over time with ``d_s`` and ``d_i``, and ``p`` over time with
the spans where one limit binds shaded and named.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lpik.control.log import SimulationLog
from lpik.paper.figures import draw_arm_motion, shade_binding
from lpik.paper.style import arm_points, new_figure, save, styled
from lpik.robots.rotations import transform

if TYPE_CHECKING:
    from matplotlib.axes import Axes

#: Colour of the obstacles.
OBSTACLE_COLOR = "tab:brown"
#: Arm outlines drawn on a 3-D panel.
ARM_POSES_3D = 4


def _box_corners(obstacle: Any) -> np.ndarray:
    size = obstacle.size if obstacle.size.size == 3 else np.append(obstacle.size, 0.0)
    center = obstacle.center if obstacle.center.size == 3 else np.append(obstacle.center, 0.0)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    pose = transform(center, obstacle.rpy)
    return (signs * size / 2) @ pose[:3, :3].T + center


def draw_obstacles_2d(ax: Axes, scene: Any) -> None:
    """The obstacles of a planar scene, filled."""
    from matplotlib.patches import Circle, Polygon

    for k, o in enumerate(scene.obstacles):
        label = "obstacle" if k == 0 else None
        style = {"color": OBSTACLE_COLOR, "alpha": 0.5, "label": label}
        if o.kind == "sphere":
            ax.add_patch(Circle(tuple(o.center), o.radius, **style))
        elif o.kind == "capsule":
            ax.plot(*np.array([o.a, o.b]).T, color=OBSTACLE_COLOR, lw=3, label=label)
        elif o.kind == "box":
            corners = _box_corners(o)[[0, 2, 6, 4], :2]
            ax.add_patch(Polygon(corners, closed=True, **style))
        else:
            direction = np.array([-o.normal[1], o.normal[0]])
            ends = np.array([o.center - 10 * direction, o.center + 10 * direction])
            ax.plot(*ends.T, color=OBSTACLE_COLOR, lw=2, label=label)


def draw_obstacles_3d(ax: Any, scene: Any) -> None:
    """The obstacles of a 3-D scene as wire frames (planes are left out)."""
    edges = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5),
             (2, 6), (3, 7)]  # fmt: skip
    for o in scene.obstacles:
        if o.kind == "box":
            c = _box_corners(o)
            for i, j in edges:
                ax.plot(*c[[i, j]].T, color=OBSTACLE_COLOR, lw=0.8)
        elif o.kind == "sphere":
            u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 16), np.linspace(0, np.pi, 9))
            x = o.center[0] + o.radius * np.cos(u) * np.sin(v)
            y = o.center[1] + o.radius * np.sin(u) * np.sin(v)
            z = o.center[2] + o.radius * np.cos(v)
            ax.plot_wireframe(x, y, z, color=OBSTACLE_COLOR, lw=0.5)
        elif o.kind == "capsule":
            ax.plot(*np.array([o.a, o.b]).T, color=OBSTACLE_COLOR, lw=3)


def _motion_3d(ax: Any, log: SimulationLog, model: Any, scene: Any, target: Any) -> None:
    trail = np.vstack([log.position, log.position_end])
    q_all = np.vstack([log.q, log.q_end])
    idx = np.unique(np.linspace(0, len(q_all) - 1, ARM_POSES_3D).round().astype(int))
    for k, shade in zip(idx, np.linspace(0.7, 0.1, idx.size)):
        points = arm_points(model, q_all[k])
        if points is not None:
            ax.plot(*points.T, "-o", color=str(shade), lw=1.3, ms=2.5)
    draw_obstacles_3d(ax, scene)
    ax.plot(*trail.T, color="tab:red", lw=2, label="tool path")
    if target is not None:
        ax.scatter(*np.asarray(target)[:3], marker="x", color="black", s=50, label="target")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_xlim(-0.2, 1.0)
    ax.set_ylim(-0.6, 0.6)
    ax.set_zlim(0.0, 1.2)
    ax.view_init(elev=20.0, azim=-70.0)
    ax.legend(loc="upper left", fontsize=8)


@styled
def avoidance_figure(
    runs: Sequence[tuple[str, SimulationLog]],
    model: Any,
    scene: Any,
    path: str | Path,
    *,
    title: str,
    target: Sequence[float] | None = None,
) -> Path:
    """One column per run: the motion among the obstacles, the smallest distance, ``p``.

    Args:
        runs: ``(caption, log)`` of each run; the logs must have ``min_distance``.
        model: The runs' task model.
        scene: Their :class:`~lpik.collision.Scene`.
        path: PNG file to write.
        title: Figure title.
        target: The commanded target position [m], marked when given.

    Raises:
        ValueError: When a log has no distances or the file cannot be written.
    """
    planar = scene.dims == 2
    fig = new_figure(max(7.0, 5.0 * len(runs)), 11.0)
    grid = fig.add_gridspec(3, len(runs), height_ratios=[3, 1.3, 1.3])
    share_d = None
    for col, (caption, log) in enumerate(runs):
        if log.min_distance is None:
            raise ValueError(f"log {caption!r}: has no distances (run it with a scene)")
        if planar:
            ax = fig.add_subplot(grid[0, col])
            draw_obstacles_2d(ax, scene)
            draw_arm_motion(ax, log, model, target=target, poses=7)
            ax.legend(loc="lower left", fontsize=7)
        else:
            ax = fig.add_subplot(grid[0, col], projection="3d")
            _motion_3d(ax, log, model, scene, target)
        ax.set_title(caption)
        ax_d = fig.add_subplot(grid[1, col], sharey=share_d)
        share_d = share_d or ax_d
        ax_d.plot(log.t, log.min_distance, color="black", lw=1.4, label="smallest distance")
        ax_d.axhline(scene.safety_distance, color="tab:red", ls="--", lw=1, label="d_s")
        ax_d.axhline(scene.influence_distance, color="tab:blue", ls=":", lw=1, label="d_i")
        k = int(np.argmin(log.min_distance))
        ax_d.annotate(f"min {log.min_distance[k]:.3f} m\n{log.closest[k]}",  # type: ignore[index]
                      xy=(log.t[k], log.min_distance[k]), xytext=(0.35, 0.55),
                      textcoords="axes fraction", fontsize=8,
                      arrowprops={"arrowstyle": "->", "lw": 0.8})  # fmt: skip
        ax_d.set_ylabel("distance [m]")
        ax_d.legend(loc="upper right", fontsize=7)
        ax_p = fig.add_subplot(grid[2, col], sharex=ax_d)
        ax_p.plot(log.t, log.p, color="black", lw=1.4)
        shade_binding(ax_p, log)
        ax_p.set_ylim(-0.05, 1.1)
        ax_p.set_ylabel("p [-]")
        ax_p.set_xlabel("t [s]")
        if any(b is not None for b in log.binding):
            ax_p.legend(loc="lower left", fontsize=7)
        for a in (ax_d, ax_p):
            a.grid(True, alpha=0.3)
            a.set_xlim(0.0, log.steps * log.dt)
    fig.suptitle(title)
    return save(fig, path)
