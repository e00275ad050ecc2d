"""lpik inside a Pinocchio setup: your model and configuration, Pinocchio's kinematics.

    python examples/pinocchio_loop.py

``PinocchioChain`` wraps a ``pinocchio.Model`` (here built from the bundled
Panda's URDF) between a base frame and a tip frame; joints off that chain (the
fingers) are locked. ``read_q`` / ``write_q`` map the chain's joints to and from
the full model's configuration, so the rest of your code keeps its own ``q``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from _common import steps

from lpik import Lp2Controller
from lpik.robots.pinocchio_adapter import PinocchioChain
from lpik.robots.registry import home_configuration, urdf_path

model = pin.buildModelFromUrdf(str(urdf_path("panda")))
data = model.createData()
chain = PinocchioChain(model, tip_link="panda_hand")  # velocity limits from the model
print(f"chain joints at q{chain.q_index.tolist()}; locked: {', '.join(chain.held_joints)}")

q_full = pin.neutral(model)
chain.write_q(home_configuration("panda"), q_full)
controller = Lp2Controller(chain, dt=0.001, qdd_max=20.0)  # a chain alone: its pose task
goal = controller.model.pose(chain.read_q(q_full))
goal[:3, :3] = goal[:3, :3] @ pin.rpy.rpyToMatrix(0.0, 0.0, 0.5)  # turn the hand 0.5 rad
goal[:3, 3] += [0.0, 0.1, 0.0]
q_prev = chain.read_q(q_full)
for _ in range(steps(1500)):
    q = chain.read_q(q_full)
    result = controller.step(q, goal, q_prev)
    chain.write_q(result.q, q_full)
    q_prev = q

pin.framesForwardKinematics(model, data, q_full)  # Pinocchio's own answer for the hand
hand = data.oMf[model.getFrameId("panda_hand")]
error = pin.log6(pin.SE3(goal[:3, :3], goal[:3, 3]).inverse() * hand).vector
print(f"pose error |[v; w]| = {np.linalg.norm(error):.2e}, last p = {result.p:.3f}")
