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

import numba
import numpy as np
from numpy.typing import NDArray

from lpik.check import task_residual
from lpik.exceptions import InvalidProblemError
from lpik.fast import lp2_kernel as K
from lpik.fast.arrays import BatchArrays, raw_problem
from lpik.fast.saturation import lp2s_kernel
from lpik.highs import HighsSolver
from lpik.labels import code_labels
from lpik.methods.assembly import kernel_args
from lpik.methods.lp2 import lp2
from lpik.problem import Problem
from lpik.result import INFEASIBLE, OPTIMAL, RECOVERING, Result, safe_step
from lpik.types import FloatArray

__all__ = ["BatchArrays", "BatchResult", "lp2_batch", "solve_compiled"]


def problem_labels(problem: Problem) -> tuple[str, ...]:
    """The problem's labels, indexed by the LP2 kernel's binding codes."""
    return code_labels(*problem.step_bounds()[2:], problem.m, problem.row_labels)


def solve_compiled(
    problem: Problem, solver: HighsSolver | None = None, *, saturate: bool = False
) -> Result:
    """LP2 (eqs. 15-18) by the compiled ratio test; HiGHS (``solver``) when ``K`` is singular.

    The same answer as :func:`lpik.methods.lp2.lp2` with ``path="ratio-test"``,
    with ``path="compiled"`` when the kernel answers. With ``saturate``, LP2 with
    saturation in the null space (:func:`lpik.methods.lp2s.lp2s`,
    :mod:`lpik.fast.saturation`).
    """
    start = time.perf_counter()
    dq, lam = np.empty(problem.n), np.empty(problem.m)
    kernel = lp2s_kernel if saturate else K.lp2_kernel
    code, p, binding, _ = kernel(*kernel_args(problem), dq, lam)
    method = "lp2s" if saturate else "lp2"
    if code == K.OK:
        outside = problem.recovering()
        return Result.trusted(
            {
                "q": problem.q0 + dq,
                "dq": dq,
                "p": float(p),
                "lam": lam,
                "status": RECOVERING if outside else OPTIMAL,
                "binding": outside[0]
                if outside
                else None
                if binding < 0
                else problem_labels(problem)[binding],
                "method": method,
                "solve_time": time.perf_counter() - start,
                "residual": task_residual(problem, dq, p),
                "path": "compiled",
            }
        )
    if code == K.INFEASIBLE:
        return safe_step(
            problem,
            method,
            INFEASIBLE,
            problem_labels(problem)[binding],
            solve_time=time.perf_counter() - start,
            path="compiled",
        )
    if saturate:  # a singular pass: the numpy method, pass by pass
        from lpik.methods.lp2s import lp2s

        return lp2s(problem, solver=solver)
    return lp2(problem, path="highs", solver=solver)


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
    """

    q: FloatArray
    dq: FloatArray
    p: FloatArray
    lam: FloatArray
    codes: NDArray[np.int64]
    binding_codes: NDArray[np.int64]
    _labels: Callable[[int], tuple[str, ...]]
    _fallback: dict[int, Result]

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
        """Item ``i`` as a :class:`~lpik.result.Result`."""
        if i in self._fallback:
            return self._fallback[i]
        lam = None if np.isnan(self.lam[i]).all() else self.lam[i].copy()
        return Result.trusted(
            {
                "q": self.q[i].copy(),
                "dq": self.dq[i].copy(),
                "p": float(self.p[i]),
                "lam": lam,
                "status": self.status_of(i),
                "binding": self.binding_of(i),
                "method": "lp2",
                "solve_time": 0.0,
                "residual": 0.0,
                "path": "compiled",
            }
        )


def lp2_batch(problems: Sequence[Problem] | BatchArrays) -> BatchResult:
    """Solve a batch of LP2 problems (eqs. 15-18) in parallel; identical to one by one.

    Args:
        problems: Validated problems of equal ``n``, ``m`` and rows, or a
            prepared :class:`BatchArrays` (faster: no per-problem Python work).

    Returns:
        The stacked answers; items the compiled ratio test cannot take
        (singular ``K``) are solved by :func:`lpik.methods.lp2.lp2` one by one.

    Raises:
        InvalidProblemError: (a ``ValueError``) for an empty batch, an item that is
            not a :class:`~lpik.problem.Problem`, problems of different sizes, or a
            raw ``H`` that is not positive definite (naming the item).
    """
    if not isinstance(problems, BatchArrays):
        try:
            problems = list(problems)
        except TypeError:
            raise InvalidProblemError(
                "problems",
                f"must be a sequence of Problems or a BatchArrays, got {type(problems).__name__}",
            ) from None
    arrays = problems if isinstance(problems, BatchArrays) else BatchArrays.from_problems(problems)
    B, m, n = arrays.J.shape
    dq = np.empty((B, n))
    lam = np.empty((B, m))
    codes = np.empty(B, dtype=np.int64)
    ps = np.empty(B)
    bindings = np.empty(B, dtype=np.int64)
    K.lp2_batch_kernel(
        arrays.J,
        arrays.dw,
        arrays.H,
        arrays.h_diag,
        arrays.c,
        arrays.c_ref,
        arrays.lower,
        arrays.upper,
        arrays.lam_min,
        arrays.lam_max,
        arrays.G,
        arrays.g,
        dq,
        lam,
        codes,
        ps,
        bindings,
        4 * numba.get_num_threads(),
    )
    problem_list = None if isinstance(problems, BatchArrays) else list(problems)
    infeasible = codes == K.INFEASIBLE
    if infeasible.any():  # dq: the kernel's safe step
        ps[infeasible], lam[infeasible] = 0.0, np.nan
    fallback: dict[int, Result] = {}
    one_by_one = (codes != K.OK) & ~infeasible
    if problem_list is not None:  # steps from outside the limits say so: solved one by one
        one_by_one |= np.array([bool(P.recovering()) for P in problem_list])
    for i in np.nonzero(one_by_one)[0].tolist():
        problem = problem_list[i] if problem_list is not None else raw_problem(arrays, i)
        res = lp2(problem, path="highs" if codes[i] != K.OK and not infeasible[i] else "compiled")
        fallback[i] = res
        dq[i], ps[i] = res.dq, res.p
        lam[i] = np.nan if res.lam is None else res.lam
    if problem_list is None:  # raw arrays: every item has the same labels
        generic = problem_labels(raw_problem(arrays, 0))
        labels: Callable[[int], tuple[str, ...]] = lambda i: generic  # noqa: E731
    else:
        labels = lambda i: problem_labels(problem_list[i])  # noqa: E731
    return BatchResult(q=arrays.q0 + dq, dq=dq, p=ps, lam=lam, codes=codes,
                       binding_codes=bindings, _labels=labels, _fallback=fallback)  # fmt: skip
