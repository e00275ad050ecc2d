"""The compiled step for a task model whose kinematics lpik cannot compile (Pinocchio, MuJoCo).

:class:`~lpik.control.controller.Lp2Controller` fuses a
:class:`~lpik.robots.chain.SerialChain`'s forward kinematics into its one
compiled call (:func:`lpik.fast.step.chain_step`). Any other backend of
:class:`~lpik.robots.tasks.Kinematics` (a Pinocchio or MuJoCo model, or your
own) computes the task frame and the world-aligned Jacobian (eqs. 1-2) itself;
:class:`BackendKinematicsStep` writes them into the controller's state buffer
and runs the rest of the step compiled (:func:`lpik.fast.step.chain_step`, its
state's ``chain`` block 0: the command, the limits of eqs. 13-14 and sec. 3.2,
LP2's ratio test of eqs. 15-18). The answers equal those of the numpy layers over the same backend
(tests hold them equal).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from lpik.fast import layout
from lpik.fast.command_law import held_at, needs_previous
from lpik.fast.step import (
    BAD_INPUT,
    TARGET_AXES,
    chain_step_batch,
    step_kernel,
)
from lpik.robots.base import TaskModel
from lpik.robots.chain import SerialChain
from lpik.types import FloatArray

#: A compiled-step callable: ``(state, q0, q_prev, target) -> outcome code``.
StepKernel = Callable[[FloatArray, FloatArray, FloatArray, FloatArray], int]
#: A batch runner: ``(state, Q0, Q_prev, targets, outs, codes, chunks) -> None``.
BatchRunner = Callable[..., None]


def _pose_and_jacobian(kinematics: Any) -> Callable[[FloatArray], tuple[Any, Any]]:
    both = getattr(kinematics, "fk_jacobian", None)
    if both is not None:
        return both  # type: ignore[no-any-return]
    return lambda q: (kinematics.fk(q), kinematics.jacobian(q))


class BackendKinematicsStep:
    """The fused step's callable for a backend's own kinematics.

    Called as the compiled :func:`lpik.fast.step.chain_step` is, with
    C-contiguous float64 arrays (anything else raises ``TypeError``, which the
    controller answers by converting them): the backend's pose (4, 4) and
    Jacobian (6, n) at ``q0`` go into the ``frame`` and ``jacobian6`` blocks of
    ``state`` (and, where the command takes off the second-order term and the
    state does not hold them, those at ``q_prev`` into the ``prev_*`` blocks);
    :func:`lpik.fast.step.chain_step` does the rest (the state's ``chain``
    block is 0: it takes the kinematics from the state).

    Args:
        kinematics: The backend (anything with ``fk`` and ``jacobian``, and
            ``fk_jacobian`` when it can give both in one pass).
        state: A state buffer of the controller (:func:`lpik.fast.layout.pack`),
            for the blocks' places.
        target_axes: The targets' numbers of axes to compile the step for.
    """

    def __init__(
        self, kinematics: Any, state: FloatArray, target_axes: tuple[int, ...] = TARGET_AXES
    ) -> None:
        self.kinematics = kinematics
        self._both = _pose_and_jacobian(kinematics)
        self._n = int(state[layout.N])
        frame, jac = int(state[layout.FRAME]), int(state[layout.JACOBIAN6])
        self._frame = slice(frame, frame + 16)
        self._jacobian = slice(jac, jac + 6 * self._n)
        frame, jac = int(state[layout.PREV_FRAME]), int(state[layout.PREV_JACOBIAN6])
        self._prev_frame = slice(frame, frame + 16)
        self._prev_jacobian = slice(jac, jac + 6 * self._n)
        self._kernel = step_kernel(target_axes)  # its state's chain block is 0

    def __call__(self, state: FloatArray, q0: Any, q_prev: Any, target: Any) -> int:
        """One step: the backend's kinematics at ``q0``, then the compiled rest (its code)."""
        if type(q0) is not np.ndarray or q0.dtype != np.float64 or not q0.flags.c_contiguous:
            raise TypeError("q0: the step takes a C-contiguous float64 array")
        if q0.shape != (self._n,):
            return BAD_INPUT
        pose, jacobian = self._both(q0)  # NaN in q0: the compiled rest answers BAD_INPUT
        state[self._frame] = np.ravel(pose)
        state[self._jacobian] = np.ravel(jacobian)
        if (type(q_prev) is np.ndarray and q_prev.shape == q0.shape
                and needs_previous(state, q0, q_prev)):  # fmt: skip
            pose, jacobian = self._both(q_prev)  # the kinematics at q_prev, for the command
            state[self._prev_frame] = np.ravel(pose)
            state[self._prev_jacobian] = np.ravel(jacobian)
            held_at(state, q_prev)
        return int(self._kernel(state, q0, q_prev, target))

    def batch(
        self,
        state: FloatArray,
        q0: FloatArray,
        q_prev: FloatArray,
        targets: FloatArray,
        outs: FloatArray,
        codes: Any,
        chunks: int,
    ) -> None:
        """Every row of a batch, one after the other (the backend is not thread-safe)."""
        local = state.copy()
        for b in range(q0.shape[0]):
            codes[b] = self(local, q0[b], q_prev[b], targets[b])
            layout.copy_out(local, outs, b)


def fuses_kinematics(model: TaskModel) -> bool:
    """Whether the controller compiles ``model``'s kinematics into its step (a SerialChain)."""
    return isinstance(getattr(model, "kinematics", None), SerialChain)


def step_functions(
    model: TaskModel, state: FloatArray, target_axes: tuple[int, ...] = TARGET_AXES
) -> tuple[StepKernel, BatchRunner]:
    """The step and batch runner for ``model``: fused for a SerialChain, else the backend's.

    The step is compiled (or loaded from the disk cache) for targets of
    ``target_axes`` axes (:data:`lpik.fast.step.STEP_SIGNATURES`) only.
    """
    if fuses_kinematics(model):
        return step_kernel(target_axes), chain_step_batch
    runner = BackendKinematicsStep(model.kinematics, state, target_axes)  # type: ignore[attr-defined]
    return runner, runner.batch
