"""First-call cost in a fresh process: import, setup and the first step, each timed.

Run by :mod:`lpik_bench.runner` as ``python -m lpik_bench.firstcall WHAT ROBOT``
(``WHAT`` is ``lpik`` or a peer's name); prints one JSON object with the
phases in seconds. Only the standard library is imported before the clock
starts. For lpik, run it with ``NUMBA_CACHE_DIR`` pointing to an empty folder
to time a cold compile instead of loading the kernels from the disk cache.
"""

from __future__ import annotations

import json
import sys
import time


def lpik_phases(robot: str) -> dict[str, float]:
    """Import, controller setup, first and second fused step, first batches (LP2, full steps)."""
    t0 = time.perf_counter()
    from lpik.control.controller import Lp2Controller
    from lpik.fast import lp2_batch
    from lpik.robots.registry import home_configuration, load_robot

    t1 = time.perf_counter()
    model = load_robot(robot, task="pose")
    controller = Lp2Controller(model, dt=1e-3, qdd_max=10.0)
    q = home_configuration(robot)
    target = model.pose(q)
    target[:3, 3] += 1e-4
    t2 = time.perf_counter()
    controller.step(q, target, q)
    t3 = time.perf_counter()
    controller.step(q, target, q)
    t4 = time.perf_counter()
    problems = [controller.problem(q, target)] * 8
    t5 = time.perf_counter()
    lp2_batch(problems, method="lp2")
    t6 = time.perf_counter()
    controller.step_batch(q[None], target[None], q[None])
    t7 = time.perf_counter()
    return {
        "import_s": t1 - t0,
        "setup_s": t2 - t1,
        "first_step_s": t3 - t2,
        "second_step_s": t4 - t3,
        "first_batch_s": t6 - t5,
        "first_step_batch_s": t7 - t6,
    }


def peer_phases(name: str, robot: str) -> dict[str, float]:
    """A peer's import + model load, and its first and second step (lpik's workload untimed)."""
    from lpik_bench.peers import ADAPTERS
    from lpik_bench.workload import make_workload

    workload = make_workload(robot, trajectories=1, steps=2)
    t0 = time.perf_counter()
    peer = ADAPTERS[name](workload)[0]
    t1 = time.perf_counter()
    peer.step(workload.q[0], workload.targets[0])
    t2 = time.perf_counter()
    peer.step(workload.q[1], workload.targets[1])
    t3 = time.perf_counter()
    return {"setup_s": t1 - t0, "first_step_s": t2 - t1, "second_step_s": t3 - t2}


def main(argv: list[str]) -> int:
    """Print the phases of ``argv = [WHAT, ROBOT]`` as JSON; exit status 0."""
    what, robot = argv
    phases = lpik_phases(robot) if what == "lpik" else peer_phases(what, robot)
    print(json.dumps(phases))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
