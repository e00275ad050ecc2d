"""Compiled single-problem LP2 and batched LP2 (many problems of the same n, m, r).

:func:`lp2_compiled` is :func:`lpik.methods.lp2.lp2` with the ratio test run by
the compiled kernel; :func:`lp2_batch` solves a stack of problems in parallel.
Both return exactly what one-by-one :func:`~lpik.methods.lp2.lp2` returns:
items whose KKT matrix is singular or ill-conditioned (or whose compiled
answer fails its own check) are handed to the general HiGHS path one by one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from lpik import result as st
from lpik.exceptions import InvalidProblemError
from lpik.fast import kernels as K
from lpik.methods._common import criterion
from lpik.methods.lp2 import lp2
from lpik.problem import SYMMETRY_RTOL, Problem
from lpik.result import Result

FloatArray = NDArray[np.float64]


def constraint_labels(problem: Problem) -> tuple[str, ...]:
    """Labels indexed by the kernels' binding codes (``2 k`` lower, ``2 k + 1`` upper)."""
    lower_labels, upper_labels = problem.step_bounds()[2:]
    lam_lo, lam_hi = problem.multiplier_labels()
    labels: list[str] = []
    for lo, hi in zip(lower_labels + lam_lo, upper_labels + lam_hi):
        labels += [lo, hi]
    for row in problem.row_labels:
        labels += [row, row]
    return tuple(labels)


def is_diagonal(H: FloatArray) -> bool:
    """Whether ``H`` is diagonal, so that the kernels need not factorise it."""
    return bool(np.count_nonzero(H - np.diag(np.diagonal(H))) == 0)


def _kernel_args(problem: Problem) -> tuple:
    H, c = criterion(problem)
    lower, upper = problem.step_bounds()[:2]
    h_diag = is_diagonal(H)
    g = problem.h - problem.G @ problem.q0
    return (
        problem.J,
        problem.dw,
        H,
        h_diag,
        c,
        lower,
        upper,
        problem.lam_min,
        problem.lam_max,
        problem.G,
        g,
    )


def lp2_compiled(problem: Problem) -> Result:
    """LP2 (eqs. 15-18) by the compiled ratio test; HiGHS when ``K`` is singular.

    Same answer as :func:`lpik.methods.lp2.lp2` with ``path="ratio-test"``.
    """
    start = time.perf_counter()
    n, m = problem.n, problem.m
    dq, lam = np.empty(n), np.empty(m)
    code, p, binding = K.lp2_kernel(*_kernel_args(problem), dq, lam)
    if code == K.OK:
        label = None if binding < 0 else constraint_labels(problem)[binding]
        return Result(
            q=problem.q0 + dq,
            dq=dq,
            p=float(p),
            lam=lam,
            status=st.OPTIMAL,
            binding=label,
            method="lp2",
            solve_time=time.perf_counter() - start,
            residual=st.task_residual(problem, dq, p),
            path="compiled",
        )
    if code == K.INFEASIBLE:
        return st.safe_step(
            problem,
            "lp2",
            st.INFEASIBLE,
            constraint_labels(problem)[binding],
            solve_time=time.perf_counter() - start,
            path="compiled",
        )
    return lp2(problem, path="highs")


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Answers of a batch, one row per problem (see :class:`~lpik.result.Result`).

    The status words and binding labels are built on access from the kernel's
    integer codes, so that a large batch pays no per-item Python work.

    Attributes:
        q: (B, n). dq: (B, n). p: (B,). lam: (B, m), NaN rows for safe steps.
        codes: (B,) kernel outcome per item (:mod:`lpik.fast.kernels` codes).
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
        return st.INFEASIBLE if self.codes[i] == K.INFEASIBLE else st.OPTIMAL

    def binding_of(self, i: int) -> str | None:
        """Binding label of item ``i``, or ``None``."""
        if i in self._fallback:
            return self._fallback[i].binding
        code = int(self.binding_codes[i])
        return None if code < 0 else self._labels(i)[code]

    @property
    def status(self) -> NDArray[np.object_]:
        """(B,) status words."""
        words = np.where(self.codes == K.INFEASIBLE, st.INFEASIBLE, st.OPTIMAL).astype(object)
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
        return Result(
            q=self.q[i].copy(),
            dq=self.dq[i].copy(),
            p=float(self.p[i]),
            lam=lam,
            status=self.status_of(i),
            binding=self.binding_of(i),
            method="lp2",
            path="compiled",
        )


@dataclass(frozen=True, eq=False)
class BatchArrays:
    """A batch of LP2 problems as stacked arrays (the compiled kernel's input).

    Build it with :meth:`from_problems` or directly from arrays of shape
    ``(B, ...)``: ``J (B, m, n)``, ``dw (B, m)``, ``H (B, n, n)`` (``M + Lambda``),
    ``c (B, n)`` (``f + Lambda (q_ref - q0)``), ``lower``/``upper (B, n)`` bounds
    on ``dq``, ``lam_min``/``lam_max (B, m)``, ``G (B, r, n)``, ``g (B, r)``
    (rows ``G dq <= g``), ``q0 (B, n)``; ``h_diag``: whether every ``H`` is
    diagonal (``None``: found out).

    The arrays are checked on construction (the compiled kernel trusts them):
    shapes, numbers, no NaN, finite ``J``, ``dw``, ``H``, ``c``, ``G``, ``g``
    and ``q0``, ordered bounds, symmetric ``H`` and a true ``h_diag``; they are
    stored as C-contiguous float64 (about 0.3 us per item for the Panda's
    n = 7, m = 6: build the arrays once and reuse them where you can). That
    ``H`` is positive definite is checked by the solve itself
    (:func:`lp2_batch` raises naming the item).

    Raises:
        InvalidProblemError: A ``ValueError`` naming the field, and the item, that is wrong.
    """

    J: FloatArray
    dw: FloatArray
    H: FloatArray
    c: FloatArray
    lower: FloatArray
    upper: FloatArray
    lam_min: FloatArray
    lam_max: FloatArray
    G: FloatArray
    g: FloatArray
    q0: FloatArray
    h_diag: bool | None = None

    def __post_init__(self) -> None:
        _check_batch(self)

    @classmethod
    def from_problems(cls, problems: Sequence[Problem]) -> BatchArrays:
        """Stack validated problems of equal ``n``, ``m`` and number of rows."""
        problems = list(problems)
        if not problems:
            raise InvalidProblemError("problems", "the batch is empty")
        for i, problem in enumerate(problems):
            if not isinstance(problem, Problem):
                raise InvalidProblemError(
                    "problems", f"item {i} is a {type(problem).__name__}, not a Problem"
                )
        shapes = {(p.n, p.m, p.G.shape[0]) for p in problems}
        if len(shapes) != 1:
            raise InvalidProblemError(
                "problems",
                f"every problem must share n, m and rows; got {sorted(shapes)}",
            )
        args = [_kernel_args(p) for p in problems]
        stack = [
            np.ascontiguousarray(np.stack([a[i] for a in args]))
            for i in (0, 1, 2, 4, 5, 6, 7, 8, 9, 10)
        ]
        J, dw, H, c, lower, upper, lam_min, lam_max, G, g = stack
        q0 = np.stack([p.q0 for p in problems])
        return cls(J, dw, H, c, lower, upper, lam_min, lam_max, G, g, q0, all(a[3] for a in args))


#: The array fields of :class:`BatchArrays`: their axes after ``B``, and which
#: infinity they may hold (``""``: none).
_BATCH_FIELDS = {
    "J": (("m", "n"), ""),
    "dw": (("m",), ""),
    "H": (("n", "n"), ""),
    "c": (("n",), ""),
    "lower": (("n",), "-inf"),
    "upper": (("n",), "+inf"),
    "lam_min": (("m",), "-inf"),
    "lam_max": (("m",), "+inf"),
    "G": (("r", "n"), ""),
    "g": (("r",), ""),
    "q0": (("n",), ""),
}
#: Problem fields as :func:`_problem_at` fills them, by the BatchArrays field they come from.
_PROBLEM_TO_BATCH = {"M": "H", "f": "c", "dq_min": "lower", "dq_max": "upper", "h": "g"}


def _check_batch(arrays: BatchArrays) -> None:
    """Validate and normalise the fields of ``arrays`` in place (see :class:`BatchArrays`)."""
    values = {}
    for name in _BATCH_FIELDS:
        try:
            values[name] = np.ascontiguousarray(getattr(arrays, name), dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidProblemError(
                f"BatchArrays.{name}", f"must be an array of numbers ({exc})"
            ) from None
    J, G = values["J"], values["G"]
    if J.ndim != 3 or 0 in J.shape:
        raise InvalidProblemError(
            "BatchArrays.J", f"must have shape (B, m, n) with B, m, n >= 1, got {J.shape}"
        )
    B, m, n = J.shape
    if G.ndim != 3:
        raise InvalidProblemError("BatchArrays.G", f"must have shape (B, r, n), got {G.shape}")
    size = {"m": m, "n": n, "r": G.shape[1]}
    for name, (axes, infinity) in _BATCH_FIELDS.items():
        arr = values[name]
        want = (B, *(size[a] for a in axes))
        if arr.shape != want:
            raise InvalidProblemError(
                f"BatchArrays.{name}",
                f"must have shape ({', '.join(('B', *axes))}) = {want}, got {arr.shape}",
            )
        bad = np.isnan(arr) if infinity else ~np.isfinite(arr)
        if infinity:
            bad |= arr == (np.inf if infinity == "-inf" else -np.inf)
        if bad.any():
            item, *where = (int(i) for i in np.unravel_index(np.argmax(bad), arr.shape))
            allowed = "finite" + (f" or {infinity}" if infinity else "")
            raise InvalidProblemError(
                f"BatchArrays.{name}",
                f"must be {allowed}; item {item} has {arr[(item, *where)]} at {where}",
            )
    for low, high in (("lower", "upper"), ("lam_min", "lam_max")):
        crossed = values[low] > values[high]
        if crossed.any():
            item, k = (int(i) for i in np.unravel_index(np.argmax(crossed), crossed.shape))
            raise InvalidProblemError(
                f"BatchArrays.{low}",
                f"item {item}: {low}[{k}] = {values[low][item, k]:g} exceeds "
                f"{high}[{k}] = {values[high][item, k]:g}",
            )
    H = values["H"]
    rows, cols = np.triu_indices(n, 1)
    above, below = H[:, rows, cols], H[:, cols, rows]
    if n > 1:
        scale = np.maximum(1.0, np.abs(H).max(axis=(1, 2)))
        asymmetric = np.abs(above - below).max(axis=1) > SYMMETRY_RTOL * scale
        if asymmetric.any():
            raise InvalidProblemError(
                "BatchArrays.H", f"must be symmetric; item {int(np.argmax(asymmetric))} is not"
            )
    off_diagonal = np.any(above != 0.0, axis=1) | np.any(below != 0.0, axis=1)
    h_diag = arrays.h_diag
    if h_diag is None:
        h_diag = not off_diagonal.any()
    elif h_diag not in (True, False):
        raise InvalidProblemError(
            "BatchArrays.h_diag", f"must be True, False or None, got {h_diag!r}"
        )
    elif h_diag and off_diagonal.any():
        raise InvalidProblemError(
            "BatchArrays.h_diag",
            f"is True but H of item {int(np.argmax(off_diagonal))} is not diagonal",
        )
    for name, arr in values.items():
        object.__setattr__(arrays, name, arr)
    object.__setattr__(arrays, "h_diag", bool(h_diag))


def _raw_problem(arrays: BatchArrays, i: int) -> Problem:
    """:func:`_problem_at`, its errors named after the field of :class:`BatchArrays`."""
    try:
        return _problem_at(arrays, i)
    except InvalidProblemError as exc:
        name = _PROBLEM_TO_BATCH.get(exc.field, exc.field)
        raise InvalidProblemError(f"BatchArrays.{name}", f"item {i}: {exc.reason}") from None


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
    if infeasible.any():
        dq[infeasible], ps[infeasible], lam[infeasible] = 0.0, 0.0, np.nan
    fallback: dict[int, Result] = {}
    for i in np.nonzero((codes != K.OK) & ~infeasible)[0].tolist():
        problem = problem_list[i] if problem_list is not None else _raw_problem(arrays, i)
        res = lp2(problem, path="highs")
        fallback[i] = res
        dq[i], ps[i] = res.dq, res.p
        lam[i] = np.nan if res.lam is None else res.lam
    if problem_list is None:  # raw arrays: every item has the same labels
        generic = constraint_labels(_raw_problem(arrays, 0))
        labels: Callable[[int], tuple[str, ...]] = lambda i: generic  # noqa: E731
    else:
        labels = lambda i: constraint_labels(problem_list[i])  # noqa: E731
    return BatchResult(q=arrays.q0 + dq, dq=dq, p=ps, lam=lam, codes=codes,
                       binding_codes=bindings, _labels=labels, _fallback=fallback)  # fmt: skip


def _problem_at(arrays: BatchArrays, i: int) -> Problem:
    """Item ``i`` of raw batch arrays as a :class:`Problem` (for labels and the HiGHS path).

    ``H`` becomes ``M`` with ``Lambda = 0`` and ``c`` becomes ``f``: the same criterion.
    """
    q0 = arrays.q0[i]
    return Problem(
        J=arrays.J[i],
        dw=arrays.dw[i],
        q0=q0,
        dq_min=arrays.lower[i],
        dq_max=arrays.upper[i],
        M=arrays.H[i],
        f=arrays.c[i],
        lam_min=arrays.lam_min[i],
        lam_max=arrays.lam_max[i],
        G=arrays.G[i],
        h=arrays.g[i] + arrays.G[i] @ q0,
        dq_min_kind="step bound",
        dq_max_kind="step bound",
    )
