"""The benchmark's workload: the same robot, configurations and targets for every library.

A workload is a set of short closed-loop trajectories of one arm (a bundled
one by name, or any URDF's chain: :class:`ArmFile`) with a 6-D pose task. Each
trajectory starts at a seeded configuration drawn uniformly from the middle of
every joint's range and heads for the pose of another seeded configuration.
Every step's target is the current pose moved towards that goal by at most
``TARGET_FRACTION`` of the command clamp (``v_max dt`` linear, ``w_max dt``
angular), so no library clamps or rescales it and every library is asked for
the same displacement ``dw``. The next configuration is the current one plus
the step of :func:`trajectory_controller` (LP2, ``M = I``, end-stops, velocity
and acceleration limits), so consecutive steps are related as in a control
loop fed its own commands: HiGHS can warm-start, the implied previous motion
``q - q_prev`` is one the drives could have made (a workload made without
acceleration limits jumps from rest to full speed in one step, and every
acceleration-limited library then answers a state no loop of its own reaches),
and limits bind where the motion takes the arm to them.

:func:`arm_only_urdf` gives the peers the arm's URDF with every joint off
the base-to-tip chain fixed (the Panda's fingers), so that every library
solves for the same n joints.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lpik.robots.arm import Arm, bundled_arm, urdf_arm
from lpik.robots.registry import urdf_path
from lpik.robots.rotations import exp_so3, log_so3
from lpik.robots.tasks import PoseTask

if TYPE_CHECKING:
    from lpik.control.controller import Lp2Controller

FloatArray = NDArray[np.float64]

#: Control period of the benchmark's steps [s] (a 1 kHz loop).
DT = 1e-3
#: Command clamp of lpik's controller: linear [m/s] and angular [rad/s] speed.
V_MAX = 0.5
W_MAX = 1.0
#: Symmetric joint acceleration limit of lpik's acceleration case [rad/s^2].
QDD_MAX = 10.0
#: Largest target offset as a fraction of the clamp, so that no library rescales it.
TARGET_FRACTION = 0.5
#: Fraction of each joint's range (centred) that start and goal configurations come from.
RANGE_FRACTION = 0.8


@dataclass(frozen=True)
class ArmFile:
    """An arm read from any URDF file (``lpik bench --urdf FILE --tip LINK [--base LINK]``).

    Attributes:
        urdf: Path of the URDF file.
        tip_link: The link of the task point.
        base_link: The link whose frame is the world frame; the URDF's root link when None.
    """

    urdf: str
    tip_link: str
    base_link: str | None = None


def bench_arm(robot: str | ArmFile) -> tuple[Arm, Path]:
    """The arm ``robot`` names and its URDF file.

    A bundled arm's name gives that arm (:func:`lpik.robots.arm.bundled_arm`);
    an :class:`ArmFile` the file's chain (:func:`lpik.robots.arm.urdf_arm`).

    Raises:
        ValueError: Unknown robot; an unreadable URDF, unknown link or no chain.
    """
    if isinstance(robot, ArmFile):
        return urdf_arm(robot.urdf, robot.tip_link, robot.base_link), Path(robot.urdf)
    return bundled_arm(robot), urdf_path(robot)


@dataclass(frozen=True, eq=False)
class Workload:
    """Steps of one arm that every library solves.

    Attributes:
        robot: The arm as :func:`make_workload` was given it: a bundled arm's
            name or an :class:`ArmFile`.
        name: The arm's name (the bundled name, or the URDF's robot name).
        model: lpik's 6-D pose task of the robot.
        q: Configurations, shape (N, n) [rad].
        q_prev: Configuration one period before each, shape (N, n) [rad]
            (equal to ``q`` at the start of a trajectory: at rest).
        targets: Commanded poses, shape (N, 4, 4) [m].
        dt: Control period [s].
        v_max: lpik's linear command clamp [m/s].
        w_max: lpik's angular command clamp [rad/s].
        qdd_max: Acceleration limit of lpik's acceleration case [rad/s^2].
        seed: Seed of the configurations.
    """

    robot: str | ArmFile
    name: str
    model: PoseTask
    q: FloatArray
    q_prev: FloatArray
    targets: FloatArray
    dt: float
    v_max: float
    w_max: float
    qdd_max: float
    seed: int

    def __len__(self) -> int:
        return int(self.q.shape[0])

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q.shape[1])

    @property
    def tip_link(self) -> str:
        """URDF link of the task point."""
        return self.model.kinematics.tip_link

    @property
    def base_link(self) -> str:
        """URDF link whose frame is the world frame."""
        return self.model.kinematics.base_link

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Chain joint names, in the order of ``q``."""
        return tuple(self.model.joint_names)

    def describe(self) -> str:
        """One line: robot, steps, period, limits."""
        return (
            f"{self.name}, 6-D pose task, {len(self)} steps of {self.dt * 1e3:g} ms "
            f"(seed {self.seed}); targets within {TARGET_FRACTION:g} x (v_max dt, w_max dt) "
            f"= ({TARGET_FRACTION * self.v_max * self.dt * 1e3:g} mm, "
            f"{TARGET_FRACTION * self.w_max * self.dt * 1e3:g} mrad)"
        )


def step_target(pose: FloatArray, goal: FloatArray, linear: float, angular: float) -> FloatArray:
    """``pose`` moved towards ``goal`` by at most ``linear`` [m] and ``angular`` [rad].

    The translation moves along ``goal - pose`` and the rotation along
    ``log(R_goal R^T)``, each shortened on its own, so that lpik's
    ``difference(pose, target)`` is exactly the (shortened) pair.
    """
    dp = goal[:3, 3] - pose[:3, 3]
    dr = log_so3(goal[:3, :3] @ pose[:3, :3].T)
    lin, ang = float(np.linalg.norm(dp)), float(np.linalg.norm(dr))
    if lin > linear:
        dp = dp * (linear / lin)
    if ang > angular:
        dr = dr * (angular / ang)
    out = np.eye(4)
    out[:3, :3] = exp_so3(dr) @ pose[:3, :3]
    out[:3, 3] = pose[:3, 3] + dp
    return out


def trajectory_controller(
    model: PoseTask, dt: float = DT, qdd_max: float | None = QDD_MAX
) -> Lp2Controller:
    """The controller whose steps make the workload's trajectories, and that ``full step +acc``
    times: the paper's LP2 (``saturate=False``; the rows say "lp2"), its strict step
    (``on_stall=None``, which the runs check against the LP), lpik's command clamp, and
    ``qdd_max`` [rad/s^2] (None: without acceleration limits, ``full step``'s controller).

    Timed over the workload in its order, the acceleration-limited one answers each state
    with the step that led to the next: a loop fed its own commands.
    """
    from lpik.control.controller import Lp2Controller

    return Lp2Controller(model, dt=dt, v_max=V_MAX, w_max=W_MAX, qdd_max=qdd_max,
                         saturate=False, on_stall=None)  # fmt: skip


def make_workload(
    robot: str | ArmFile = "panda",
    *,
    trajectories: int = 8,
    steps: int = 500,
    seed: int = 0,
    dt: float = DT,
) -> Workload:
    """Seeded trajectories of ``robot`` (see the module docstring).

    Args:
        robot: A bundled arm's name, or an :class:`ArmFile`.
        trajectories: Number of trajectories.
        steps: Steps per trajectory.
        seed: Seed of the start and goal configurations.
        dt: Control period [s].

    Raises:
        ValueError: Unknown robot or bad URDF (:func:`bench_arm`), or fewer than one
            trajectory or step.
    """
    if trajectories < 1 or steps < 1:
        raise ValueError("trajectories, steps: must be >= 1")
    arm, _ = bench_arm(robot)
    model = arm.task("pose")
    controller = trajectory_controller(model, dt)
    rng = np.random.default_rng(seed)
    lo, hi = model.q_min, model.q_max
    mid, half = 0.5 * (lo + hi), 0.5 * RANGE_FRACTION * (hi - lo)
    linear = TARGET_FRACTION * V_MAX * dt
    angular = TARGET_FRACTION * W_MAX * dt
    qs, prevs, targets = [], [], []
    for _ in range(trajectories):
        q = rng.uniform(mid - half, mid + half)
        goal = model.pose(rng.uniform(mid - half, mid + half))
        prev = q.copy()
        for _ in range(steps):
            target = step_target(model.pose(q), goal, linear, angular)
            qs.append(q)
            prevs.append(prev)
            targets.append(target)
            result = controller.step(q, target, prev)
            prev, q = q, result.q
    return Workload(
        robot=robot,
        name=arm.name,
        model=model,
        q=np.array(qs),
        q_prev=np.array(prevs),
        targets=np.array(targets),
        dt=dt,
        v_max=V_MAX,
        w_max=W_MAX,
        qdd_max=QDD_MAX,
        seed=seed,
    )


def arm_only_urdf(robot: str | ArmFile) -> str:
    """The arm's URDF text (:func:`bench_arm`) with every joint off its chain made fixed.

    Limits, mimic tags and axes of those joints are dropped; the chain's joints
    are unchanged, so every library sees the same n joints with the same limits.
    """
    arm, urdf = bench_arm(robot)
    keep = set(arm.chain.joint_names)
    root = ET.parse(urdf).getroot()
    for joint in root.iter("joint"):
        if joint.get("name") in keep or joint.get("type") == "fixed":
            continue
        joint.set("type", "fixed")
        for child in list(joint):
            if child.tag in ("limit", "mimic", "axis", "dynamics", "safety_controller"):
                joint.remove(child)
    return ET.tostring(root, encoding="unicode")
