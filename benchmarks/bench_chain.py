"""Per-call time of the built-in chain's forward kinematics and Jacobian.

Prints, for each bundled robot, the median and 99th percentile of the wall
time of one call [us] over many calls at random configurations:

    .venv/bin/python benchmarks/bench_chain.py [--calls N] [--json]

``fk`` is ``SerialChain.fk(q)`` (task-frame pose), ``jacobian`` is
``SerialChain.jacobian(q)`` (world-aligned geometric Jacobian, which includes
the forward kinematics it needs). When Pinocchio is installed, its
``framesForwardKinematics`` and ``computeFrameJacobian`` on the same URDF are
timed too, for reference. A 1 kHz loop has 1000 us per step.
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from lpik.robots.registry import ROBOTS, load_chain, robot_names, urdf_path


def per_call_us(fn, configurations: np.ndarray) -> tuple[float, float]:
    """Median and 99th percentile of one call's wall time [us]."""
    for q in configurations[:200]:
        fn(q)
    times = np.empty(len(configurations))
    clock = time.perf_counter_ns
    for i, q in enumerate(configurations):
        start = clock()
        fn(q)
        times[i] = clock() - start
    return float(np.median(times) / 1e3), float(np.percentile(times, 99) / 1e3)


def pinocchio_calls(name: str):
    """Pinocchio's fk and Jacobian of the robot's task frame, or None when not installed."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    model = pin.buildModelFromUrdf(str(urdf_path(name)))
    data = model.createData()
    frame = model.getFrameId(ROBOTS[name].tip_link)
    n = load_chain(name).n_joints
    base = pin.neutral(model)

    def full(q: np.ndarray) -> np.ndarray:
        q_pin = base.copy()
        q_pin[:n] = q
        return q_pin

    def fk(q: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(model, data, full(q))
        return data.oMf[frame].homogeneous

    def jac(q: np.ndarray) -> np.ndarray:
        return pin.computeFrameJacobian(model, data, full(q), frame, pin.LOCAL_WORLD_ALIGNED)

    return fk, jac


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=20000, help="timed calls per function")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = parser.parse_args()
    rows = []
    for name in robot_names():
        chain = load_chain(name)
        rng = np.random.default_rng(0)
        qs = rng.uniform(chain.q_min, chain.q_max, size=(args.calls, chain.n_joints))
        row = {"robot": name, "n": chain.n_joints}
        row["fk"] = per_call_us(chain.fk, qs)
        row["jacobian"] = per_call_us(chain.jacobian, qs)
        row["fk_jacobian"] = per_call_us(chain.fk_jacobian, qs)
        reference = pinocchio_calls(name)
        if reference is not None:
            row["pinocchio_fk"] = per_call_us(reference[0], qs)
            row["pinocchio_jacobian"] = per_call_us(reference[1], qs)
        rows.append(row)
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    print(
        f"{platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}; "
        f"{args.calls} calls each; times in microseconds"
    )
    keys = [k for k in rows[0] if k not in ("robot", "n")]
    print(f"{'robot':<8} {'n':>2}  " + "  ".join(f"{k + ' med/p99':>24}" for k in keys))
    for row in rows:
        cells = "  ".join(f"{row[k][0]:>11.1f} /{row[k][1]:>11.1f}" for k in keys)
        print(f"{row['robot']:<8} {row['n']:>2}  {cells}")


if __name__ == "__main__":
    main()
