"""A batch sweep of the affine dexterity p over the planar arm's workspace, with a plot.

    python examples/dexterity_sweep.py

For a grid of configurations (joints 1 and 2 swept, joints 3 and 4 fixed), one
compiled batch call asks how much of a 1 cm pull towards the base each pose
can follow in one 10 ms step under the velocity limits (eq. 14) and end-stops
(eq. 13). The scatter plot colours each end-effector position by p.
"""

from __future__ import annotations

import numpy as np
from _common import out_dir, steps

from lpik import Lp2Controller, planar_arm

arm = planar_arm([1.0, 1.0, 1.0, 1.0], q_min=np.deg2rad([-180, -150, -150, -150]),
                 q_max=np.deg2rad([95, 150, 150, 150]), qd_max=1.0)  # fmt: skip
controller = Lp2Controller(arm, dt=0.01, v_max=1.0)

side = max(8, int(np.sqrt(steps(3600))))
q1, q2 = np.meshgrid(np.linspace(-1.5, 1.6, side), np.linspace(-2.5, 2.5, side))
q0 = np.column_stack([q1.ravel(), q2.ravel(), np.full(q1.size, -0.6), np.full(q1.size, -0.6)])
positions = np.array([arm.position(q) for q in q0])
pull = -0.01 * positions / np.linalg.norm(positions, axis=1, keepdims=True)  # 1 cm inwards
targets = np.column_stack([positions + pull, np.zeros(len(q0))])  # xyz, z = 0

batch = controller.step_batch(q0, targets)  # all rows at once, in parallel
print(f"{len(q0)} poses: p = 1 at {np.mean(batch.p == 1.0):.0%} of them, "
      f"median p {np.median(batch.p):.3f}")  # fmt: skip
kinds = [b.kind for b in batch.binding if b is not None]
for kind in sorted(set(kinds)):
    print(f"  bound by {kind}: {kinds.count(kind)} poses")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(5, 4.5))
dots = ax.scatter(positions[:, 0], positions[:, 1], c=batch.p, s=8, cmap="viridis", vmin=0, vmax=1)
fig.colorbar(dots, label="affine dexterity p")
ax.set(xlabel="x [m]", ylabel="y [m]", title="p of a 1 cm pull towards the base", aspect="equal")
path = out_dir() / "dexterity-sweep.png"
fig.savefig(path, dpi=120)
print(f"wrote {path}")
