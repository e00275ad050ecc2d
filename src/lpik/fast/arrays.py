"""LP2 problems as the compiled kernel's arrays: one problem's arguments, a batch's stack.

:class:`BatchArrays` holds a batch of LP2 problems of equal ``n``, ``m`` and
number of extra rows as stacked, validated arrays (the input of
:func:`lpik.fast.batch.lp2_batch`), each problem's arguments those of
:func:`lpik.methods.assembly.kernel_args`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lpik.exceptions import InvalidProblemError
from lpik.methods.assembly import kernel_args
from lpik.problem import Problem
from lpik.tolerances import SYMMETRY_RTOL
from lpik.types import FloatArray


@dataclass(frozen=True, eq=False)
class BatchArrays:
    """A batch of LP2 problems as stacked arrays (the compiled kernel's input).

    Build it with :meth:`from_problems` or directly from arrays of shape
    ``(B, ...)``: ``J (B, m, n)``, ``dw (B, m)``, ``H (B, n, n)`` (``M + Lambda``),
    ``c (B, n)`` (``f``), ``lower``/``upper (B, n)`` bounds
    on ``dq``, ``lam_min``/``lam_max (B, m)``, ``G (B, r, n)``, ``g (B, r)``
    (rows ``G dq <= g``), ``q0 (B, n)``; ``h_diag``: whether every ``H`` is
    diagonal (``None``: found out); ``c_ref (B, n)``: sec. 3.1's pull
    ``Lambda (q_ref - q0)`` (``None``: none), which the kernel scales
    (:func:`lpik.methods.kkt.smoothing_scale`).

    The arrays are checked on construction (the compiled kernel trusts them):
    shapes, numbers, no NaN, finite ``J``, ``dw``, ``H``, ``c``, ``G``, ``g``
    and ``q0``, ordered bounds, symmetric ``H`` and a true ``h_diag``; they are
    stored as C-contiguous float64 (work on every item: build the arrays
    once and reuse them where you can). That
    ``H`` is positive definite is checked by the solve itself
    (:func:`~lpik.fast.batch.lp2_batch` raises naming the item).

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
    c_ref: FloatArray | None = None

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
        args = [kernel_args(p) for p in problems]
        stack = [
            np.ascontiguousarray(np.stack([a[i] for a in args]))
            for i in (0, 1, 2, 4, 5, 6, 7, 8, 9, 10, 11)
        ]
        J, dw, H, c, c_ref, lower, upper, lam_min, lam_max, G, g = stack
        q0 = np.stack([p.q0 for p in problems])
        return cls(J, dw, H, c, lower, upper, lam_min, lam_max, G, g, q0,
                   all(a[3] for a in args), c_ref)  # fmt: skip


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
    "c_ref": (("n",), ""),
}
#: Problem fields as :func:`problem_at` fills them, by the BatchArrays field they come from.
_PROBLEM_TO_BATCH = {"M": "H", "f": "c", "dq_min": "lower", "dq_max": "upper", "h": "g"}


def _check_batch(arrays: BatchArrays) -> None:
    """Validate and normalise the fields of ``arrays`` in place (see :class:`BatchArrays`)."""
    values = _float_arrays(arrays)
    n = _check_shapes(values)
    _check_ordered(values)
    h_diag = _check_h(values["H"], n, arrays.h_diag)
    for name, arr in values.items():
        object.__setattr__(arrays, name, arr)
    object.__setattr__(arrays, "h_diag", h_diag)


def _float_arrays(arrays: BatchArrays) -> dict[str, FloatArray]:
    """Each array field as a writable C-contiguous float64 array (no pull: ``c_ref`` zero).

    Writable too: numba types a read-only array (``np.broadcast_to``'s, a memory
    map's) apart and would compile the batch kernel once more for it.
    """
    values = {}
    for name in _BATCH_FIELDS:
        if name == "c_ref" and arrays.c_ref is None:  # no pull (c comes before it)
            values[name] = np.zeros_like(values["c"])
            continue
        try:
            value = np.ascontiguousarray(getattr(arrays, name), dtype=np.float64)
            values[name] = value if value.flags.writeable else value.copy()
        except (TypeError, ValueError) as exc:
            raise InvalidProblemError(
                f"BatchArrays.{name}", f"must be an array of numbers ({exc})"
            ) from None
    return values


def _check_shapes(values: dict[str, FloatArray]) -> int:
    """Check each field's shape and values against ``J``'s ``(B, m, n)``; returns ``n``."""
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
        _check_values(name, arr, infinity)
    return n


def _check_values(name: str, arr: FloatArray, infinity: str) -> None:
    """No NaN in field ``name``, and no infinity but ``infinity`` (``""``: none)."""
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


def _check_ordered(values: dict[str, FloatArray]) -> None:
    """Lower bounds below upper ones, on ``dq`` and on the multipliers."""
    for low, high in (("lower", "upper"), ("lam_min", "lam_max")):
        crossed = values[low] > values[high]
        if crossed.any():
            item, k = (int(i) for i in np.unravel_index(np.argmax(crossed), crossed.shape))
            raise InvalidProblemError(
                f"BatchArrays.{low}",
                f"item {item}: {low}[{k}] = {values[low][item, k]:g} exceeds "
                f"{high}[{k}] = {values[high][item, k]:g}",
            )


def _check_h(H: FloatArray, n: int, h_diag: bool | None) -> bool:
    """Check that every ``H`` is symmetric and ``h_diag`` true; returns ``h_diag`` (found out)."""
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
    if h_diag is None:
        return not off_diagonal.any()
    if h_diag not in (True, False):
        raise InvalidProblemError(
            "BatchArrays.h_diag", f"must be True, False or None, got {h_diag!r}"
        )
    if h_diag and off_diagonal.any():
        raise InvalidProblemError(
            "BatchArrays.h_diag",
            f"is True but H of item {int(np.argmax(off_diagonal))} is not diagonal",
        )
    return bool(h_diag)


def raw_problem(arrays: BatchArrays, i: int) -> Problem:
    """:func:`problem_at`, its errors named after the field of :class:`BatchArrays`."""
    try:
        return problem_at(arrays, i)
    except InvalidProblemError as exc:
        name = _PROBLEM_TO_BATCH.get(exc.field, exc.field)
        raise InvalidProblemError(f"BatchArrays.{name}", f"item {i}: {exc.reason}") from None


def problem_at(arrays: BatchArrays, i: int) -> Problem:
    """Item ``i`` of raw batch arrays as a :class:`Problem` (for labels and the HiGHS path).

    ``H`` becomes ``M`` with ``Lambda = 0`` and ``c`` becomes ``f``: the same criterion.
    A pull ``c_ref`` becomes ``Lambda = t I``, ``q_ref = q0 + c_ref / t`` and
    ``M = H - t I`` with ``t`` half ``H``'s smallest eigenvalue: again the same.
    """
    q0 = arrays.q0[i]
    weights = {"M": arrays.H[i]}
    if np.any(arrays.c_ref[i]):
        t = 0.5 * float(np.linalg.eigvalsh(arrays.H[i])[0])
        n = q0.size
        weights = {"M": arrays.H[i] - t * np.eye(n), "Lambda": np.full(n, t),
                   "q_ref": q0 + arrays.c_ref[i] / t}  # fmt: skip
    return Problem(
        J=arrays.J[i],
        dw=arrays.dw[i],
        q0=q0,
        dq_min=arrays.lower[i],
        dq_max=arrays.upper[i],
        f=arrays.c[i],
        lam_min=arrays.lam_min[i],
        lam_max=arrays.lam_max[i],
        G=arrays.G[i],
        h=arrays.g[i] + arrays.G[i] @ q0,
        dq_min_kind="step bound",
        dq_max_kind="step bound",
        **weights,
    )
