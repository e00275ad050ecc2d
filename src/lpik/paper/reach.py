"""``lpik simulate reach``: from the home configuration straight to a point, orientation held.

On a bundled 3-D arm (pose task) the target is the home pose with its
position moved to the point: the tool point moves straight toward it at
``v_max`` (:data:`lpik.command.DEFAULT_V_MAX`) with the orientation
held. On the paper's planar arm (:data:`~lpik.paper.scenarios.PLANAR`; the
position task) the start is the paper's ``q0`` and the target an (x, y) point.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX, checked_target
from lpik.paper.scenarios import PLANAR, PaperArm, Setup
from lpik.robots.arm import Arm, as_arm
from lpik.robots.planar import planar_arm

#: Default steps of a reach run (10 s at ``dt``).
REACH_STEPS = 1000
#: Control period of a reach run [s].
REACH_DT = 0.01


def reach_setup(robot: str | Arm, target: Sequence[float]) -> Setup:
    """The run toward ``target`` on ``robot`` (see the module docstring).

    Args:
        robot: :data:`~lpik.paper.scenarios.PLANAR`, a bundled arm's name or an
            :class:`~lpik.robots.arm.Arm` (a URDF's).
        target: The point [m]: x, y, z (a planar arm takes x, y, or z = 0).

    Raises:
        ValueError: For an unknown robot or a target that is not a finite point.
    """
    point = np.asarray(target, dtype=np.float64).reshape(-1)
    if point.size not in (2, 3) or not np.isfinite(point).all():
        raise ValueError(f"--target: must be 3 finite numbers X,Y,Z [m], got {list(target)}")
    try:
        checked_target(point)  # none too large in size
    except ValueError as exc:
        raise ValueError(f"--{exc}") from None  # the command line's name, --target
    if robot == PLANAR:
        if point.size == 3 and point[2] != 0.0:
            raise ValueError("--target: the planar arm moves in the plane z = 0")
        arm = PaperArm(q_min=(-np.pi,) * 4, q_max=(np.pi,) * 4, target=(point[0], point[1]))
        model = planar_arm(arm.link_lengths, arm.q_min, arm.q_max, arm.qd_max, name="planar-reach")
        n = model.n_joints
        return Setup(
            name="reach", robot=robot, model=model, q0=np.array(arm.q0),
            target=np.array([point[0], point[1], 0.0]), v_max=DEFAULT_V_MAX,
            w_max=DEFAULT_W_MAX, dt=REACH_DT, steps=REACH_STEPS,
            weights={"M": np.ones(n), "f": np.zeros(n), "Lambda": np.zeros(n)},
        )  # fmt: skip
    if point.size != 3:
        raise ValueError(f"--target: a 3-D arm needs X,Y,Z [m], got {list(target)}")
    arm = as_arm(robot)
    model, q0 = arm.task("pose"), arm.home.copy()
    pose = np.array(model.kinematics.fk(q0), dtype=np.float64)  # type: ignore[attr-defined]
    pose[:3, 3] = point
    n = model.n_joints
    return Setup(
        name=f"reach {arm.name}", robot=arm.name, model=model, q0=q0, target=pose,
        v_max=DEFAULT_V_MAX, w_max=DEFAULT_W_MAX, dt=REACH_DT, steps=REACH_STEPS,
        weights={"M": np.ones(n), "f": np.zeros(n)},
    )  # fmt: skip
