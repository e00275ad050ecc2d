"""First-call cost in a fresh process: import, setup and the first step, each timed.

Run by :mod:`lpik_bench.runner` as ``python -m lpik_bench.firstcall WHAT ROBOT``
(``WHAT`` is ``lpik`` or a peer's name; ``ROBOT`` is a bundled arm's name, or
``URDF TIP [BASE]`` for an arm read from a URDF file, :func:`robot_argv`); prints
one JSON object with the phases in seconds. Only the standard library is imported before the clock
starts. For lpik, run it with ``NUMBA_CACHE_DIR`` pointing to an empty folder
to time a cold compile instead of loading the kernels from the disk cache.
"""

from __future__ import annotations

import json
import sys
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lpik_bench.workload import ArmFile


def robot_argv(robot: str | ArmFile) -> list[str]:
    """``ROBOT``'s words: a bundled arm's name, or an :class:`ArmFile`'s ``URDF TIP [BASE]``."""
    if isinstance(robot, str):
        return [robot]
    return [robot.urdf, robot.tip_link, *([robot.base_link] if robot.base_link else [])]


def lpik_phases(robot: list[str]) -> dict[str, float]:
    """Import, controller setup, first and second fused step, first batches (LP2, full steps).

    Args:
        robot: The arm's words (:func:`robot_argv`); it starts at its home configuration.
    """
    t0 = time.perf_counter()
    from lpik.control.controller import Lp2Controller
    from lpik.fast import lp2_batch
    from lpik.robots.arm import bundled_arm, urdf_arm

    t1 = time.perf_counter()
    arm = bundled_arm(robot[0]) if len(robot) == 1 else urdf_arm(*robot)
    model = arm.task("pose")
    controller = Lp2Controller(model, dt=1e-3, qdd_max=10.0)
    q = arm.home
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


def peer_phases(name: str, robot: list[str]) -> dict[str, float]:
    """A peer's import + model load, and its first and second step (lpik's workload untimed).

    Args:
        name: The peer's name (:data:`lpik_bench.peers.ADAPTERS`).
        robot: The arm's words (:func:`robot_argv`).
    """
    from lpik_bench.peers import ADAPTERS
    from lpik_bench.workload import ArmFile, make_workload

    arm = robot[0] if len(robot) == 1 else ArmFile(*robot)
    workload = make_workload(arm, trajectories=1, steps=2)
    t0 = time.perf_counter()
    peer = ADAPTERS[name](workload)[0]
    t1 = time.perf_counter()
    peer.step(workload.q[0], workload.targets[0])
    t2 = time.perf_counter()
    peer.step(workload.q[1], workload.targets[1])
    t3 = time.perf_counter()
    return {"setup_s": t1 - t0, "first_step_s": t2 - t1, "second_step_s": t3 - t2}


def main(argv: list[str]) -> int:
    """Print the phases of ``argv = [WHAT, *ROBOT]`` as JSON; exit status 0."""
    what, *robot = argv
    phases = lpik_phases(robot) if what == "lpik" else peer_phases(what, robot)
    print(json.dumps(phases))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
