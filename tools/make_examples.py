"""Write the bundled example problems of `lpik solve` from the paper's scenario data.

Run: .venv/bin/python tools/make_examples.py  (rewrites src/lpik/data/examples/*.json)
"""

import json
from pathlib import Path

import numpy as np

from lpik import (
    ClampedTarget,
    EndStops,
    MultiplierBounds,
    VelocityLimits,
    build_problem,
    planar_arm,
)

OUT = Path(__file__).resolve().parents[1] / "src" / "lpik" / "data" / "examples"


def step(arm, q0, target, limits, method, dt=0.01, v_max=0.5):
    """One step's problem document, with lpik's command law toward ``target`` (x, y)."""
    dw = ClampedTarget(np.append(target, 0.0), v_max)(arm, q0, dt)
    pb = build_problem(arm.jacobian(q0), dw, q0, limits, dt=dt)
    doc = {
        "method": method,
        "J": pb.J.tolist(),
        "dw": pb.dw.tolist(),
        "q0": pb.q0.tolist(),
        "q_min": [None if not np.isfinite(v) else v for v in pb.q_min],
        "q_max": [None if not np.isfinite(v) else v for v in pb.q_max],
        "dq_min": pb.dq_min.tolist(),
        "dq_max": pb.dq_max.tolist(),
    }
    if np.isfinite(pb.lam_max).any():
        doc["lam_min"], doc["lam_max"] = pb.lam_min.tolist(), pb.lam_max.tolist()
    return doc


def main():
    """Write every example problem."""
    OUT.mkdir(parents=True, exist_ok=True)
    arm = planar_arm([1, 1, 1, 1])
    deg = np.deg2rad
    vel = VelocityLimits(np.ones(4))
    # First step of the pull-in scenario, joint 1 already at its 95 deg end-stop.
    q_stop = deg(np.array([95.0, -60.0, -60.0, -60.0]))
    stops = EndStops(
        deg(np.array([-180, -180, -180, -180.0])), deg(np.array([95, 180, 180, 180.0]))
    )
    docs = {
        "pull-in-step": step(
            arm, deg(np.array([60.0, -30, -30, -30])), np.array([0.2, 0.8660]), [stops, vel], "lp2"
        ),
        "joint1-at-end-stop": step(arm, q_stop, np.array([0.2, 0.8660]), [stops, vel], "lp2"),
        "near-singularity-bounded": step(
            arm,
            deg(np.array([8.0, -1.0, -1.0, -1.0])),
            np.array([4.5, 0.3]),
            [stops, vel, MultiplierBounds.symmetric(0.01)],
            "lp2",
        ),
    }
    for name, doc in docs.items():
        (OUT / f"{name}.json").write_text(json.dumps(doc, indent=1) + "\n")
        print("wrote", OUT / f"{name}.json")


if __name__ == "__main__":
    main()
