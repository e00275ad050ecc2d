"""LP2 by the compiled ratio test: one problem, or a batch of problems in parallel.

:func:`solve_compiled` is the ``path="compiled"`` of :func:`lpik.methods.lp2.lp2`;
:func:`lp2_batch` solves a stack of problems (of equal ``n``, ``m`` and number
of rows) in parallel. Both return exactly what one-by-one
:func:`~lpik.methods.lp2.lp2` returns: items whose KKT matrix is singular or
ill-conditioned (or whose compiled answer fails its own check) are handed to
the general HiGHS path one by one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial

import numba
import numpy as np
from numpy.typing import NDArray

from lpik.check import task_residual
from lpik.continuation import around_motion
from lpik.exceptions import InvalidProblemError
from lpik.fast import lp2_kernel as K
from lpik.fast.arrays import BatchArrays, raw_problem
from lpik.fast.outcome import compiled_result
from lpik.fast.saturation import lp2s_batch_kernel, lp2s_kernel
from lpik.highs import HighsSolver
from lpik.labels import code_labels
from lpik.methods.assembly import kernel_args
from lpik.methods.engines import register_compiled
from lpik.methods.lp2 import lp2
from lpik.methods.lp2s import lp2s
from lpik.problem import Problem
from lpik.result import INFEASIBLE, OPTIMAL, Result
from lpik.types import FloatArray

__all__ = ["BatchArrays", "BatchResult", "lp2_batch", "solve_compiled"]


def problem_labels(problem: Problem) -> tuple[str, ...]:
    """The problem's labels, indexed by the LP2 kernel's binding codes."""
    return code_labels(*problem.step_bounds()[2:], problem.m, problem.row_labels)


@around_motion
def solve_compiled(
    problem: Problem, solver: HighsSolver | None = None, *, saturate: bool = False
) -> Result:
    """LP2 (eqs. 15-18) by the compiled ratio test; the numpy method where the kernel cannot.

    The same answer as :func:`lpik.methods.lp2.lp2` (``saturate``: as
    :func:`lpik.methods.lp2s.lp2s`, :mod:`lpik.fast.saturation`), with
    ``path="compiled"`` when the kernel answers; where ``K`` is singular, HiGHS
    (``solver``) for LP2, and the numpy passes for LP2 with saturation.
    """
    start = time.perf_counter()
    dq, lam = np.empty(problem.n), np.empty(problem.m)
    kernel = lp2s_kernel if saturate else K.lp2_kernel
    code, p, binding, _, pull_scale = kernel(*kernel_args(problem), dq, lam)
    method = "lp2s" if saturate else "lp2"
    if code not in (K.OK, K.INFEASIBLE):
        if saturate:
            return lp2s(problem, solver=solver)
        return lp2(problem, path="highs", solver=solver)
    outside = problem.recovering()
    p = float(p) if code == K.OK else 0.0
    label = None if binding < 0 else problem_labels(problem)[binding]
    return compiled_result(
        code, problem.q0 + dq, dq, p, lam, label, outside[0] if outside else None, method,
        task_residual(problem, dq, p),
        time.perf_counter() - start, float(pull_scale),
    )  # fmt: skip


register_compiled("lp2", solve_compiled)
register_compiled("lp2s", partial(solve_compiled, saturate=True))


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Answers of a batch, one row per problem (see :class:`~lpik.result.Result`).

    The status words and binding labels are built on access from the kernel's
    integer codes, so that a large batch pays no per-item Python work.

    Attributes:
        q: (B, n). dq: (B, n). p: (B,). lam: (B, m), NaN rows for safe steps.
        codes: (B,) kernel outcome per item (:mod:`lpik.fast.lp2_kernel` codes).
        binding_codes: (B,) index of each item's binding limit in its table of
            labels (``-1``: none); :meth:`binding_of` gives the label.
        residual: (B,) ``max |J dq - p dw|`` of each item.
        method: ``"lp2"`` or ``"lp2s"``.
        pull_scale: (B,) each item's share of sec. 3.1's pull
            (:attr:`lpik.result.Result.pull_scale`; 1 for a safe step), or ``None``
            where the producer does not report it (read as 1 by :meth:`__getitem__`).
    """

    q: FloatArray
    dq: FloatArray
    p: FloatArray
    lam: FloatArray
    codes: NDArray[np.int64]
    binding_codes: NDArray[np.int64]
    _labels: Callable[[int], tuple[str, ...]]
    _fallback: dict[int, Result]
    residual: FloatArray
    method: str
    pull_scale: FloatArray | None = None

    def __len__(self) -> int:
        return int(self.p.shape[0])

    def status_of(self, i: int) -> str:
        """Status word of item ``i``."""
        if i in self._fallback:
            return self._fallback[i].status
        return INFEASIBLE if self.codes[i] == K.INFEASIBLE else OPTIMAL

    def binding_of(self, i: int) -> str | None:
        """Binding label of item ``i``, or ``None``."""
        if i in self._fallback:
            return self._fallback[i].binding
        code = int(self.binding_codes[i])
        return None if code < 0 else self._labels(i)[code]

    @property
    def status(self) -> NDArray[np.object_]:
        """(B,) status words."""
        words = np.where(self.codes == K.INFEASIBLE, INFEASIBLE, OPTIMAL).astype(object)
        for i, res in self._fallback.items():
            words[i] = res.status
        return words

    @property
    def binding(self) -> NDArray[np.object_]:
        """(B,) binding labels or ``None``."""
        return np.array([self.binding_of(i) for i in range(len(self))] + [None],
                        dtype=object)[:-1]  # fmt: skip

    @property
    def path(self) -> NDArray[np.object_]:
        """(B,) ``"compiled"``, or ``"highs"`` for the items handed to HiGHS."""
        paths = np.full(len(self), "compiled", dtype=object)
        for i, res in self._fallback.items():
            paths[i] = res.path
        return paths

    def __getitem__(self, i: int) -> Result:
        """Item ``i`` as a :class:`~lpik.result.Result` (its :func:`compiled_result`)."""
        if i in self._fallback:
            return self._fallback[i]
        return compiled_result(
            int(self.codes[i]), self.q[i].copy(), self.dq[i].copy(), float(self.p[i]),
            self.lam[i].copy(), self.binding_of(i), None, self.method, float(self.residual[i]),
            0.0, 1.0 if self.pull_scale is None else float(self.pull_scale[i]),
        )  # fmt: skip


def batch_residuals(J: FloatArray, dw: FloatArray, dq: FloatArray, p: FloatArray) -> FloatArray:
    """(B,) ``max |J dq - p dw|`` of every row (the residual each Result reports)."""
    return np.abs(np.einsum("bmn,bn->bm", J, dq) - p[:, None] * dw).max(axis=1)


#: The batch kernels, by method.
BATCH_KERNELS = {"lp2": K.lp2_batch_kernel, "lp2s": lp2s_batch_kernel}


def lp2_batch(problems: Sequence[Problem] | BatchArrays, method: str = "lp2s") -> BatchResult:
    """Solve a batch of LP2 problems (eqs. 15-18) in parallel; identical to one by one.

    Args:
        problems: Validated problems of equal ``n``, ``m`` and rows, or a
            prepared :class:`BatchArrays` (faster: no per-problem Python work).
        method: ``"lp2s"`` (the default: LP2 with saturation in the null space,
            :func:`lpik.methods.lp2s.lp2s`) or ``"lp2"`` (the paper's LP2).

    Returns:
        The stacked answers; items the compiled ratio test cannot take
        (singular ``K``) are solved by the numpy method one by one.

    Raises:
        InvalidProblemError: (a ``ValueError``) for an empty batch, an item that is
            not a :class:`~lpik.problem.Problem`, problems of different sizes, or a
            raw ``H`` that is not positive definite (naming the item), or an
            unknown method.
    """
    if method not in BATCH_KERNELS:
        raise InvalidProblemError("method", f"must be one of {', '.join(BATCH_KERNELS)}, got "
                                  f"{method!r}")  # fmt: skip
    problem_list = None if isinstance(problems, BatchArrays) else _problem_list(problems)
    arrays = problems if problem_list is None else BatchArrays.from_problems(problem_list)
    B, m, n = arrays.J.shape
    dq, lam = np.empty((B, n)), np.empty((B, m))
    codes, ps, bindings = np.empty(B, dtype=np.int64), np.empty(B), np.empty(B, dtype=np.int64)
    scales = np.empty(B)
    BATCH_KERNELS[method](
        arrays.J, arrays.dw, arrays.H, arrays.h_diag, arrays.c, arrays.c_ref, arrays.lower,
        arrays.upper, arrays.lam_min, arrays.lam_max, arrays.G, arrays.g, dq, lam, codes, ps,
        bindings, scales, 4 * numba.get_num_threads(),
    )  # fmt: skip
    infeasible = codes == K.INFEASIBLE
    ps[infeasible], lam[infeasible], scales[infeasible] = 0.0, np.nan, 1.0  # dq: the safe step
    one_by_one = (codes != K.OK) & ~infeasible
    if problem_list is not None:  # steps from outside the limits say so, and steps around
        # the current motion (lpik.continuation) are solved so: one by one
        one_by_one |= np.array([bool(P.recovering()) or P.last is not None for P in problem_list])
    fallback: dict[int, Result] = {}
    for i in np.nonzero(one_by_one)[0].tolist():
        problem = problem_list[i] if problem_list is not None else raw_problem(arrays, i)
        res = solve_compiled(problem, saturate=method == "lp2s")
        fallback[i] = res
        dq[i], ps[i], scales[i] = res.dq, res.p, res.pull_scale
        lam[i] = np.nan if res.lam is None else res.lam
    residual = batch_residuals(arrays.J, arrays.dw, dq, ps)
    for i, res in fallback.items():
        residual[i] = res.residual
    return BatchResult(
        q=arrays.q0 + dq, dq=dq, p=ps, lam=lam, codes=codes, binding_codes=bindings,
        _labels=_label_tables(arrays, problem_list), _fallback=fallback,
        residual=residual, method=method, pull_scale=scales,
    )  # fmt: skip


def _problem_list(problems: Sequence[Problem]) -> list[Problem]:
    try:
        return list(problems)
    except TypeError:
        raise InvalidProblemError(
            "problems",
            f"must be a sequence of Problems or a BatchArrays, got {type(problems).__name__}",
        ) from None


def _label_tables(
    arrays: BatchArrays, problem_list: list[Problem] | None
) -> Callable[[int], tuple[str, ...]]:
    """Each item's table of labels (raw arrays: every item has the same labels)."""
    if problem_list is None:
        generic = problem_labels(raw_problem(arrays, 0))
        return lambda i: generic
    return lambda i: problem_labels(problem_list[i])
