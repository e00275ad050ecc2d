"""Your own URDF in a 1 kHz loop, with every limit: end-stops, velocity, acceleration, multipliers.

    python examples/own_urdf_1khz.py

The arm below is a 4-joint URDF written inline (use a path to your file the
same way). The loop follows a moving target for 2 s at 1 kHz with the compiled
LP2 step and reports how much of the command it followed (p) and which limit
stopped it when it could not.
"""

from __future__ import annotations

import collections

import numpy as np
from _common import steps

from lpik import Lp2Controller, load_urdf

URDF = """<robot name="my_arm">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="tool"/>
  <joint name="shoulder_yaw" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-2.9" upper="2.9" velocity="2.0" effort="1"/></joint>
  <joint name="shoulder_pitch" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-1.8" upper="1.8" velocity="2.0" effort="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0 0.4"/><axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="0.2" velocity="2.5" effort="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="l3"/><child link="tool"/>
    <origin xyz="0 0 0.35"/><axis xyz="0 1 0"/>
    <limit lower="-2.0" upper="2.0" velocity="3.0" effort="1"/></joint>
</robot>"""

# load_urdf gives a SerialChain: end-stops and velocity limits come from the URDF.
chain = load_urdf(URDF, tip_link="tool")
# The controller takes the chain itself (its pose task) or a task of lpik.robots.tasks;
# here a position task: the arm has 4 joints, so 3 position rows leave it redundant.
from lpik import make_task  # noqa: E402

task = make_task(chain, "position")
controller = Lp2Controller(
    task,
    dt=0.001,  # 1 kHz: the command is a per-step displacement of at most v_max * dt
    v_max=0.5,  # [m/s]
    qdd_max=15.0,  # acceleration limits [rad/s^2], one number for every joint
    lambda_bound=5.0,  # |lambda_i| <= 5: smooth motion near singularities (sec. 3.2)
)

q = np.array([0.0, 0.3, -1.2, 0.5])
q_prev = q.copy()  # at rest
out = np.empty_like(q)
start = task.pose(q)
bindings: collections.Counter[str] = collections.Counter()
p_sum = 0.0
n_steps = steps(2000)
for k in range(n_steps):
    t = k * 0.001
    # a target that moves 0.4 m away and back; its far end is beyond what the limits allow
    target = start + np.array([0.4 * np.sin(np.pi * t / 2.0), 0.0, 0.0])
    # step_into writes q into `out` and returns p, allocating nothing: the tightest loop
    p = controller.step_into(q, target, q_prev, out=out)
    p_sum += p
    if controller.last_binding is not None:
        # a Binding is its label; .kind, .name, .side say what it names
        b = controller.last_binding
        bindings[f"{b.name} {b.side} {b.kind}"] += 1
    q_prev, q = q, out.copy()

print(f"{n_steps} steps, mean p = {p_sum / n_steps:.3f}")
for label, count in bindings.most_common(4):
    print(f"  {count:5d} steps bound by {label}")
