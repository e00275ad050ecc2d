"""The p of one step in each direction from a configuration, and the kind of limit that binds.

Every step is the one problem ``lpik solve`` solves for it:
``build_problem(J, speed * dt * twist, q, standard_limits(model,
lambda_bound=None), dt=dt)`` (eqs. 12-14: the end-stops and the velocity
limits of the arm, ``M = I``, ``f = 0``, no smoothing and no multiplier
bound), solved by LP1 (eqs. 11-14, HiGHS, :func:`lpik.methods.lp1.lp1`) or
by LP2 / LP2 with saturation (eqs. 15-18, the compiled batch,
:func:`lpik.fast.batch.lp2_batch`). The automatic multiplier bound that the
controller adds where an unbounded step races towards a singularity (sec.
3.2) is a property of a run, not of one step, and is not applied.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from lpik import labels
from lpik.fast.step import step_bounds
from lpik.types import FloatArray

#: The map's binding codes: -1 the pose is not reached, 0 no limit binds (p = 1),
#: ``1 + k`` the kind ``labels.KINDS[k]`` (end-stop, velocity, ..., singularity).
NOT_REACHED, NO_BINDING = -1, 0
#: The words of the binding codes from 0 on.
BINDING_WORDS = ("none", *labels.KINDS)


def binding_code(kind: str | None) -> int:
    """The map's code of a binding limit's kind (``None``: :data:`NO_BINDING`)."""
    return NO_BINDING if kind is None else 1 + labels.KINDS.index(kind)


@njit(cache=True)
def _bounds(limits, dt, q, lower, upper, kinds):
    """Each configuration's bounds on ``dq`` and which limit sets them (``step_bounds``)."""
    for b in range(q.shape[0]):
        step_bounds(limits, dt, q[b], q[b], lower[b], upper[b], kinds[b])


def step_limits(model: Any, q: FloatArray, dt: float) -> tuple[FloatArray, FloatArray, Any]:
    """Bounds on ``dq`` (P, n) at rest at the configurations ``q`` (P, n), their kinds (P, 2, n).

    The rule of :func:`lpik.limits.build_problem` (eqs. 13-14 by
    :mod:`lpik.bands`), compiled; kind 0 is an end-stop, 1 a velocity limit.
    """
    qd = np.asarray(model.qd_max, dtype=np.float64)
    inf = np.full(q.shape[1], np.inf)
    limits = np.stack([model.q_min, model.q_max, -qd, qd, -inf, inf]).astype(np.float64)
    P, n = q.shape
    lower, upper = np.empty((P, n)), np.empty((P, n))
    kinds = np.empty((P, 2, n), dtype=np.int64)
    _bounds(limits, float(dt), np.ascontiguousarray(q), lower, upper, kinds)
    return lower, upper, kinds


def lp2_steps(
    J: FloatArray, dw: FloatArray, q: FloatArray, bounds: tuple[Any, ...], method: str
) -> tuple[FloatArray, Any]:
    """The p (P, K) and binding codes of LP2 (``"lp2"``) or LP2 with saturation, in a batch.

    ``J`` (P, m, n) at the configurations ``q`` (P, n); ``dw`` (P, K, m) the
    steps; ``bounds``: :func:`step_limits`' answer.
    """
    from lpik.fast.batch import BatchArrays, lp2_batch

    P, K, m = dw.shape
    n = q.shape[1]
    lower, upper, kinds = bounds
    each = np.repeat(np.arange(P), K)
    H = np.broadcast_to(np.eye(n), (P * K, n, n))
    zeros_n = np.zeros((P * K, n))
    arrays = BatchArrays(
        J=J[each], dw=dw.reshape(P * K, m), H=H, c=zeros_n, lower=lower[each],
        upper=upper[each], lam_min=np.full((P * K, m), -np.inf),
        lam_max=np.full((P * K, m), np.inf), G=np.zeros((P * K, 0, n)), g=np.zeros((P * K, 0)),
        q0=q[each], h_diag=True, c_ref=zeros_n,
    )  # fmt: skip
    result = lp2_batch(arrays, method=method)
    codes = _kernel_codes(result.binding_codes, kinds[each], n, m)
    for i in np.flatnonzero(result.path != "compiled"):
        binding = result[int(i)].binding
        codes[i] = binding_code(None if binding is None else binding.kind)
    return result.p.reshape(P, K), codes.reshape(P, K)


def _kernel_codes(binding: Any, kinds: Any, n: int, m: int) -> Any:
    """The map's codes of the LP2 kernel's binding codes (a joint's: by which limit set it)."""
    names = labels.default_joint_names(n)
    lower = [labels.bound_label(name, "lower", labels.END_STOP, i) for i, name in enumerate(names)]
    upper = [labels.bound_label(name, "upper", labels.END_STOP, i) for i, name in enumerate(names)]
    table = labels.code_labels(lower, upper, m, ())
    joint = np.array([b.index if b.kind == "end-stop" else -1 for b in table] + [-1])
    side = np.array([labels.SIDES.index(b.side) if b.side else 0 for b in table] + [0])
    fixed = np.array([binding_code(b.kind) for b in table] + [NO_BINDING], dtype=np.int8)
    at = np.where(binding < 0, len(table), binding)  # -1 (none): the appended entry
    j, s = joint[at], side[at]
    rows = np.arange(len(binding))
    joint_kind = kinds[rows, s, np.maximum(j, 0)]
    return np.where(j >= 0, 1 + joint_kind, fixed[at]).astype(np.int8)


def lp1_steps(model: Any, J: FloatArray, dw: FloatArray, q: FloatArray, dt: float) -> tuple:
    """The p (P, K) and binding codes of LP1 (eqs. 11-14), one HiGHS solve each.

    Each solve starts cold, as ``lpik solve`` does: a warm start from the
    previous problem could pick another optimal vertex (and so another
    binding limit), and the map would depend on the order of its cells.
    """
    from lpik.limits import build_problem, standard_limits
    from lpik.methods.lp1 import lp1

    P, K, _ = dw.shape
    limits = standard_limits(model, lambda_bound=None)
    p, codes = np.empty((P, K)), np.empty((P, K), dtype=np.int8)
    for a in range(P):
        for k in range(K):
            problem = build_problem(J[a], dw[a, k], q[a], limits, dt=dt)
            result = lp1(problem)
            p[a, k] = result.p
            codes[a, k] = binding_code(None if result.binding is None else result.binding.kind)
    return p, codes
