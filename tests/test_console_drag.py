"""The target gizmo works by mouse: a drag in headless Chromium moves the target, the arm follows.

The test sets the page's camera (through viser's client handle) to look down
near the target and waits until the page reports it, projects a point of the
gizmo's x arrow to the screen with that camera (viser's camera frame is
OpenCV's: x right, y down, z forward; ``fov`` is vertical), and drags it 1 m
towards the base with ``page.mouse``. Only the page's own events move the
target: nothing is set through Python. Skipped, with the reason, where
Playwright or Chromium is missing (as ``test_console_browser``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from console_browser import browser_problem, chromium, open_console  # noqa: E402

PROBLEM = browser_problem()
pytestmark = pytest.mark.skipif(PROBLEM is not None, reason=f"no browser test: {PROBLEM}")

#: The camera's offset from the target [m] (above it, towards -y), and where it looks: right
#: of the target, so that the drag runs left of the page's panel (on the right).
CAMERA_OFFSET, LOOK_AT = (0.3, -0.8, 1.6), (0.3, 0.0, 0.0)
#: The point of the gizmo's x arrow that is grabbed, as a share of the gizmo's scale.
GRAB_AT = 0.6
#: The page's size [px]: small, since its WebGL renders in software.
VIEW = (800, 500)
#: How far the drag moves the target along -x [m].
DRAG = 1.0
#: The arm has followed when the tool is this share of the way from the target, or closer.
FOLLOWED = 0.2
#: How long [s] the page and the loop may take to answer: generous, since the whole suite
#: runs beside it on two cores (the camera once took over 10 s there); a wait that ends
#: early costs nothing.
PATIENCE = 30.0


def _wait(condition: Callable[[], object], timeout: float) -> bool:
    """Whether ``condition()`` came true within ``timeout`` s."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return bool(condition())


def _camera(console) -> object:
    """The one page's camera handle, once the page has reported its camera."""

    def reported() -> list:
        clients = list(console.server.get_clients().values())
        return [c for c in clients if c.camera.update_timestamp]

    assert _wait(reported, PATIENCE), "the page never reported its camera"
    return reported()[0].camera


def _aim(camera, position: np.ndarray, look_at: np.ndarray) -> None:
    """Set the page's camera, and wait until the page reports it has taken it."""
    camera.position = position
    camera.look_at = look_at
    sent = camera.update_timestamp

    def taken() -> bool:
        return camera.update_timestamp > sent and np.allclose(
            [camera.position, camera.look_at], [position, look_at], atol=1e-4
        )

    assert _wait(taken, PATIENCE), "the page did not take the camera"


def _canvas_box(page) -> list[float]:
    """x, y, width, height [px] of the 3-D view: the page's largest canvas."""
    return page.evaluate(
        """() => {
        const canvases = [...document.querySelectorAll('canvas')];
        const c = canvases.reduce((a, b) => a.width * a.height >= b.width * b.height ? a : b);
        const r = c.getBoundingClientRect();
        return [r.x, r.y, r.width, r.height];
    }"""
    )


def _screen(camera, box: list[float], point: np.ndarray) -> tuple[float, float]:
    """Where ``point`` [m] shows on the page [px]: the camera's pinhole projection."""
    import viser.transforms as tf

    in_camera = tf.SO3(np.asarray(camera.wxyz)).as_matrix().T @ (point - camera.position)
    focal = box[3] / 2 / np.tan(camera.fov / 2)
    return (
        box[0] + box[2] / 2 + focal * in_camera[0] / in_camera[2],
        box[1] + box[3] / 2 + focal * in_camera[1] / in_camera[2],
    )


def _drag(page, start: tuple[float, float], end: tuple[float, float], steps: int = 1) -> None:
    page.mouse.move(*start)
    page.mouse.down()
    for k in range(1, steps + 1):
        page.mouse.move(start[0] + (end[0] - start[0]) * k / steps,
                        start[1] + (end[1] - start[1]) * k / steps)  # fmt: skip
    page.mouse.up()


def test_dragging_the_gizmo_moves_the_target_and_the_arm_follows() -> None:
    from lpik.console import console_robot
    from lpik.console.app import Console

    with Console(console_robot("planar"), port=0) as console, chromium() as browser:
        page = open_console(browser, console.url, width=VIEW[0], height=VIEW[1])
        loop, robot = console.loop, console.loop.robot
        home = np.asarray(loop.target(), dtype=float)
        camera = _camera(console)
        _aim(camera, home + np.asarray(CAMERA_OFFSET), home + np.asarray(LOOK_AT))
        grab = home + [GRAB_AT * console.view.gizmo.scale, 0.0, 0.0]
        box = _canvas_box(page)
        _drag(page, _screen(camera, box, grab), _screen(camera, box, grab - [DRAG, 0.0, 0.0]))

        goal = home - [DRAG, 0.0, 0.0]
        assert _wait(lambda: np.linalg.norm(loop.target() - goal) < 0.1, PATIENCE), (
            f"the drag did not move the target: {loop.target()} (from {home}, to about {goal})"
        )
        target = np.asarray(loop.target(), dtype=float)
        assert target[1:] == pytest.approx(home[1:]), "a drag along x moved y or z"

        def tool() -> np.ndarray:
            return robot.tool_pose(loop.snapshot().q)[:3, 3]

        start = np.linalg.norm(home - target)  # the tool was at home when the drag began
        assert _wait(lambda: np.linalg.norm(tool() - target) < FOLLOWED * start, PATIENCE), (
            f"the arm did not follow: tool at {tool()}, target {target}, from {home}"
        )
        assert page.errors == []
