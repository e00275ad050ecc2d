"""Lp2Controller over Pinocchio and MuJoCo: the compiled step with the backend's kinematics.

Every step is held to the numpy layers over the same backend (build_problem +
lp2) and to the fused step over lpik's own chain; the joint maps are held to
the backends' own ``qpos`` / ``q``.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from robot_cases import random_configurations

from lpik.methods import solve
from lpik.robots.registry import ROBOTS, home_configuration, load_chain, urdf_path
from lpik.robots.tasks import PoseTask, as_task_model

pytest.importorskip("numba")
from lpik.control.controller import Lp2Controller  # noqa: E402


def _backends() -> list[tuple[str, object]]:
    spec = ROBOTS["panda"]
    out: list[tuple[str, object]] = []
    try:
        from lpik.robots.pinocchio_adapter import PinocchioChain

        out.append(("pinocchio", PinocchioChain.from_urdf(urdf_path("panda"), spec.tip_link)))
    except ImportError:
        pass
    try:
        from lpik.robots.mujoco_adapter import MujocoChain

        out.append(("mujoco", MujocoChain.from_urdf(urdf_path("panda"), spec.tip_link)))
    except ImportError:
        pass
    return out


BACKENDS = _backends()


@pytest.mark.parametrize(("name", "backend"), BACKENDS, ids=[b[0] for b in BACKENDS])
def test_the_backend_step_equals_the_numpy_layers_and_lpik_s_own_chain(name, backend) -> None:  # type: ignore[no-untyped-def]
    chain = load_chain("panda")
    options = {"dt": 0.01, "qdd_max": 20.0, "lambda_bound": 5.0, "v_max": 1.0}
    fast = Lp2Controller(PoseTask(backend), **options)
    own = Lp2Controller(PoseTask(chain), **options)
    rng = np.random.default_rng(5)
    kinds = set()
    for q0 in random_configurations(chain, 60, seed=17):
        prev = q0 - rng.uniform(-1, 1, 7) * chain.qd_max * 0.01 * rng.integers(0, 2)
        target = own.model.pose(q0)
        target[:3, 3] += rng.normal(0, 0.05, 3)
        got = fast.step(q0, target, prev)
        ref = solve(fast.problem(q0, target, prev), fast.method)
        assert got.path == "compiled" or got.path == ref.path
        assert (got.status, got.binding) == (ref.status, ref.binding)
        np.testing.assert_allclose(got.q, ref.q, atol=1e-9, rtol=0)
        assert abs(got.p - ref.p) <= 1e-9
        twin = own.step(q0, target, prev)
        np.testing.assert_allclose(got.q, twin.q, atol=1e-8, rtol=0)
        kinds.add(None if got.binding is None else got.binding.kind)
    assert len(kinds) >= 2, kinds
    batch = fast.step_batch(np.array([q0, q0]), np.array([target, target]))
    np.testing.assert_allclose(batch.q[0], fast.step(q0, target).q, atol=1e-12, rtol=0)


@pytest.mark.parametrize(("name", "backend"), BACKENDS, ids=[b[0] for b in BACKENDS])
def test_the_automatic_bound_over_a_backend_is_the_fused_chain_s(name, backend) -> None:  # type: ignore[no-untyped-def]
    """The default bound, applied in Python over a backend (its probe needs the backend's
    kinematics), at and near the Panda's singular configurations: the fused chain's steps,
    within J's rounding times its condition number; step_into and the batch as step."""
    from lpik_bench.singular import singular_workload

    work = singular_workload(bases=1, seed=3)
    fast = Lp2Controller(PoseTask(backend), dt=1e-3, v_max=0.5, w_max=1.0)
    own = Lp2Controller(PoseTask(load_chain("panda")), dt=1e-3, v_max=0.5, w_max=1.0)
    bounded, out = 0, np.empty(7)
    for q, prev, target in zip(work.q, work.q_prev, work.targets):
        got, twin = fast.step(q, target, prev), own.step(q, target, prev)
        assert (got.status, got.binding) == (twin.status, twin.binding)
        s = np.linalg.svd(own.model.jacobian(q), compute_uv=False)
        tol = 1e-13 * s[0] / s[-1] + 1e-10
        assert abs(got.p - twin.p) <= tol
        np.testing.assert_allclose(got.q, twin.q, atol=tol, rtol=0)
        assert fast.step_into(q, target, prev, out=out) == got.p
        np.testing.assert_array_equal(out, got.q)
        bounded += own._out.item(own._bounded_at) == 1.0
    assert bounded > 0
    batch = fast.step_batch(work.q, work.targets, work.q_prev)
    for b in range(len(work)):
        fast.reset()  # a batch row is an independent state: no stall stage's band before it
        ref = fast.step(work.q[b], work.targets[b], work.q_prev[b])
        assert (batch.status_of(b), batch.binding_of(b), batch.p[b]) == (ref.status, ref.binding,
                                                                         ref.p)  # fmt: skip
        np.testing.assert_array_equal(batch.q[b], ref.q)


@pytest.mark.parametrize(("name", "backend"), BACKENDS, ids=[b[0] for b in BACKENDS])
def test_a_chain_alone_is_its_pose_task_and_bad_input_is_named(name, backend) -> None:  # type: ignore[no-untyped-def]
    controller = Lp2Controller(backend, dt=0.001)
    assert controller.model.task_dim == 6 and isinstance(as_task_model(backend), PoseTask)
    q = home_configuration("panda")
    with pytest.raises(ValueError, match="q0: contains NaN"):
        controller.step(np.full(7, np.nan), np.eye(4))
    with pytest.raises(ValueError, match="q0: must have length 7"):
        controller.step(np.zeros(3), np.eye(4))
    res = controller.step(list(q), PoseTask(backend).pose(q).tolist())  # lists converted
    assert (res.p, res.status, res.binding) == (1.0, "optimal", None)


def test_a_bare_serial_chain_is_accepted_by_the_controller_and_simulate() -> None:
    from lpik.command import ClampedTarget
    from lpik.control.simulate import simulate
    from lpik.robots.planar import planar_chain

    chain = load_chain("panda")
    q = np.clip(np.zeros(7), chain.q_min, chain.q_max)
    goal = chain.fk(q)
    goal[:3, 3] += [0.02, 0.0, 0.0]
    assert Lp2Controller(chain, dt=0.01).step(q, goal).p == 1.0
    log = simulate(chain, ClampedTarget(goal), q, 3, dt=0.01)
    assert log.q.shape == (3, 7)
    planar = as_task_model(planar_chain([1.0, 1.0, 1.0]))
    assert planar.task_dim == 2 and planar.row_names == ("x", "y")
    with pytest.raises(ValueError, match="expected a task model .* or a chain"):
        simulate("panda", ClampedTarget(goal), q, 3, dt=0.01)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="model: expected a task model"):
        Lp2Controller(object(), dt=0.01)  # type: ignore[arg-type]


def test_joint_maps_read_and_write_only_the_chain() -> None:
    mujoco = pytest.importorskip("mujoco")
    from lpik.robots.mujoco_adapter import MujocoChain, kinematic_urdf

    model = mujoco.MjModel.from_xml_string(kinematic_urdf(urdf_path("panda").read_text()))
    chain = MujocoChain(model, tip_link="panda_hand", qd_max=2.0)
    assert chain.held_joints == ("panda_finger_joint1", "panda_finger_joint2")
    data = mujoco.MjData(model)
    data.qpos[:] = np.arange(model.nq) * 0.01
    q = chain.read_qpos(data.qpos)
    np.testing.assert_array_equal(q, data.qpos[chain.qpos_index])
    fingers = data.qpos[[7, 8]].copy()
    chain.write_qpos(q + 0.1, data.qpos)
    np.testing.assert_array_equal(data.qpos[[7, 8]], fingers)
    mujoco.mj_kinematics(model, data)  # the simulator's own pose of the hand = lpik's
    hand = model.body("panda_hand").id
    np.testing.assert_allclose(chain.fk(q + 0.1)[:3, 3], data.xpos[hand], atol=1e-12)
    with pytest.raises(ValueError, match="qpos: expected shape"):
        chain.read_qpos(np.zeros(3))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = MujocoChain(model, tip_body="panda_hand", qd_max=2.0)
    assert old.joint_names == chain.joint_names and caught[0].category is DeprecationWarning


def test_pinocchio_from_urdf_takes_text_and_maps_its_q() -> None:
    pin = pytest.importorskip("pinocchio")
    from lpik.robots.pinocchio_adapter import PinocchioChain

    text = urdf_path("panda").read_text()
    chain = PinocchioChain.from_urdf(text, tip_link="panda_hand")
    full = pin.buildModelFromXML(text)
    q_full = pin.randomConfiguration(full)
    q = chain.read_q(q_full)
    data = full.createData()
    pin.framesForwardKinematics(full, data, q_full)
    hand = data.oMf[full.getFrameId("panda_hand")].homogeneous
    np.testing.assert_allclose(chain.fk(q), hand, atol=1e-12)
    out = pin.neutral(full)
    chain.write_q(q, out)
    np.testing.assert_allclose(chain.read_q(out), q, atol=1e-15)
    with pytest.raises(ValueError) as info:
        PinocchioChain.from_urdf("<robot name='x'><link name='a'/><joint/></robot>", "a")
    assert len(str(info.value)) < 300 and "\n" not in str(info.value)


def test_a_joint_the_chain_cannot_move_is_refused_with_the_fix() -> None:
    mujoco = pytest.importorskip("mujoco")
    from lpik.robots.mujoco_adapter import MujocoChain

    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body name="cart"><freejoint name="float"/><geom size=".1"/>'
        '<body name="l1"><joint name="j1" type="hinge" axis="0 0 1"/><geom size=".1"/>'
        '<body name="tip" pos="1 0 0"><geom size=".1"/></body></body></body></worldbody>'
        "</mujoco>"
    )
    with pytest.raises(ValueError, match="'float' is a ball or free joint .* base_link="):
        MujocoChain(model, tip_link="tip", qd_max=1.0)
    arm = MujocoChain(model, tip_link="tip", base_link="cart", qd_max=1.0)
    assert arm.joint_names == ("j1",) and arm.held_joints == ("float",)
    np.testing.assert_allclose(arm.fk(np.array([np.pi / 2]))[:3, 3], [0.0, 1.0, 0.0], atol=1e-12)


def test_fk_jacobian_equals_lpik_s_chain_with_an_inner_base_and_a_tool() -> None:
    """The one-pass kinematics the backend step uses, on every joint type, a base inside the
    model and a tool offset: equal to lpik's own chain (an independent implementation)."""
    from robot_cases import MIXED_URDF

    from lpik.robots.urdf import load_urdf

    tool = (0.01, -0.03, 0.12, 0.2, 0.0, -0.4)
    chain = load_urdf(MIXED_URDF, "tool", base_link="l1", tool=tool)
    adapters = []
    if BACKENDS and any(name == "pinocchio" for name, _ in BACKENDS):
        from lpik.robots.pinocchio_adapter import PinocchioChain

        adapters.append(PinocchioChain.from_urdf(MIXED_URDF, "tool", "l1", tool))
    if any(name == "mujoco" for name, _ in BACKENDS):
        from lpik.robots.mujoco_adapter import MujocoChain

        no_float = MIXED_URDF.replace(
            '<joint name="float" type="floating"><origin xyz="0 0 0.1" rpy="0 0 0"/>'
            '<parent link="l2"/><child link="branch"/><axis xyz="0 0 1"/></joint>',
            "",
        ).replace('<link name="branch"/>', "")
        adapters.append(MujocoChain.from_urdf(no_float, "tool", "l1", tool))
    if not adapters:
        pytest.skip("neither Pinocchio nor MuJoCo is installed")
    for adapter in adapters:
        for q in random_configurations(chain, 30, seed=4):
            pose, jac = adapter.fk_jacobian(q)
            np.testing.assert_allclose(pose, chain.fk(q), atol=1e-10)
            np.testing.assert_allclose(jac, chain.jacobian(q), atol=1e-10)
