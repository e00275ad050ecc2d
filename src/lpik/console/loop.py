"""The console's control loop: one controller in one server thread, whatever the browsers do.

:class:`ControlLoop` steps the robot at its control period (1 kHz for the 3-D
arms, 0.01 s for the planar arm) in a thread of its own, toward the latest
target; pages read :meth:`ControlLoop.snapshot` and send targets and settings,
so closing a tab or opening many neither stops nor duplicates the controller.
A step that raises (it should not) pauses the loop and shows the message;
every target is checked (:meth:`ControlLoop.set_target`), and a target far
outside the workspace is simply one the arm cannot reach: ``p`` goes to 0 and
the binding names the limit or the singularity.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lpik.collision.model import as_avoidance
from lpik.command import checked_target
from lpik.console.record import Recorder, Replay, read_replay, recording_path
from lpik.console.robot import ConsoleRobot
from lpik.console.stepper import Settings, make_stepper
from lpik.types import FloatArray

#: Seconds behind schedule after which the loop stops catching up and restarts its clock.
RESYNC_AFTER = 0.05
#: Weight of the latest step in the step time's moving average (about the last 100 steps).
STEP_TIME_WEIGHT = 0.01
#: Steps between two distance read-outs when not recording (every step while recording).
DISTANCE_EVERY = 30


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The loop's state after one step, as the page shows it.

    Attributes:
        step: Steps taken since start or reset.
        q: Joint coordinates [rad].
        qd: Joint velocities of the last step [rad/s].
        p: The last step's affine dexterity.
        binding: The limit that held it (a :class:`~lpik.labels.Binding`), or None.
        status: The last step's status.
        step_time: Wall time of a control step, averaged over about the last 100 steps [s].
        rate: Real-time factor: steps per second over the control rate (1: real time).
        target: The commanded task value.
        paused: Whether the loop is paused.
        replaying: Whether a recording is being replayed.
        recording: Steps recorded so far, or None when not recording.
        closest: The smallest distance [m] and its pair, with a scene; else None.
        error: The message of a step that raised, or None.
        settings: The settings in force.
    """

    step: int
    q: FloatArray
    qd: FloatArray
    p: float
    binding: Any
    status: str
    step_time: float
    rate: float
    target: FloatArray
    paused: bool
    replaying: bool
    recording: int | None
    closest: tuple[float, str] | None
    error: str | None
    settings: Settings


class ControlLoop:
    """The robot's control loop, run in a thread of its own (:meth:`start`, :meth:`stop`).

    Args:
        robot: What to drive.
        settings: The first settings (default: LP2 at the robot's speeds).
        record_dir: The one folder recordings may be written to and replayed from; None: none.

    Raises:
        ValueError: For settings the robot cannot take.
    """

    def __init__(
        self,
        robot: ConsoleRobot,
        settings: Settings | None = None,
        record_dir: str | Path | None = None,
    ) -> None:
        self.robot = robot
        self.record_dir = None if record_dir is None else Path(record_dir)
        self._settings = settings or Settings(v_max=robot.v_max, w_max=robot.w_max)
        self._stepper = make_stepper(robot, self._settings)
        self._avoid = as_avoidance(robot.model, robot.scene, robot.q0)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._recorder: Recorder | None = None
        self._replay: Replay | None = None
        self._reset_state()

    def _reset_state(self) -> None:
        n = self.robot.model.n_joints
        self._q, self._q_prev = self.robot.q0.copy(), None
        self._target = self.robot.home_target()
        self._replay, self._replay_at = None, 0
        self._paused, self._error = False, None
        self._mean_time = getattr(self, "_mean_time", 0.0)
        self._closest = self._distance(self._q)
        self._snap = self._make_snapshot(0, np.zeros(n), 1.0, None, "optimal", 0.0, 1.0)

    # ---- the thread -------------------------------------------------------------------------
    def start(self) -> None:
        """Start stepping in a daemon thread (once; a second call does nothing)."""
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._run, name="lpik-console-loop", daemon=True)
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread and wait for it (at most ``timeout`` seconds)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    @property
    def running(self) -> bool:
        """Whether the thread is alive."""
        return self._thread is not None and self._thread.is_alive()

    def _run(self) -> None:
        dt = self.robot.dt
        clock = time.perf_counter()
        window_start, window_steps, rate = clock, 0, 1.0
        while not self._stop.is_set():
            try:
                self.tick(rate)
            except Exception as exc:  # e.g. a distance query: the thread goes on, paused
                self._fail(exc, rate)
            window_steps += 1
            now = time.perf_counter()
            if now - window_start >= 1.0:
                rate = window_steps * dt / (now - window_start)
                window_start, window_steps = now, 0
            clock += dt
            if clock - now > 0:
                time.sleep(clock - now)
            elif now - clock > RESYNC_AFTER:  # behind: drop the backlog, never rush
                clock = now

    # ---- one step ---------------------------------------------------------------------------
    def tick(self, rate: float = 1.0) -> Snapshot:
        """One control period: a step toward the target (or a replayed row), then publish it."""
        with self._lock:
            if self._paused:
                return self._snap
            if self._replay is not None:
                return self._replay_tick(rate)
            q, q_prev, target, stepper = self._q, self._q_prev, self._target, self._stepper
            recorder = self._recorder
        start = time.perf_counter()
        try:
            result = stepper(q, target, q_prev)
            if not np.isfinite(result.q).all():
                raise ValueError("the step returned coordinates that are not finite")
        except Exception as exc:  # the loop must not die: pause and show why
            return self._fail(exc, rate)
        elapsed = time.perf_counter() - start
        step = self._snap.step + 1
        self._mean_time += STEP_TIME_WEIGHT * (elapsed - self._mean_time)
        if self._avoid is not None and (recorder is not None or step % DISTANCE_EVERY == 0):
            self._closest = self._distance(q)
        if recorder is not None:
            position = self.robot.tool_pose(q)[:3, 3]
            recorder.add(q, position, result, self._closest)
        qd = np.asarray(result.dq, dtype=float) / self.robot.dt
        p = float(result.p) if result.moved else 0.0
        with self._lock:
            if self._q is not q:  # a reset or a replay came in meanwhile: drop this step
                return self._snap
            self._q_prev, self._q = q, np.array(result.q, dtype=float)
            self._snap = self._make_snapshot(
                step, qd, p, result.binding, result.status, self._mean_time, rate
            )
            return self._snap

    def _fail(self, exc: Exception, rate: float) -> Snapshot:
        """Pause, holding the robot where it is, and publish why."""
        with self._lock:
            self._paused, self._error = True, f"{type(exc).__name__}: {exc}"
            self._snap = self._make_snapshot(
                self._snap.step, np.zeros_like(self._snap.qd), 0.0, None, "error", 0.0, rate
            )
            return self._snap

    def _replay_tick(self, rate: float) -> Snapshot:
        replay, k = self._replay, self._replay_at
        assert replay is not None
        q_prev = self._q
        self._q = replay.q[k].copy()
        qd = (self._q - q_prev) / self.robot.dt
        binding = replay.binding[k] or None
        self._replay_at = k + 1
        if self._replay_at >= replay.steps:  # the end: hold the last row, paused
            self._replay, self._paused, self._q_prev = None, True, None
            self._target = self._task_value(self._q)
        self._snap = self._make_snapshot(
            k, qd, float(replay.p[k]), binding, replay.status[k] or "replay", 0.0, rate
        )
        return self._snap

    def _distance(self, q: FloatArray) -> tuple[float, str] | None:
        if self._avoid is None:
            return None
        distance, pair = self._avoid.closest(q)
        return float(distance), str(pair)

    def _task_value(self, q: FloatArray) -> FloatArray:
        pose = self.robot.tool_pose(q)
        return pose if self.robot.orientation else pose[:3, 3].copy()

    def _make_snapshot(
        self,
        step: int,
        qd: FloatArray,
        p: float,
        binding: Any,
        status: str,
        step_time: float,
        rate: float,
    ) -> Snapshot:
        recorder = self._recorder
        return Snapshot(
            step=step,
            q=self._q.copy(),
            qd=np.asarray(qd, dtype=float),
            p=p,
            binding=binding,
            status=status,
            step_time=step_time,
            rate=rate,
            target=np.array(self._target),
            paused=self._paused,
            replaying=self._replay is not None,
            recording=None if recorder is None else len(recorder.rows),
            closest=self._closest,
            error=self._error,
            settings=self._settings,
        )

    # ---- what a page (or a test) asks -------------------------------------------------------
    def snapshot(self) -> Snapshot:
        """The state after the latest step."""
        return self._snap

    def set_target(self, target: Any) -> None:
        """Command a new target: an xyz point [m], or a 4 x 4 pose for an arm with orientation.

        A pose given to a position task uses its translation; the planar arm's
        target lies in its plane (z is set to 0).

        Raises:
            ValueError: For a target of the wrong shape or with values a command cannot take
                (:func:`lpik.command.checked_target`).
        """
        value = checked_target(target)
        if value.shape not in ((3,), (4, 4)):
            raise ValueError(f"target: must be xyz (3,) or a pose (4, 4), got shape {value.shape}")
        if self.robot.orientation:
            if value.shape == (3,):
                pose = np.array(self._target)
                pose[:3, 3] = value
                value = pose
        else:
            value = value[:3, 3].copy() if value.shape == (4, 4) else value
            if self.robot.planar:
                value[2] = 0.0
        with self._lock:
            self._target = value

    def target(self) -> FloatArray:
        """The commanded target now (as :meth:`set_target` stored it)."""
        with self._lock:
            return np.array(self._target)

    def settings(self) -> Settings:
        """The settings in force."""
        return self._settings

    def change(self, **values: Any) -> Settings:
        """Change settings (``method``, ``v_max``, ``w_max``, ``lambda_bound``, ``qdd_max``).

        Raises:
            ValueError: For values the settings or the robot cannot take (nothing changes).
        """
        settings = self._settings.changed(**values)
        stepper = make_stepper(self.robot, settings)
        with self._lock:
            self._settings, self._stepper = settings, stepper
        return settings

    def pause(self, paused: bool = True) -> None:
        """Pause (or resume) stepping or a replay; resuming clears a step's error."""
        with self._lock:
            self._paused = paused
            if not paused:
                self._error = None
            self._snap = self._make_snapshot(
                self._snap.step,
                self._snap.qd,
                self._snap.p,
                self._snap.binding,
                self._snap.status,
                self._snap.step_time,
                self._snap.rate,
            )

    def reset(self) -> None:
        """Back to the start configuration and target, running; a recording goes on."""
        with self._lock:
            self._reset_state()

    # ---- recording and replay ---------------------------------------------------------------
    def start_recording(self) -> None:
        """Record every step from now on (:meth:`stop_recording` writes the CSV).

        Raises:
            ValueError: Without a record folder.
        """
        recording_path(self.record_dir, "check.csv")  # raises without a usable folder
        model = self.robot.model
        recorder = Recorder(
            self.robot.dt,
            tuple(model.joint_names),
            model.task_dim,
            2 if self.robot.planar else 3,
            self._avoid is not None,
        )
        with self._lock:
            self._recorder = recorder

    def stop_recording(self, name: str | None = None) -> Path:
        """Stop recording and write the CSV into the record folder; returns its path.

        Raises:
            ValueError: When not recording, for a bad name, or a file that cannot be written.
        """
        path = recording_path(self.record_dir, name)
        with self._lock:
            recorder, self._recorder = self._recorder, None
            q = self._q.copy()
        if recorder is None:
            raise ValueError("record: not recording")
        return recorder.write(path, q, self.robot.tool_pose(q)[:3, 3])

    def replay(self, name: str) -> Replay:
        """Replay a CSV of the record folder, one row per control period.

        Raises:
            ValueError: For a name outside the folder, or a CSV that is not a run of this arm.
        """
        path = recording_path(self.record_dir, name)
        replay = read_replay(path, self.robot.model.n_joints)
        with self._lock:
            self._replay, self._replay_at, self._paused, self._error = replay, 0, False, None
        return replay

    def status(self) -> Mapping[str, Any]:
        """The latest snapshot as plain values (for logs and tests)."""
        s = self._snap
        return {
            "step": s.step,
            "p": s.p,
            "binding": s.binding,
            "status": s.status,
            "q": s.q.tolist(),
            "paused": s.paused,
        }
