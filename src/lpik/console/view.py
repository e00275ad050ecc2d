"""The viser layer: the scene, the target gizmo, the instruments and the controls of the page.

Thin on purpose: it draws what :mod:`lpik.console.geometry` computes from the
loop's :class:`~lpik.console.loop.Snapshot`, and turns the page's widgets into
calls of :class:`~lpik.console.loop.ControlLoop`. One refresh thread updates
every connected page at :data:`REFRESH_HZ`; the control loop never waits for it.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Any

import numpy as np

from lpik.console import geometry as geo
from lpik.console.loop import ControlLoop
from lpik.console.record import recordings
from lpik.console.stepper import LAMBDA_RANGE, QDD_RANGE, V_RANGE, W_RANGE
from lpik.methods.registry import METHODS

#: The multiplier-bound choice that uses the number ``B``.
BOUNDED = "|lam| <= B"
#: How often the page is refreshed [Hz].
REFRESH_HZ = 30.0
#: Seconds of p the scrolling plot shows, and the points of the tool's trail.
PLOT_SECONDS, TRAIL_POINTS = 10.0, 300


class ConsoleView:
    """The page of one console: built once on a viser server, refreshed by a thread.

    Args:
        server: A started ``viser.ViserServer``.
        loop: The control loop it shows and commands.
    """

    def __init__(self, server: Any, loop: ControlLoop) -> None:
        self.server, self.loop, self.robot = server, loop, loop.robot
        model = self.robot.model
        self._limits = (
            np.asarray(model.q_min),
            np.asarray(model.q_max),
            None if model.qd_max is None else np.asarray(model.qd_max),
        )
        self._trail: deque[np.ndarray] = deque(maxlen=TRAIL_POINTS)
        self._path: deque[np.ndarray] = deque(maxlen=TRAIL_POINTS)
        self._plot_t: deque[float] = deque(maxlen=int(PLOT_SECONDS * REFRESH_HZ))
        self._plot_p: deque[float] = deque(maxlen=int(PLOT_SECONDS * REFRESH_HZ))
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._frames, self._t0, self._last_step = 0, time.perf_counter(), -1
        self._build_scene()
        self._build_gui()

    # ---- building -----------------------------------------------------------------------------
    def _build_scene(self) -> None:
        scene, planar = self.server.scene, self.robot.planar
        scene.set_up_direction("+z")
        camera = self.server.initial_camera
        camera.position, camera.look_at = (
            ((1.5, -2.5, 6.0), (1.5, 1.0, 0.0)) if planar else ((1.6, -1.4, 1.1), (0.3, 0.0, 0.4))
        )
        scene.add_grid(
            "/grid",
            width=10.0 if planar else 3.0,
            height=10.0 if planar else 3.0,
            cell_size=0.5 if planar else 0.1,
        )
        self._links = [self._add_link(k, c.radius) for k, c in enumerate(self.robot.capsules)]
        self._obstacles: dict[str, list[Any]] = {}
        for k, shape in enumerate(geo.obstacle_shapes(self.robot.scene)):
            handle = self._add_obstacle(f"/obstacles/{k}", shape)
            self._obstacles.setdefault(shape.name, []).append(handle)
        self._add_target()

    def _add_link(self, k: int, radius: float) -> tuple[Any, list[Any]]:
        """Link ``k``'s capsule: a unit cylinder and its two end spheres, placed each refresh."""
        scene = self.server.scene
        cyl = scene.add_cylinder(f"/robot/link{k}", radius=radius, height=1.0, color=geo.ARM)
        ends = [
            scene.add_icosphere(f"/robot/end{k}-{e}", radius=radius, color=geo.ARM, subdivisions=2)
            for e in (0, 1)
        ]
        return cyl, ends

    def _add_obstacle(self, name: str, shape: geo.Shape) -> Any:
        """One shape of :func:`lpik.console.geometry.obstacle_shapes` in the scene."""
        scene = self.server.scene
        if shape.kind == "sphere":
            return scene.add_icosphere(
                name, radius=shape.size[0], color=geo.OBSTACLE, position=shape.position
            )
        if shape.kind == "cylinder":
            return scene.add_cylinder(
                name,
                radius=shape.size[0],
                height=shape.size[1],
                color=geo.OBSTACLE,
                position=shape.position,
                wxyz=shape.wxyz,
            )
        return scene.add_box(
            name,
            color=geo.OBSTACLE,
            dimensions=shape.size,
            position=shape.position,
            wxyz=shape.wxyz,
            opacity=0.8,
        )

    def _add_target(self) -> None:
        """The target's gizmo, at the loop's target, and the tool's frame."""
        scene, planar = self.server.scene, self.robot.planar
        target = np.asarray(self.loop.snapshot().target)
        pose = target if target.shape == (4, 4) else None
        position = target[:3, 3] if pose is not None else target
        self.gizmo = scene.add_transform_controls(
            "/target",
            scale=0.6 if planar else 0.2,
            position=tuple(position),
            wxyz=geo.wxyz(pose[:3, :3]) if pose is not None else (1.0, 0.0, 0.0, 0.0),
            disable_rotations=not self.robot.orientation,
            depth_test=False,
            active_axes=(True, True, not planar),
        )
        self.gizmo.on_update(self._on_gizmo)
        self._shown_target = np.array(target)
        self._tool = scene.add_frame(
            "/tool", axes_length=0.3 if planar else 0.08, axes_radius=0.01 if planar else 0.004
        )

    def _build_gui(self) -> None:
        gui, loop, robot = self.server.gui, self.loop, self.robot
        title = "paper's planar arm" if robot.planar else robot.name
        gui.add_markdown(f"**lpik console** · {title} · {1 / robot.dt:.0f} Hz")
        self.gauge = gui.add_progress_bar(100.0, color="green")
        self.panel = gui.add_html(self._instruments())
        self.plot = gui.add_uplot(
            data=(np.zeros(1), np.ones(1)),
            series=({"label": "t [s]"}, {"label": "p", "stroke": "#1971c2", "width": 2}),
            scales={"x": {"time": False, "auto": True}, "y": {"range": (0.0, 1.05)}},
            title="p over time",
            aspect=2.2,
        )
        s = loop.settings()
        with gui.add_folder("Controls"):
            self.method = gui.add_dropdown("method", tuple(METHODS), initial_value=s.method)
            self.v_max = gui.add_slider("v_max [m/s]", *V_RANGE, 0.01, s.v_max)
            self.w_max = gui.add_slider("w_max [rad/s]", *W_RANGE, 0.05, s.w_max)
            kind = {None: "none", "auto": "auto"}.get(s.lambda_bound, BOUNDED)  # type: ignore[arg-type]
            self.bound_kind = gui.add_dropdown(
                "multiplier bound", ("auto", "none", BOUNDED), initial_value=kind
            )
            number = s.lambda_bound if isinstance(s.lambda_bound, float | int) else 1.0
            self.bound = gui.add_number("B", number, min=LAMBDA_RANGE[0], max=LAMBDA_RANGE[1])
            self.accel_on = gui.add_checkbox("acceleration limits", s.qdd_max is not None)
            self.accel = gui.add_number(
                "qdd_max [rad/s²]", s.qdd_max or 20.0, min=QDD_RANGE[0], max=QDD_RANGE[1]
            )
            self.pause = gui.add_button("Pause / resume")
            self.reset = gui.add_button("Reset")
            self.message = gui.add_markdown("")
        for handle in (
            self.method,
            self.v_max,
            self.w_max,
            self.bound_kind,
            self.bound,
            self.accel_on,
            self.accel,
        ):
            handle.on_update(lambda _: self._apply_settings())
        self.pause.on_click(lambda _: loop.pause(not loop.snapshot().paused))
        self.reset.on_click(lambda _: self._reset())
        with gui.add_folder("Record and replay"):
            disabled = loop.record_dir is None
            self.record = gui.add_button(
                "Record" if not disabled else "Record (no --record-dir)", disabled=disabled
            )
            files = recordings(loop.record_dir) or ["(none)"]
            self.replay_file = gui.add_dropdown("CSV", files, disabled=disabled)
            self.replay = gui.add_button("Replay", disabled=disabled)
        self.record.on_click(lambda _: self._toggle_recording())
        self.replay.on_click(lambda _: self._start_replay())

    # ---- the widgets --------------------------------------------------------------------------
    def _say(self, text: str) -> None:
        self.message.content = text

    def _apply_settings(self) -> None:
        try:
            self.loop.change(
                method=self.method.value,
                v_max=float(self.v_max.value),
                w_max=float(self.w_max.value),
                lambda_bound={"auto": "auto", "none": None}.get(
                    self.bound_kind.value, float(self.bound.value)
                ),
                qdd_max=float(self.accel.value) if self.accel_on.value else None,
            )
            self._say("")
        except ValueError as exc:
            self._say(f"**not applied:** {exc}")

    def _on_gizmo(self, event: Any) -> None:
        # viser >= 1.1 passes an event whose ``target`` is the gizmo; older ones the gizmo
        handle = getattr(event, "target", event)
        pose = np.eye(4)
        pose[:3, :3] = geo.rotation(handle.wxyz)
        pose[:3, 3] = handle.position
        try:
            self.loop.set_target(pose)
            self._shown_target = self.loop.target()
        except ValueError as exc:
            self._say(f"**target refused:** {exc}")

    def _reset(self) -> None:
        self.loop.reset()
        self._trail.clear()
        self._path.clear()

    def _follow_target(self, target: np.ndarray) -> None:
        """Move the gizmo to a target set elsewhere (reset, replay, the Python API)."""
        if self._shown_target.shape == target.shape and np.allclose(self._shown_target, target):
            return
        self._shown_target = target
        self.gizmo.position = tuple(target[:3, 3] if target.shape == (4, 4) else target)
        if target.shape == (4, 4):
            self.gizmo.wxyz = geo.wxyz(target[:3, :3])

    def _toggle_recording(self) -> None:
        try:
            if self.loop.snapshot().recording is None:
                self.loop.start_recording()
                self.record.label = "Stop and save"
                self._say("recording...")
            else:
                path = self.loop.stop_recording()
                self.record.label = "Record"
                self.replay_file.options = recordings(self.loop.record_dir) or ["(none)"]
                self._say(f"saved {path.name}")
        except ValueError as exc:
            self._say(f"**record:** {exc}")

    def _start_replay(self) -> None:
        try:
            replay = self.loop.replay(str(self.replay_file.value))
            self._trail.clear()
            self._say(f"replaying {self.replay_file.value}: {replay.steps} steps")
        except ValueError as exc:
            self._say(f"**replay:** {exc}")

    # ---- refreshing ---------------------------------------------------------------------------
    def _instruments(self) -> str:
        return geo.instruments_html(
            self.loop.snapshot(), self.robot.model.joint_names, *self._limits
        )

    def start(self) -> None:
        """Start the refresh thread."""
        self._thread = threading.Thread(target=self._run, name="lpik-console-view", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the refresh thread."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)

    @property
    def frame_rate(self) -> float:
        """Refreshes per second since the page was built [Hz]."""
        return self._frames / max(time.perf_counter() - self._t0, 1e-9)

    def _run(self) -> None:
        period = 1.0 / REFRESH_HZ
        clock = time.perf_counter()
        while True:
            clock = max(clock + period, time.perf_counter() - period)  # never rush to catch up
            if self._stop.wait(max(0.0, clock - time.perf_counter())):
                return
            try:
                self.refresh()
            except Exception as exc:  # a page error must not end the refresh
                self._say(f"**view:** {type(exc).__name__}: {exc}")

    def refresh(self) -> None:
        """Draw the latest snapshot on every page."""
        snap = self.loop.snapshot()
        robot = self.robot
        a, b = self._capsule_ends(snap.q)
        lit, lit_obstacles = geo.highlighted(snap.binding, robot.capsules)
        colour = geo.HIGHLIGHT.get(getattr(snap.binding, "kind", ""), geo.ARM)
        tool = robot.tool_pose(snap.q)
        target = np.asarray(snap.target)
        goal = target[:3, 3] if target.shape == (4, 4) else target
        moved = snap.step != self._last_step
        self._last_step = snap.step
        if moved:
            self._trail.append(tool[:3, 3].copy())
            self._path.append(np.array(goal, dtype=float))
        self._frames += 1
        with self.server.atomic():
            self._follow_target(self.loop.target())
            for k, (cyl, ends) in enumerate(self._links):
                seg = geo.segment(a[k], b[k])
                cyl.position, cyl.wxyz = seg.center, seg.wxyz
                cyl.scale = (1.0, 1.0, max(seg.length, 1e-6))
                ends[0].position, ends[1].position = tuple(a[k]), tuple(b[k])
                want = colour if k in lit else geo.ARM
                if cyl.color != want:
                    cyl.color = want
                    ends[0].color = ends[1].color = want
            for name, handles in self._obstacles.items():
                want = colour if name in lit_obstacles else geo.OBSTACLE
                for h in handles:
                    if h.color != want:
                        h.color = want
            self._tool.position, self._tool.wxyz = tuple(tool[:3, 3]), geo.wxyz(tool[:3, :3])
            self._draw_lines(tool[:3, 3], goal)
            self.gauge.value = 100.0 * snap.p
            self.gauge.color = "green" if snap.p > 0.99 else "orange" if snap.p > 0.2 else "red"
            self.panel.content = self._instruments()
            self._plot_t.append(time.perf_counter() - self._t0)
            self._plot_p.append(snap.p)
            if self._frames % 3 == 0:
                self.plot.data = (np.array(self._plot_t), np.array(self._plot_p))

    def _capsule_ends(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        frames = self.robot.model.kinematics.joint_frames(q)  # type: ignore[attr-defined]
        a, b = [], []
        for c in self.robot.capsules:
            pose = np.eye(4) if c.joint < 0 else frames[c.joint]
            a.append(pose[:3, :3] @ c.a + pose[:3, 3])
            b.append(pose[:3, :3] @ c.b + pose[:3, 3])
        return np.array(a), np.array(b)

    def _draw_lines(self, tool: np.ndarray, goal: np.ndarray) -> None:
        scene = self.server.scene
        thin = 0.01 if self.robot.planar else 0.003
        lines = [("/trail", self._trail, (30, 110, 220)), ("/path", self._path, (230, 120, 20))]
        for name, points, rgb in lines:
            if len(points) < 2:
                continue
            p = np.array(points)
            segments = np.stack([p[:-1], p[1:]], axis=1)
            scene.add_line_segments(name, segments, rgb, thickness=thin)
        scene.add_line_segments(
            "/command", np.array([[tool, goal]]), (230, 120, 20), thickness=thin / 2
        )
