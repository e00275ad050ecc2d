"""Where can the planar arm follow a fast outward pull? A batch sweep of p, plotted.

    python examples/dexterity_sweep.py

A grid of 3,600 poses of the paper's 4-link arm: joint 1 swept from -86 deg
up to its end-stop at 95 deg, joints 2-4 folded alike from 0 (stretched) to
69 deg. At every pose one compiled batch call asks how much of a 2 cm pull
straight away from the base the arm can follow in one 10 ms step (2 m/s),
under its end-stops (eq. 13) and velocity limits of 1 rad/s (eq. 14), once
with the paper's LP2 and once with LP2 with saturation in the null space
(lpik's default, ``lp2s``).

What the colours mean (each dot is the tool's position, coloured by p):

* yellow, p = 1: the whole 2 cm are followed; the arm is folded enough that
  its joints unfold the tool outwards at 2 m/s within 1 rad/s;
* the green-blue band: a velocity limit binds (e.g. ``joint 3 lower velocity
  limit``); p is the share of the 2 cm that joint's 1 rad/s allows;
* the dark outer rim: the arm is (nearly) stretched. Outward motion leaves
  the range of the Jacobian (the edge singularity): p = 0 at full stretch
  (``singularity``); just inside it the automatic multiplier bound holds the
  step (e.g. ``multiplier 1 lower bound``) rather than let the joints race;
* the dark inner edge, LP2 only: joint 1 sits at its end-stop of 95 deg and
  the pull needs it to turn further. LP2 stops there (p = 0,
  ``joint 1 upper end-stop``); LP2s fixes joint 1 at its end-stop and moves
  the others, so p comes back up to what their velocity limits allow.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
from _common import out_dir, steps

from lpik import Lp2Controller, planar_arm

arm = planar_arm([1.0, 1.0, 1.0, 1.0], q_min=np.deg2rad([-180, -150, -150, -150]),
                 q_max=np.deg2rad([95, 150, 150, 150]), qd_max=1.0)  # fmt: skip
DT, PULL = 0.01, 0.02  # a 10 ms step, 2 cm outwards: 2 m/s

side = max(8, int(np.sqrt(steps(3600))))
q1, fold = np.meshgrid(np.linspace(-1.5, arm.q_max[0], side), np.linspace(0.0, 1.2, side))
q0 = np.column_stack([q1.ravel(), fold.ravel(), fold.ravel(), fold.ravel()])
positions = np.array([arm.position(q) for q in q0])
outwards = positions / np.linalg.norm(positions, axis=1, keepdims=True)
targets = np.column_stack([positions + PULL * outwards, np.zeros(len(q0))])  # xyz, z = 0

p_of = {}
for method, saturate in (("lp2", False), ("lp2s", True)):
    controller = Lp2Controller(arm, dt=DT, v_max=PULL / DT, saturate=saturate)
    batch = controller.step_batch(q0, targets)  # all rows at once, in parallel
    p_of[method] = batch.p
    kinds = Counter(b.kind if b is not None else "none (p = 1)" for b in batch.binding)
    print(f"{method}: {len(q0)} poses, p from {batch.p.min():.2f} to {batch.p.max():.2f}, "
          f"p = 1 at {np.mean(batch.p >= 1.0):.0%}, median p {np.median(batch.p):.2f}")  # fmt: skip
    for kind, count in kinds.most_common():
        print(f"  bound by {kind}: {count} poses")

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), sharex=True, sharey=True)
titles = {"lp2": "LP2 (the paper): stops at\njoint 1's end-stop (inner edge)",
          "lp2s": "LP2s (lpik's default): joint 1 held,\nthe others carry on"}  # fmt: skip
for ax, (method, p) in zip(axes, p_of.items()):
    dots = ax.scatter(positions[:, 0], positions[:, 1], c=p, s=8, cmap="viridis", vmin=0, vmax=1)
    ax.plot(0, 0, "k+", markersize=10)  # the base
    ax.set(xlabel="x [m]", title=titles[method], aspect="equal")
axes[0].set_ylabel("y [m]")
fig.colorbar(dots, ax=axes, label="p of a 2 cm outward pull in 10 ms")
path = out_dir() / "dexterity-sweep.png"
fig.savefig(path, dpi=120)
print(f"wrote {path}")
