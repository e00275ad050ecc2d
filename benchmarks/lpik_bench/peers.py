"""Other libraries' differential-IK steps on the benchmark's robot, targets and limits.

One small adapter per peer, imported only when asked for; a peer that is not
installed (or fails to load the robot) is skipped with a note. Every adapter
loads the same arm-only URDF (:func:`lpik_bench.workload.arm_only_urdf`),
enforces the same end-stops and velocity limits as lpik's step and returns a
function ``step(q, target) -> dq``: one full control step from the joint
coordinates ``q`` [rad] towards the commanded pose ``target`` (4, 4) [m],
forward kinematics and Jacobian included, answered as the joint displacement
over one period ``dq = v dt`` [rad].

==========  =========================================  ===============================
peer        step                                       limits
==========  =========================================  ===============================
drake       ``DoDifferentialInverseKinematics``        position and velocity limits
            (MultibodyPlant from the URDF): QP, max    (``qdd_max``: and acceleration
            ``alpha`` with ``J v = alpha V``, then     limits, around the joint
            least-norm ``v``                           velocities of the last step)
pink        ``solve_ik`` with a ``FrameTask`` (QP:     ``ConfigurationLimit`` (gain 1),
            least squares on the SE(3) error), daqp    ``VelocityLimit``
            and quadprog
mink        ``solve_ik`` with a ``FrameTask``          ``ConfigurationLimit`` (gain 1),
            (MuJoCo loads the URDF), daqp              ``VelocityLimit``
rtb         ETS ``eval`` + ``jacob0``, ``angle_axis``  clipping of the step to the
            error, damped least squares                velocity and position limits
==========  =========================================  ===============================

The configuration-limit gains of pink and mink are set to 1 (their defaults,
0.5 and 0.95, would only let a joint cover part of the distance to its
end-stop per step), so that every library bounds ``q + dq`` by the same
end-stops.

A peer with acceleration limits (:attr:`PeerStep.qdd_max`, so far Drake's)
needs the arm's joint velocities: its step takes the joint coordinates of the
last step too, ``step(q, target, q_prev)``, and the velocities are
``(q - q_prev) / dt``.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lpik.types import FloatArray
from lpik_bench.workload import QDD_MAX, Workload, arm_only_urdf

#: ``step(q, target) -> dq``, or ``step(q, target, q_prev)`` with acceleration limits.
StepFn = Callable[..., FloatArray]

#: Peer names in the order they are tried, with the PyPI package that provides each.
PEER_PACKAGES: dict[str, str] = {
    "drake": "drake",
    "pink": "pin-pink",
    "mink": "mink",
    "rtb": "roboticstoolbox-python",
}

#: Damping of the Robotics Toolbox's damped-least-squares step: ``lambda^2`` added to
#: ``J J^T`` [m^2]. Small, so that away from singularities the step is the least-norm one.
RTB_DAMPING = 1e-6


@dataclass(frozen=True, eq=False)
class PeerStep:
    """One peer's full control step.

    Attributes:
        library: Peer name (a key of :data:`PEER_PACKAGES`).
        method: What it runs, e.g. ``"solve_ik daqp"``.
        step: ``step(q, target) -> dq`` (see the module docstring).
        fk: ``fk(q) -> (4, 4)`` pose of the task frame in the peer's model.
        version: Installed version of the peer's package.
        note: How the step is set up.
        qdd_max: The joint acceleration limit it holds [rad/s^2] (None: none);
            its step then needs ``q_prev``.
    """

    library: str
    method: str
    step: StepFn
    fk: Callable[[FloatArray], FloatArray]
    version: str
    note: str = ""
    qdd_max: Any = None


@dataclass(frozen=True)
class Skipped:
    """A peer that was not run, and why."""

    library: str
    reason: str


@dataclass
class PeerSet:
    """The peers that loaded and those that were skipped."""

    steps: list[PeerStep] = field(default_factory=list)
    skipped: list[Skipped] = field(default_factory=list)


def _version(library: str) -> str:
    try:
        return metadata.version(PEER_PACKAGES[library])
    except metadata.PackageNotFoundError:
        return "unknown"


def _order(indices: list[int]) -> NDArray[np.int64] | None:
    """Permutation from lpik's joint order into a peer's, or None when it is the identity."""
    order = np.array(indices, dtype=np.int64)
    return None if np.array_equal(order, np.arange(order.size)) else order


def _to_peer(q: FloatArray, order: NDArray[np.int64] | None, size: int) -> FloatArray:
    if order is None:
        return q
    out = np.zeros(size)
    out[order] = q
    return out


def _from_peer(v: FloatArray, order: NDArray[np.int64] | None) -> FloatArray:
    return v if order is None else v[order]


#: OSQP tolerances of the Drake step used to check that Drake's program equals LP2's
#: (the timed step keeps Drake's defaults).
DRAKE_TIGHT_OSQP = {"eps_abs": 1e-8, "eps_rel": 1e-8, "max_iter": 100_000}


def _drake_plant(workload: Workload) -> tuple[Any, Any, NDArray[np.int64] | None]:
    """A MultibodyPlant of the arm-only URDF welded at its base, its context and joint order."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(arm_only_urdf(workload.robot), "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(workload.base_link))
    plant.Finalize()
    order = _order([plant.GetJointByName(j).position_start() for j in workload.joint_names])
    return plant, plant.CreateDefaultContext(), order


def _drake_parameters(
    workload: Workload, order: NDArray[np.int64] | None, nq: int, tight: bool, qdd_max: Any
) -> Any:  # DifferentialInverseKinematicsParameters
    """Drake's parameters: time step, end-stops, velocity and (``qdd_max``) acceleration limits."""
    from pydrake.multibody.inverse_kinematics import DifferentialInverseKinematicsParameters

    model = workload.model
    params = DifferentialInverseKinematicsParameters(nq, nq)
    params.set_time_step(workload.dt)
    params.set_joint_position_limits(
        (_to_peer(model.q_min, order, nq), _to_peer(model.q_max, order, nq))
    )
    params.set_joint_velocity_limits(
        (_to_peer(-model.qd_max, order, nq), _to_peer(model.qd_max, order, nq))
    )
    if qdd_max is not None:  # one limit for every joint, or one per joint
        accel = np.broadcast_to(np.asarray(qdd_max, dtype=np.float64), model.q_min.shape).copy()
        params.set_joint_acceleration_limits(
            (_to_peer(-accel, order, nq), _to_peer(accel, order, nq))
        )
    if tight:
        from pydrake.solvers import OsqpSolver

        options = params.get_mutable_solver_options()
        for key, value in DRAKE_TIGHT_OSQP.items():
            options.SetOption(OsqpSolver().solver_id(), key, value)
    return params


def _per_joint(limit: Any) -> str:
    """A limit as text: one number, or one per joint (``1, 2, 3``)."""
    values = np.atleast_1d(np.asarray(limit, dtype=np.float64))
    return ", ".join(f"{v:g}" for v in values)


def drake_peer(workload: Workload, *, tight: bool = False, qdd_max: Any = None) -> list[PeerStep]:
    """Drake's ``DoDifferentialInverseKinematics`` on a MultibodyPlant of the URDF.

    Args:
        workload: The benchmark's workload.
        tight: Solve Drake's QP (OSQP) to :data:`DRAKE_TIGHT_OSQP` instead of
            Drake's default tolerances (for the agreement check, not for timing).
        qdd_max: Joint acceleration limit [rad/s^2], one or one per joint (None: none). With it the
            step is ``step(q, target, q_prev)``: the context's joint velocities
            are ``(q - q_prev) / dt``, and Drake's answer is taken whenever it
            returns joint velocities (kSolutionFound, and kStuck: a small
            ``alpha``, which under acceleration limits is every step of a
            far target), not only at kSolutionFound.
    """
    from pydrake.math import RigidTransform
    from pydrake.multibody.inverse_kinematics import (
        DifferentialInverseKinematicsStatus,
        DoDifferentialInverseKinematics,
    )

    dt = workload.dt
    plant, context, order = _drake_plant(workload)
    frame, world, nq = (
        plant.GetFrameByName(workload.tip_link),
        plant.world_frame(),
        plant.num_positions(),
    )
    params = _drake_parameters(workload, order, nq, tight, qdd_max)
    taken = {DifferentialInverseKinematicsStatus.kSolutionFound}
    if qdd_max is not None:
        taken.add(DifferentialInverseKinematicsStatus.kStuck)

    def step(q: FloatArray, target: FloatArray, q_prev: FloatArray | None = None) -> FloatArray:
        plant.SetPositions(context, _to_peer(q, order, nq))
        if qdd_max is not None:
            plant.SetVelocities(context, _to_peer((q - q_prev) / dt, order, nq))
        res = DoDifferentialInverseKinematics(plant, context, RigidTransform(target), frame, params)
        if res.status not in taken or res.joint_velocities is None:
            return np.full(q.size, np.nan)
        return _from_peer(res.joint_velocities, order) * dt

    def fk(q: FloatArray) -> FloatArray:
        plant.SetPositions(context, _to_peer(q, order, nq))
        return plant.CalcRelativeTransform(context, world, frame).GetAsMatrix4()

    note = (
        "pose target (RigidTransform); V = pose difference / dt; joint centering gain 0, "
        "so the null-space objective is the least-norm v"
    )
    method = "DoDifferentialInverseKinematics"
    if tight:
        method += " (OSQP eps 1e-8)"
        note += "; OSQP eps_abs = eps_rel = 1e-8"
    if qdd_max is not None:
        note += (
            f"; joint acceleration limits {_per_joint(qdd_max)} rad/s^2 "
            "(set_joint_acceleration_limits), "
            "joint velocities (q - q_prev) / dt in the context; kStuck's velocities taken too"
        )
    return [PeerStep("drake", method, step, fk, _version("drake"), note, qdd_max)]


def pink_peer(workload: Workload) -> list[PeerStep]:
    """The ``solve_ik`` of pink (Pinocchio model of the URDF) with daqp and with quadprog."""
    import pink
    import pinocchio as pin
    import qpsolvers
    from pink.limits import ConfigurationLimit, VelocityLimit
    from pink.tasks import FrameTask

    dt = workload.dt
    pmodel = pin.buildModelFromXML(arm_only_urdf(workload.robot))
    order = _order([pmodel.idx_qs[pmodel.getJointId(j)] for j in workload.joint_names])
    nq = pmodel.nq
    configuration = pink.Configuration(pmodel, pmodel.createData(), np.zeros(nq))
    task = FrameTask(workload.tip_link, position_cost=1.0, orientation_cost=1.0)
    limits = [ConfigurationLimit(pmodel, config_limit_gain=1.0), VelocityLimit(pmodel)]
    tip = workload.tip_link
    out = []
    for solver in ("daqp", "quadprog"):
        if solver not in qpsolvers.available_solvers:
            continue

        def step(q: FloatArray, target: FloatArray, solver: str = solver) -> FloatArray:
            configuration.update(_to_peer(q, order, nq))
            task.set_target(pin.SE3(target[:3, :3], target[:3, 3]))
            v = pink.solve_ik(
                configuration, [task], dt, solver=solver, limits=limits, safety_break=False
            )
            return _from_peer(v, order) * dt

        def fk(q: FloatArray) -> FloatArray:
            configuration.update(_to_peer(q, order, nq))
            return configuration.get_transform_frame_to_world(tip).homogeneous

        out.append(
            PeerStep(
                "pink",
                f"solve_ik {solver}",
                step,
                fk,
                _version("pink"),
                "FrameTask (position and orientation cost 1), damping 1e-12",
            )
        )
    if not out:
        raise ImportError("neither daqp nor quadprog is installed for qpsolvers")
    return out


def mink_peer(workload: Workload) -> list[PeerStep]:
    """The ``solve_ik`` of mink with daqp; MuJoCo loads the URDF."""
    import mink
    import mujoco

    from lpik.robots.mujoco_adapter import kinematic_urdf

    dt = workload.dt
    mmodel = mujoco.MjModel.from_xml_string(kinematic_urdf(arm_only_urdf(workload.robot)))
    order = _order([int(mmodel.joint(j).qposadr[0]) for j in workload.joint_names])
    nq = mmodel.nq
    configuration = mink.Configuration(mmodel, np.zeros(nq))
    task = mink.FrameTask(workload.tip_link, "body", position_cost=1.0, orientation_cost=1.0)
    velocities = dict(zip(workload.joint_names, (float(v) for v in workload.model.qd_max)))
    limits = [mink.ConfigurationLimit(mmodel, gain=1.0), mink.VelocityLimit(mmodel, velocities)]
    tip = workload.tip_link

    def step(q: FloatArray, target: FloatArray) -> FloatArray:
        configuration.update(_to_peer(q, order, nq))
        task.set_target(mink.SE3.from_matrix(target))
        v = mink.solve_ik(configuration, [task], dt, solver="daqp", limits=limits)
        return _from_peer(v, order) * dt

    def fk(q: FloatArray) -> FloatArray:
        configuration.update(_to_peer(q, order, nq))
        return configuration.get_transform_frame_to_world(tip, "body").as_matrix()

    return [
        PeerStep(
            "mink",
            "solve_ik daqp",
            step,
            fk,
            _version("mink"),
            "FrameTask (position and orientation cost 1), damping 1e-12",
        )
    ]


def _rtb_robot(text: str) -> Any:  # the Robotics Toolbox's Robot class
    """A Robotics Toolbox ``Robot`` read from URDF text."""
    import roboticstoolbox as rtb

    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "robot.urdf")
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        try:
            from roboticstoolbox.models.URDF.URDFRobot import URDF_read
        except ImportError:  # older toolboxes
            return rtb.Robot.URDF(path)
        links, name, _ = URDF_read(path)
        return rtb.Robot(links, name=name)


def rtb_peer(workload: Workload) -> list[PeerStep]:
    """The Robotics Toolbox: ETS forward kinematics and Jacobian, damped least squares."""
    import roboticstoolbox as rtb

    model, dt = workload.model, workload.dt
    robot = _rtb_robot(arm_only_urdf(workload.robot))
    ets = robot.ets(end=workload.tip_link)
    lo, hi = model.q_min, model.q_max
    vel = model.qd_max * dt
    damping = RTB_DAMPING * np.eye(6)
    angle_axis = rtb.angle_axis

    def step(q: FloatArray, target: FloatArray) -> FloatArray:
        e = angle_axis(ets.eval(q), target)
        J = ets.jacob0(q)
        dq = J.T @ np.linalg.solve(J @ J.T + damping, e)
        dq = np.clip(dq, -vel, vel)
        return np.clip(q + dq, lo, hi) - q

    return [
        PeerStep(
            "rtb",
            "DLS (jacob0)",
            step,
            ets.eval,
            _version("rtb"),
            f"dq = J^T (J J^T + {RTB_DAMPING:g} I)^-1 e, e = angle_axis error; limits by "
            "clipping dq to the velocity limits and q + dq to the end-stops",
        )
    ]


#: Adapter of each peer.
ADAPTERS: dict[str, Callable[[Workload], list[PeerStep]]] = {
    "drake": drake_peer,
    "pink": pink_peer,
    "mink": mink_peer,
    "rtb": rtb_peer,
}


#: The peers that take joint acceleration limits, set up with the benchmark's
#: :data:`~lpik_bench.workload.QDD_MAX` (the motion-quality suite's "+acc" peers).
ACCELERATION_ADAPTERS: dict[str, Callable[[Workload], list[PeerStep]]] = {
    "drake": lambda workload: drake_peer(workload, qdd_max=QDD_MAX),
}


def load_peers(
    workload: Workload,
    names: tuple[str, ...] = tuple(ADAPTERS),
    adapters: dict[str, Callable[[Workload], list[PeerStep]]] | None = None,
) -> PeerSet:
    """Every peer in ``names`` that imports and loads the robot; the others skipped with a note.

    A peer whose forward kinematics disagrees with lpik's at the workload's
    first configuration (by more than 1e-9) is skipped too: it would not be
    solving the same problem. ``adapters``: where the names are looked up
    (None: :data:`ADAPTERS`; :data:`ACCELERATION_ADAPTERS` for the peers with
    acceleration limits, where a name without an entry is passed over).
    """
    adapters = ADAPTERS if adapters is None else adapters  # read now: tests replace ADAPTERS
    peers = PeerSet()
    q, pose = workload.q[0], workload.model.pose(workload.q[0])
    for name in names:
        if name not in adapters:
            continue
        try:
            loaded = adapters[name](workload)
        except ImportError as exc:
            reason = f"not installed ({exc}); pip install {PEER_PACKAGES[name]}"
            peers.skipped.append(Skipped(name, reason))
            continue
        except Exception as exc:  # a broken peer must not stop the benchmark
            peers.skipped.append(Skipped(name, f"failed to load: {type(exc).__name__}: {exc}"))
            continue
        for peer in loaded:
            error = float(np.abs(peer.fk(q) - pose).max())
            if not error <= 1e-9:
                peers.skipped.append(
                    Skipped(name, f"{peer.method}: forward kinematics differs by {error:.3g}")
                )
            else:
                peers.steps.append(peer)
    return peers
