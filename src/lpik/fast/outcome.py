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
  no multipliers), ``infeasible`` naming the conflict, or ``recovering``
  from outside a limit.
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
    """
    moved = code == OK
    if outside is not None:
        status, binding = RECOVERING, outside
    else:
        status = OPTIMAL if moved else INFEASIBLE
    return Result.trusted(
        {
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
    )
