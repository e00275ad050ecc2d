"""Lp2Controller's steps beyond one fused call: a batch, and a step under the automatic bound."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import ArrayLike

from lpik.control.autobound import bound_for_step, decide
from lpik.control.backend_step import fuses_kinematics
from lpik.control.inputs import TARGET_SHAPES, stacked_rows
from lpik.fast import layout
from lpik.fast.batch import BatchResult
from lpik.fast.lp2_kernel import INFEASIBLE as KERNEL_INFEASIBLE
from lpik.fast.lp2_kernel import OK
from lpik.fast.singular_values import probe_singular_values
from lpik.fast.step import BAD_INPUT
from lpik.result import Result
from lpik.tolerances import FULL_P

if TYPE_CHECKING:
    from lpik.control.controller import Lp2Controller


def batch_steps(
    controller: Lp2Controller, q0: ArrayLike, targets: ArrayLike, q_prev: ArrayLike | None
) -> BatchResult:
    """``controller.step`` over the rows of ``q0``, ``targets`` and ``q_prev``, in parallel.

    The compiled batch kernel takes every row; rows it does not answer itself
    (from outside the limits, the HiGHS path, and under the automatic
    multiplier bound every row with ``p < 1``) are stepped again one by one.
    """
    n = controller._n
    Q0 = stacked_rows("q0", q0, ((n,),))
    B = Q0.shape[0]
    Qp = Q0 if q_prev is None else stacked_rows("q_prev", q_prev, ((n,),), B)
    T = stacked_rows("targets", targets, TARGET_SHAPES, B)
    outs = np.empty((B, controller._out.shape[0]))
    codes = np.empty(B, dtype=np.int64)
    controller._batch(controller._state, Q0, Qp, T, outs, codes, 4 * numba.get_num_threads())
    if (codes == BAD_INPUT).any():  # every row was checked: a bug if it happens
        raise ValueError(f"row {int(np.argmax(codes == BAD_INPUT))}: rejected by the step")
    q, dq = outs[:, controller._q].copy(), outs[:, controller._dq].copy()
    lam, p = outs[:, controller._lam].copy(), outs[:, controller._p].copy()
    labels = outs[:, controller._label_at].astype(np.int64)
    infeasible = codes == KERNEL_INFEASIBLE
    p[infeasible], lam[infeasible] = 0, np.nan  # q, dq: the kernel's safe step
    fallback: dict[int, Result] = {}
    outside = outs[:, controller._outside] >= 0
    # rows from outside the limits, those the HiGHS path takes, and (automatic
    # multiplier bound) those that may need a bound: one by one
    again = (codes != OK) & ~infeasible | outside
    if controller.automatic_bound is not None:
        again |= ~infeasible & (p < FULL_P)
    for b in np.nonzero(again)[0].tolist():
        res = controller.step(Q0[b], T[b], None if q_prev is None else Qp[b], watch=False)
        fallback[b] = res
        q[b], dq[b], p[b] = res.q, res.dq, res.p
        lam[b] = np.nan if res.lam is None else res.lam
    table = controller._labels
    return BatchResult(q=q, dq=dq, p=p, lam=lam, codes=codes, binding_codes=labels,
                       _labels=lambda b: table, _fallback=fallback)  # fmt: skip


def bounded_step(
    controller: Lp2Controller, q0: Any, target: Any, q_prev: Any, unbounded: Result
) -> Result:
    """``controller``'s step again under the automatic multiplier bound, where it applies.

    The rule is :func:`lpik.control.autobound.decide`'s; over a SerialChain the
    singular values come from the compiled
    :func:`lpik.fast.singular_values.probe_singular_values`, else from the
    numpy :func:`~lpik.control.autobound.bound_for_step`. The bound is written
    into the state's multiplier bounds for one compiled step (and into the
    problem :meth:`~lpik.control.controller.Lp2Controller.problem` builds, for
    its HiGHS path), then restored.
    """
    if not unbounded.moved:
        return unbounded
    c, q, auto = controller, np.asarray(q0, dtype=np.float64), controller.automatic_bound
    start = int(c._state[layout.JACOBIAN])  # the step's J, as the kernel left it
    J = c._state[start : start + c._m * c._n].reshape(c._m, c._n).copy()
    if fuses_kinematics(c.model):  # the singular values, compiled
        values = np.empty(3)
        probe_singular_values(c._state, q, unbounded.dq, auto.activation, auto.probe, values)
        bound = decide(auto, J, c._row_index, c.dt, tuple(values.tolist()))
    else:
        bound = bound_for_step(auto, c.model.jacobian, q, J, c._row_index, c.dt, unbounded)
    if bound is None:
        return unbounded
    block = layout.matrix_at(controller._state, layout.LAM_BOUNDS, 2, controller._m)
    saved = block.copy()
    block[0], block[1] = np.maximum(saved[0], -bound), np.minimum(saved[1], bound)
    controller._bound = bound
    try:
        return controller.step(q0, target, q_prev, watch=False)
    finally:
        block[...], controller._bound = saved, None
