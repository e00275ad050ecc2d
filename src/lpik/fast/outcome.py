"""A compiled step's outcome as a :class:`~lpik.result.Result`: the one decoding.

Every compiled path (the controller's fused step, its batch rows, the
one-problem step :func:`lpik.fast.batch.solve_compiled` and the rows of
:func:`lpik.fast.batch.lp2_batch`) ends in an outcome code of the LP2 kernel
(:mod:`lpik.fast.lp2_kernel`), the step, ``p``, the multipliers, the binding
limit and whether the state was outside a limit; :func:`compiled_result`
turns that into the status the numpy methods give the same step:

* ``OK`` from within the limits: ``optimal``;
* ``OK`` from outside a limit: ``recovering``, naming the limit it is outside of;
* ``INFEASIBLE``: the kernel's safe step (:func:`lpik.result.safe_step`: ``p = 0``,
  no multipliers, ``pull_scale`` 1), ``infeasible`` naming the conflict, or
  ``recovering`` from outside a limit.
"""

from __future__ import annotations

from typing import Any

from lpik.fast.lp2_kernel import OK
from lpik.result import INFEASIBLE, OPTIMAL, RECOVERING, Result
from lpik.types import FloatArray


def compiled_result(
    code: int,
    q: FloatArray,
    dq: FloatArray,
    p: float,
    lam: FloatArray | None,
    binding: Any,
    outside: Any,
    method: str,
    residual: float,
    solve_time: float,
    pull_scale: float | None = None,
) -> Result:
    """The Result of a compiled step whose kernel outcome is ``OK`` or ``INFEASIBLE``.

    Args:
        code: The LP2 kernel's outcome (``OK`` or ``INFEASIBLE``).
        q: The step's joint coordinates, (n,).
        dq: The step, (n,) (the safe step when infeasible).
        p: The kernel's ``p`` (ignored when infeasible: 0).
        lam: The multipliers (ignored when infeasible: None).
        binding: The label of the limit that stops ``p`` (or the conflict), or None.
        outside: The label of the limit the state is outside of, or None.
        method: ``"lp2"`` or ``"lp2s"``.
        residual: ``max |J dq - p dw|`` of the step.
        solve_time: Wall time of the step [s].
        pull_scale: The share of sec. 3.1's pull the kernel's step took
            (:func:`lpik.fast.lp2_kernel.pull_scale_of`; ignored when infeasible: 1);
            ``None``: the caller does not report it (the field is left out of the
            result's fields, which then read :class:`~lpik.result.Result`'s default 1).
    """
    fields = _fields(code, q, dq, p, lam, binding, outside, method, residual, solve_time)
    if pull_scale is not None:
        fields["pull_scale"] = pull_scale if code == OK else 1.0
    return Result.trusted(fields)


def _fields(
    code: int, q: FloatArray, dq: FloatArray, p: float, lam: FloatArray | None, binding: Any,
    outside: Any, method: str, residual: float, solve_time: float,
) -> dict[str, Any]:  # fmt: skip
    """:func:`compiled_result`'s fields, ``pull_scale`` aside."""
    moved = code == OK
    if outside is not None:
        status, binding = RECOVERING, outside
    else:
        status = OPTIMAL if moved else INFEASIBLE
    return {
        "q": q,
        "dq": dq,
        "p": p if moved else 0.0,
        "lam": lam if moved else None,
        "status": status,
        "binding": binding,
        "method": method,
        "solve_time": solve_time,
        "residual": residual,
        "path": "compiled",
    }
