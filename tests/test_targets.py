"""A target must command every row of its task, on every way to take a step.

A point given to a pose task has no rotation: no path may make one up (the
identity would turn the hand over); each says so with a ValueError naming
``target``.
"""

from __future__ import annotations

import numpy as np
import pytest

from lpik.command import ClampedTarget
from lpik.control.simulate import simulate
from lpik.control.stepper import Stepper
from lpik.robots.registry import home_configuration, load_robot
from lpik.robots.tasks import make_task

PANDA = load_robot("panda")
HOME = home_configuration("panda")
POINT = np.array([0.5, 0.0, 0.4])


def _controller(model):  # type: ignore[no-untyped-def]
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller

    return Lp2Controller(model, dt=0.001)


def test_a_point_for_a_pose_task_is_refused_on_every_path() -> None:
    controller = _controller(PANDA)
    calls = {
        "Stepper.step": lambda: Stepper(PANDA, dt=0.001).step(HOME, POINT),
        "Lp2Controller.step": lambda: controller.step(HOME, POINT),
        "Lp2Controller.step_into": lambda: controller.step_into(HOME, POINT, out=np.empty(7)),
        "Lp2Controller.step_batch": lambda: controller.step_batch(np.tile(HOME, (3, 1)),
                                                                  np.tile(POINT, (3, 1))),
        "Lp2Controller.problem": lambda: controller.problem(HOME, POINT),
        "simulate": lambda: simulate(PANDA, ClampedTarget(POINT), HOME, 2, dt=0.001),
    }  # fmt: skip
    for name, call in calls.items():
        with pytest.raises(ValueError, match="^target: "):
            call()
        assert name


def test_a_rotation_for_a_task_with_position_rows_is_refused() -> None:
    controller = _controller(PANDA)
    with pytest.raises(ValueError, match="not a rotation: it has no position"):
        controller.step(HOME, np.eye(3))


@pytest.mark.parametrize(("kind", "target"), [("position", POINT), ("orientation", np.eye(3))])
def test_a_target_that_gives_every_row_is_taken(kind: str, target: np.ndarray) -> None:
    model = make_task(PANDA.kinematics, kind)
    controller = _controller(model)
    pose = np.eye(4)
    pose[:3, 3] = POINT
    for value in (target, pose):  # the part it needs, or a whole pose
        a = controller.step(HOME, value)
        b = Stepper(model, dt=0.001).step(HOME, value)
        assert a.status == b.status == "optimal"
        np.testing.assert_allclose(a.q, b.q, atol=1e-9, rtol=0)
