"""The paper's planar 4-link arm: the pull-in scenario, LP2 against the joint 1 end-stop.

    python examples/planar_arm_paper.py

The end effector is pulled in horizontally while joint 1 may not pass 95 deg.
LP2 follows until joint 1 reaches its end-stop; from then on p falls to 0 and
the binding limit says why. ``lpik reproduce`` draws all of section 4.
"""

from __future__ import annotations

import numpy as np
from _common import out_dir, steps

from lpik import ClampedTarget, planar_arm, simulate, standard_limits

arm = planar_arm(
    [1.0, 1.0, 1.0, 1.0],
    q_min=np.deg2rad([-180, -180, -180, -180]),
    q_max=np.deg2rad([95, 180, 180, 180]),
    qd_max=1.0,  # [rad/s]: the step's bound is qd_max * dt, derived by lpik
)
q0 = np.deg2rad([60.0, -30.0, -30.0, -30.0])
command = ClampedTarget(np.array([0.2, 0.8660, 0.0]), v_max=0.5)  # pull in along x
log = simulate(arm, command, q0, steps(400), method="lp2", dt=0.01,
               limits=standard_limits(arm))  # fmt: skip

first = next((k for k, b in enumerate(log.binding) if b is not None), None)
if first is not None:
    b = log.binding[first]
    print(f"t = {log.t[first]:.2f} s: p = {log.p[first]:.3f}, bound by {b} "
          f"(kind {b.kind}, joint index {b.index})")  # fmt: skip
print(f"final p = {log.p[-1]:.3f}, joint 1 = {np.rad2deg(log.q_end[0]):.2f} deg")
path = log.to_csv(out_dir() / "pull-in-lp2.csv")  # the `lpik simulate` CSV
print(f"wrote {path}")
