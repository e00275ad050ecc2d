"""Following a timed trajectory under acceleration limits: a smooth reference, a stateful loop.

    python examples/trajectory_acceleration.py

The command law of lpik knows no time: each step moves toward the target given
to it. A timed reference is therefore sampled by the loop itself (here a
minimum-jerk move of 0.3 m in 1.5 s), and the controller is given the previous
configuration so that its acceleration limits hold between steps.
"""

from __future__ import annotations

import numpy as np
from _common import steps

from lpik import Lp2Controller, home_configuration, load_robot

panda = load_robot("panda", task="pose")
dt, duration = 0.002, 1.5
qdd_max = 8.0  # [rad/s^2]
controller = Lp2Controller(panda, dt=dt, v_max=1.0, qdd_max=qdd_max)


def min_jerk(s: float) -> float:
    """Smooth 0 -> 1 with zero velocity and acceleration at both ends."""
    s = min(max(s, 0.0), 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


q = home_configuration("panda")
q_prev = q.copy()
start = panda.pose(q)
goal_offset = np.array([0.0, 0.3, -0.1])
worst_error, worst_acc = 0.0, 0.0
n_steps = steps(int(duration / dt) + 250)
for k in range(n_steps):
    reference = start.copy()
    reference[:3, 3] += min_jerk(k * dt / duration) * goal_offset  # where we should be at t
    result = controller.step(q, reference, q_prev)
    acc = np.abs(result.q - 2 * q + q_prev).max() / dt**2
    worst_acc = max(worst_acc, acc)
    q_prev, q = q, result.q
    worst_error = max(worst_error, float(np.linalg.norm(panda.pose(q)[:3, 3] - reference[:3, 3])))

print(f"largest tracking error {1000 * worst_error:.2f} mm, "
      f"largest joint acceleration {worst_acc:.2f} rad/s^2 (limit {qdd_max})")  # fmt: skip
assert worst_acc <= qdd_max * (1 + 1e-6)
