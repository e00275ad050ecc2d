"""lpik driving a MuJoCo scene: read the arm's joints from qpos, step, write them back.

    python examples/mujoco_scene.py

The scene is the bundled Panda compiled by MuJoCo (your own MJCF or URDF goes
the same way). ``MujocoChain`` uses MuJoCo's own kinematics; its public joint
map (``qpos_index``, ``read_qpos``, ``write_qpos``) touches only the chain's
joints, so the fingers (``held_joints``) stay as the scene has them. MuJoCo
keeps no velocity limits, so they are given explicitly.
"""

from __future__ import annotations

import mujoco
import numpy as np
from _common import steps

from lpik import Lp2Controller
from lpik.robots.mujoco_adapter import MujocoChain, kinematic_urdf
from lpik.robots.registry import home_configuration, urdf_path
from lpik.robots.tasks import PoseTask

model = mujoco.MjModel.from_xml_string(kinematic_urdf(urdf_path("panda").read_text()))
data = mujoco.MjData(model)
chain = MujocoChain(model, tip_link="panda_hand", qd_max=[2.0] * 7)  # [rad/s]
print(f"chain joints at qpos{chain.qpos_index.tolist()}; held: {', '.join(chain.held_joints)}")

chain.write_qpos(home_configuration("panda"), data.qpos)
data.qpos[chain.qpos_index[-1] + 1 :] = 0.03  # open the fingers: lpik leaves them alone
mujoco.mj_forward(model, data)

task = PoseTask(chain)
controller = Lp2Controller(task, dt=0.002, qdd_max=20.0)  # compiled LP2, MuJoCo's kinematics
goal = task.pose(chain.read_qpos(data.qpos))
goal[:3, 3] += [0.1, -0.15, -0.1]  # 20 cm away
q_prev = chain.read_qpos(data.qpos)
for _ in range(steps(1500)):  # 3 s
    q = chain.read_qpos(data.qpos)
    result = controller.step(q, goal, q_prev)
    chain.write_qpos(result.q, data.qpos)  # kinematic control: the joints go where LP2 says
    mujoco.mj_forward(model, data)
    q_prev = q

hand = data.body("panda_hand").xpos
print(f"hand at {np.round(hand, 4).tolist()}, {1000 * np.linalg.norm(hand - goal[:3, 3]):.2f} mm "
      f"from the goal; fingers still at {data.qpos[7:9].round(3).tolist()}")  # fmt: skip
