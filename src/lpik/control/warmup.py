"""The first controller starts at once: the numpy engine steps while a child process compiles.

numba compiles a controller's kernels (the fused step, the stall stage's LP) the
first time a process needs them and caches them on disk: about a minute of CPU
on an empty cache, after which every process loads them in well under a second.
A controller built with ``compile="background"`` (the default,
:data:`lpik.defaults.DEFAULT_COMPILE`) does not wait for that minute:

1. it loads its kernels from the disk cache when the cache has them
   (:func:`cached`, which never compiles), and is compiled from its first step;
2. otherwise it starts one child process (:class:`Warmup`, shared by the
   controllers of the process that need the same kernels) that compiles them
   into the cache, and takes its steps on the numpy engine
   (:class:`~lpik.control.stepper.Stepper`: the same answers, which the parity
   suite holds equal; each step some hundred microseconds instead of a few);
3. at the first step after the child is done, it loads the kernels (a fraction of a
   second, once) and is compiled from then on.

``compile="now"`` (or ``LPIK_COMPILE=now`` in the environment,
:data:`lpik.defaults.COMPILE_ENV`) compiles when the controller is built instead,
for a loop that must be compiled from its first step without a warm cache; paying
the compile at deployment with ``lpik compile`` serves both.

Run as ``python -m lpik.control.warmup AXES [STAGE ...]`` this module is the child:
it compiles the fused step for targets of ``AXES`` (``1``, ``2`` or ``1,2``) and the
named stages (``progress``, ``further``, ``recovery``, ``bound``), and exits 0.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from typing import Any

from numba import types

from lpik.defaults import COMPILE_ENV, COMPILE_MODES, DEFAULT_COMPILE
from lpik.fast.autobound import bound_in_state, floor_in_state
from lpik.fast.command_law import follow_in_state
from lpik.fast.commanded import (
    FOLLOW_SIGNATURE,
    HOLD_SIGNATURE,
    PLAUSIBLE_SIGNATURE,
    hold_step,
    plausible_previous,
)
from lpik.fast.progress import (
    further_stage,
    largest_share_lp,
    least_error_step,
    least_l1_in_state,
    stall_stage,
    state_rows,
)
from lpik.fast.signatures import load_cached
from lpik.fast.step import cached_step_kernel, step_kernel

_VECTOR, _MATRIX = types.float64[::1], types.float64[:, ::1]
#: Each stage's kernels beside the fused step, each with the one signature a controller
#: calls it with.
STAGES = {
    # on_stall (the stall stage's rule and its progress step, one call)
    "progress": (
        (
            stall_stage,
            ((_VECTOR,) * 4 + (types.float64,) + (types.boolean,) * 4 + (_VECTOR,) * 3),
        ),
        (floor_in_state, (_VECTOR,) * 3),  # the bound's floor as the progress step's row
        # the criterion stage: Ho's LP where LP2's conditions admit no step
        (least_l1_in_state, (_VECTOR,) * 5),
    ),
    "further": ((further_stage, (_VECTOR,) * 6),),  # mode="progress"'s second stage
    # under acceleration limits: the state's implied step against the commanded one
    # (lpik.control.commanded)
    "motion": (
        (plausible_previous, PLAUSIBLE_SIGNATURE),
        (hold_step, HOLD_SIGNATURE),
        (follow_in_state, FOLLOW_SIGNATURE),  # the target's motion after a corrected q_prev
    ),
    # the automatic multiplier bound's rule on the fused step's state, over a SerialChain
    "bound": ((bound_in_state, (_VECTOR,) * 3),),
    # a scene's recovery stage (lpik.collision.recovery.recovery_motion on the state's arrays)
    "recovery": (
        (least_error_step, (_MATRIX, *(_VECTOR,) * 3, _MATRIX, _VECTOR, _VECTOR)),
        (largest_share_lp, (_MATRIX, *(_VECTOR,) * 4)),
        (state_rows, (*(_VECTOR,) * 3, types.boolean, types.boolean)),
    ),
}


def compile_mode(value: str | None) -> str:
    """``value``, or the process's default (``LPIK_COMPILE``, else ``"background"``), checked."""
    mode = value if value is not None else os.environ.get(COMPILE_ENV) or DEFAULT_COMPILE
    if mode not in COMPILE_MODES:
        source = "compile" if value is not None else COMPILE_ENV
        raise ValueError(f"{source}: must be one of {', '.join(COMPILE_MODES)}, got {mode!r}")
    return mode


def cached(target_axes: Sequence[int], stages: Sequence[str]) -> bool:
    """Whether every kernel is in this process or loads from the disk cache (compiles nothing)."""
    if cached_step_kernel(tuple(target_axes)) is None:
        return False
    return all(load_cached(*kernel) for stage in stages for kernel in STAGES[stage])


def compile_now(target_axes: Sequence[int], stages: Sequence[str]) -> None:
    """Compile (or load) the fused step for ``target_axes`` and each of ``stages``."""
    step_kernel(tuple(target_axes))
    for stage in stages:
        for kernel, signature in STAGES[stage]:
            kernel.compile(signature)


class Warmup:
    """The child process that compiles ``target_axes`` and ``stages`` into numba's disk cache.

    It runs in its own session, so that Ctrl-C in the terminal of a short script
    does not stop it halfway: it finishes filling the cache for the next run
    (a minute or so) and exits. Its messages go to a temporary file, read only
    when it fails.
    """

    def __init__(self, target_axes: Sequence[int], stages: Sequence[str]) -> None:
        self._log = tempfile.TemporaryFile()
        command = [sys.executable, "-m", "lpik.control.warmup",
                   ",".join(map(str, target_axes)), *stages]  # fmt: skip
        self.process = subprocess.Popen(command, stdin=subprocess.DEVNULL,
                                        stdout=subprocess.DEVNULL, stderr=self._log,
                                        start_new_session=True)  # fmt: skip

    def finished(self) -> bool:
        """Whether the child has exited (a non-blocking check)."""
        return self.process.poll() is not None

    def failure(self) -> str | None:
        """Why the finished child failed (the last line it wrote), or None if it did not."""
        if self.process.returncode in (None, 0):
            return None
        self._log.seek(0)
        lines = self._log.read().decode(errors="replace").strip().splitlines()
        tail = lines[-1] if lines else "no message"
        return f"the background compile exited with status {self.process.returncode}: {tail}"


_RUNNING: dict[tuple[Any, ...], Warmup] = {}


def warmup(target_axes: Sequence[int], stages: Sequence[str]) -> Warmup:
    """The child compiling these kernels: the one already running in this process, or a new one."""
    key = (tuple(sorted(target_axes)), tuple(sorted(stages)))
    running = _RUNNING.get(key)
    if running is None or (running.finished() and running.failure() is None):
        running = _RUNNING[key] = Warmup(*key)
    return running


def main(argv: Sequence[str]) -> int:
    """The child: compile the kernels ``argv`` names (``AXES [STAGE ...]``)."""
    axes = tuple(int(a) for a in argv[0].split(","))
    compile_now(axes, argv[1:])
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
