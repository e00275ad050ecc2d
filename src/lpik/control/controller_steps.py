"""Lp2Controller's steps beyond one fused call: a batch, the HiGHS path, the automatic bound.

Over a :class:`~lpik.robots.chain.SerialChain` the fused step applies the
automatic multiplier bound itself (:func:`lpik.fast.step.bounded_again`);
:func:`bounded_step` applies it where the step could not: over a backend's
kinematics (the rule's probe needs them) and after HiGHS took the unbounded step.
"""

from __future__ import annotations

from time import perf_counter
from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import ArrayLike

from lpik.control.backend_step import fuses_kinematics
from lpik.control.inputs import TARGET_SHAPES, stacked_rows
from lpik.fast import layout
from lpik.fast.autobound import bound_in_state, settings
from lpik.fast.batch import BatchResult
from lpik.fast.lp2_kernel import INFEASIBLE as KERNEL_INFEASIBLE
from lpik.fast.lp2_kernel import OK
from lpik.fast.step import BAD_INPUT
from lpik.limits import AutomaticMultiplierBounds
from lpik.methods.autobound import bound_for_step
from lpik.result import INFEASIBLE, RECOVERING, Result
from lpik.robots.base import TaskModel
from lpik.tolerances import FULL_P
from lpik.types import FloatArray

if TYPE_CHECKING:
    from lpik.control.controller import Lp2Controller


def not_optimal_step(
    c: Lp2Controller, code: int, q0: Any, target: Any, q_prev: Any, start: float
) -> Result:
    """The Result of a kernel outcome other than OK: infeasible, bad input or the HiGHS path.

    A step from outside the limits (``recovering``) and the kernel's safe step
    (``infeasible``) are read from the state's out blocks; bad input raises a
    ValueError naming it; anything else goes to :func:`highs_step`.
    """
    outside = int(c._out.item(c._outside))
    if code in (OK, KERNEL_INFEASIBLE):  # from outside the limits, or the safe step
        out, moved = c._out.copy(), code == OK
        label = outside if outside >= 0 else int(out.item(c._label_at))
        return Result.trusted(
            {
                "q": out[c._q],
                "dq": out[c._dq],
                "p": out.item(c._p) if moved else 0.0,
                "lam": out[c._lam] if moved else None,
                "status": RECOVERING if outside >= 0 else INFEASIBLE,
                "binding": c._labels[label].outside() if outside >= 0 else c._labels[label],
                "method": c.method,
                "solve_time": perf_counter() - start,
                "residual": out.item(c._residual),
                "path": "compiled",
            }
        )
    if code == BAD_INPUT:
        c._converted(q0, target, q_prev, check_finite=True)  # raises, naming the input
    return highs_step(c, q0, target, q_prev)


def batch_steps(
    controller: Lp2Controller, q0: ArrayLike, targets: ArrayLike, q_prev: ArrayLike | None
) -> BatchResult:
    """``controller.step`` over the rows of ``q0``, ``targets`` and ``q_prev``, in parallel.

    The compiled batch kernel takes every row; rows it does not answer itself
    (from outside the limits, the HiGHS path, and rows with ``p < 1`` where
    the automatic multiplier bound is applied outside the kernel) are stepped
    again one by one.
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
    # rows from outside the limits, those the HiGHS path takes, and those that may
    # need the automatic multiplier bound the kernel did not apply: one by one
    again = (codes != OK) & ~infeasible | outside
    if controller.automatic_bound is not None:
        again |= ~infeasible & (p < FULL_P) & (outs[:, controller._bounded_at] < 0)
    for b in np.nonzero(again)[0].tolist():
        res = controller.step(Q0[b], T[b], None if q_prev is None else Qp[b], watch=False)
        fallback[b] = res
        q[b], dq[b], p[b] = res.q, res.dq, res.p
        lam[b] = np.nan if res.lam is None else res.lam
    table = controller._labels
    return BatchResult(q=q, dq=dq, p=p, lam=lam, codes=codes, binding_codes=labels,
                       _labels=lambda b: table, _fallback=fallback)  # fmt: skip


def auto_bound_block(limit: AutomaticMultiplierBounds | None, model: TaskModel) -> FloatArray:
    """The state's ``auto_bound`` block: the fused step applies the rule over a SerialChain."""
    return settings(limit, fuses_kinematics(model))


def highs_step(controller: Lp2Controller, q0: Any, target: Any, q_prev: Any) -> Result:
    """The step by the HiGHS path, on its problem with the automatic bound it ran under, if any."""
    c = controller
    if c._bound is not None or c._out.item(c._bounded_at) <= 0:  # no bound, or bounded_step's
        return c._fallback(c.problem(q0, target, q_prev))
    c._bound = c._out[c._bound_at].copy()  # the fused step's (lpik.fast.step.bounded_again)
    try:
        return c._fallback(c.problem(q0, target, q_prev))
    finally:
        c._bound = None


def bounded_step(
    controller: Lp2Controller, q0: Any, target: Any, q_prev: Any, unbounded: Result
) -> Result:
    """``controller``'s step again under the automatic multiplier bound, where it applies.

    For the steps the fused step did not decide (module docstring). The rule
    is :func:`lpik.methods.autobound.automatic_bound`: compiled over a
    SerialChain (:func:`lpik.fast.autobound.bound_in_state`), else through
    the numpy :func:`~lpik.methods.autobound.bound_for_step`. The bound is
    written into the state's multiplier bounds for one compiled step (the
    step's own rule switched off, and into the problem
    :meth:`~lpik.control.controller.Lp2Controller.problem` builds, for its
    HiGHS path), then restored.
    """
    if not unbounded.moved:
        return unbounded
    c, q = controller, np.ascontiguousarray(q0, dtype=np.float64)
    if fuses_kinematics(c.model):  # the rule, compiled, on the step the state holds
        dq = np.ascontiguousarray(unbounded.dq, dtype=np.float64)
        found = bound_in_state(c._state, q, dq)
        bound = c._out[c._bound_at].copy() if found else None
    else:
        start = int(c._state[layout.JACOBIAN])  # the step's J, as the kernel left it
        J = c._state[start : start + c._m * c._n].reshape(c._m, c._n).copy()
        bound = bound_for_step(c.automatic_bound, c.model.jacobian, q, J, c._row_index, c.dt,
                               unbounded)  # fmt: skip
    if bound is None:
        return unbounded
    block = layout.matrix_at(c._state, layout.LAM_BOUNDS, 2, c._m)
    on = int(c._state[layout.AUTO_BOUND])
    saved, saved_on = block.copy(), c._state[on]
    block[0], block[1] = np.maximum(saved[0], -bound), np.minimum(saved[1], bound)
    c._state[on], c._bound = 0.0, bound
    try:
        return c.step(q0, target, q_prev, watch=False)
    finally:
        block[...], c._state[on], c._bound = saved, saved_on, None
