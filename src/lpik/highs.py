"""The one place in lpik that talks to the LP solver (HiGHS, through highspy).

A :class:`LinearProgram` is ``min c^T x`` subject to ``row_lower <= A x <=
row_upper`` and ``col_lower <= x <= col_upper``. :class:`HighsSolver` keeps one
HiGHS instance and, when the next program has the same shape and sparsity,
changes only its coefficients and bounds so that HiGHS can start from the
previous basis (warm start across control steps). :data:`HIGHS_STATUS` is the
one table from HiGHS's model statuses to lpik's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import highspy
import numpy as np
from numpy.typing import NDArray

from lpik.result import INFEASIBLE, LIMIT_REACHED, OPTIMAL, SOLVER_ERROR
from lpik.types import FloatArray

_MS = highspy.HighsModelStatus

#: HiGHS model status -> lpik status. Anything not listed is a solver error.
HIGHS_STATUS: dict[object, str] = {
    _MS.kOptimal: OPTIMAL,
    _MS.kInfeasible: INFEASIBLE,
    _MS.kUnboundedOrInfeasible: INFEASIBLE,
    _MS.kUnbounded: SOLVER_ERROR,  # every lpik LP is bounded (0 <= p <= 1, |dq| >= 0)
    _MS.kIterationLimit: LIMIT_REACHED,
    _MS.kTimeLimit: LIMIT_REACHED,
    _MS.kModelEmpty: SOLVER_ERROR,
    _MS.kModelError: SOLVER_ERROR,
    _MS.kLoadError: SOLVER_ERROR,
    _MS.kPresolveError: SOLVER_ERROR,
    _MS.kSolveError: SOLVER_ERROR,
    _MS.kPostsolveError: SOLVER_ERROR,
    _MS.kMemoryLimit: SOLVER_ERROR,
    _MS.kUnknown: SOLVER_ERROR,
    _MS.kNotset: SOLVER_ERROR,
}

#: HiGHS options used for every solve: tight tolerances (steps are small numbers).
HIGHS_OPTIONS: dict[str, object] = {
    "primal_feasibility_tolerance": 1e-10,
    "dual_feasibility_tolerance": 1e-10,
    "presolve": "choose",
    "threads": 1,
}

#: Wall-time limit of one solve [s]. HiGHS's own ``time_limit`` counts the whole life of
#: an instance, so a solver reused across thousands of control steps would hit it after
#: a few seconds of total solving: :meth:`HighsSolver._run` moves it before every run.
SOLVE_TIME_LIMIT = 5.0

#: Options tried in turn, from scratch, when a solve does not end optimal. With the
#: tight tolerances above, HiGHS's presolve can call a nearly singular program (an arm
#: with aligned links) infeasible although it is not, and its simplex can stop with a
#: solve error; the retries settle it, and every answer is re-checked by the caller.
RETRY_OPTIONS: tuple[dict[str, object], ...] = (
    {"presolve": "off"},
    {"presolve": "off", "primal_feasibility_tolerance": 1e-7, "dual_feasibility_tolerance": 1e-7},
)


@dataclass(frozen=True, eq=False)
class LinearProgram:
    """``min c^T x`` s.t. ``row_lower <= A x <= row_upper``, ``col_lower <= x <= col_upper``.

    Infinite bounds are written as ``+-inf``.
    """

    c: FloatArray
    A: FloatArray
    row_lower: FloatArray
    row_upper: FloatArray
    col_lower: FloatArray
    col_upper: FloatArray


@dataclass(frozen=True, eq=False)
class LpSolution:
    """What HiGHS answered, already mapped to lpik's status words."""

    status: str
    x: FloatArray
    col_dual: FloatArray
    row_dual: FloatArray
    highs_status: str
    solve_time: float
    #: Which columns, then which rows, are basic in the final basis (``None`` if unknown).
    basic: NDArray[np.bool_] | None = None


class _Highs(getattr(highspy, "_Highs", highspy.Highs)):  # type: ignore[misc]
    """highspy's core class, for lpik's :class:`HighsSolver`.

    highspy's own Python subclass ``highspy.Highs`` prints a banner on the
    process's standard output when it is constructed (highspy 1.16), before any
    option can silence it, which corrupts ``lpik solve``'s JSON. lpik uses none
    of that subclass's additions (callbacks, ``solve``).
    """


class HighsSolver:
    """One reusable HiGHS instance.

    Calls with a program of the same shape and the same nonzero pattern of
    ``A`` as the previous call only change coefficients and bounds, keeping
    HiGHS's basis as a warm start; anything else loads a new model.
    """

    def __init__(self) -> None:
        self._highs = _Highs()
        self._highs.setOptionValue("output_flag", False)  # before any other call
        for name, value in HIGHS_OPTIONS.items():
            self._highs.setOptionValue(name, value)
        self._pattern: tuple[tuple[int, int], bytes] | None = None
        self._A: FloatArray | None = None

    def solve(self, lp: LinearProgram) -> LpSolution:
        """Solve ``lp``; never raises for solver trouble (the status says it)."""
        start = time.perf_counter()
        h = self._highs
        nz = lp.A != 0
        pattern = (lp.A.shape, np.packbits(nz).tobytes())
        try:
            if pattern == self._pattern and self._A is not None:
                self._update(lp, nz, self._A)
            else:
                self._load(lp, nz)
                self._pattern = pattern
            self._A = lp.A.copy()
            self._run()
            model_status = h.getModelStatus()
            if model_status != _MS.kOptimal:
                model_status = self._retry(model_status)
        except Exception as exc:  # a solver crash must become a status
            self._pattern = None
            return LpSolution(
                SOLVER_ERROR,
                np.zeros(lp.c.size),
                np.zeros(lp.c.size),
                np.zeros(lp.A.shape[0]),
                f"exception: {exc}",
                time.perf_counter() - start,
            )
        status = HIGHS_STATUS.get(model_status, SOLVER_ERROR)
        sol = h.getSolution()
        x = np.array(sol.col_value, dtype=np.float64)
        col_dual = np.array(sol.col_dual, dtype=np.float64)
        row_dual = np.array(sol.row_dual, dtype=np.float64)
        if x.size != lp.c.size:
            x = np.zeros(lp.c.size)
            status = SOLVER_ERROR if status == OPTIMAL else status
        if col_dual.size != lp.c.size:
            col_dual = np.zeros(lp.c.size)
        if row_dual.size != lp.A.shape[0]:
            row_dual = np.zeros(lp.A.shape[0])
        return LpSolution(
            status,
            x,
            col_dual,
            row_dual,
            h.modelStatusToString(model_status),
            time.perf_counter() - start,
            self._basic(lp.c.size + lp.A.shape[0]),
        )

    def _basic(self, size: int) -> NDArray[np.bool_] | None:
        """The final basis as a mask over the columns, then the rows."""
        basis = self._highs.getBasis()
        if not basis.valid:
            return None
        statuses = list(basis.col_status) + list(basis.row_status)
        mask = np.array([s == highspy.HighsBasisStatus.kBasic for s in statuses], dtype=bool)
        return mask if mask.size == size else None

    def _run(self) -> None:
        """One HiGHS run with at most :data:`SOLVE_TIME_LIMIT` seconds of its own."""
        h = self._highs
        h.setOptionValue("time_limit", h.getRunTime() + SOLVE_TIME_LIMIT)
        h.run()

    def _retry(self, first: object) -> object:
        """Solve again from scratch under each of :data:`RETRY_OPTIONS` until one is optimal.

        Returns the optimal status; else ``kInfeasible`` if any attempt proved
        infeasibility (a warm-started run can end ``kUnknown`` on a program that
        a fresh one calls infeasible); else ``first``. When no attempt is
        optimal, the solution left in HiGHS is the last retry's, which the
        caller discards.
        """
        h = self._highs
        verdict = first
        for options in RETRY_OPTIONS:
            for name, value in options.items():
                h.setOptionValue(name, value)
            h.clearSolver()
            self._run()
            status = h.getModelStatus()
            for name in options:
                h.setOptionValue(name, HIGHS_OPTIONS[name])
            if status == _MS.kOptimal:
                return status
            if status == _MS.kInfeasible:
                verdict = status
        return verdict

    def _load(self, lp: LinearProgram, nz: NDArray[np.bool_]) -> None:
        model = highspy.HighsLp()
        n_row, n_col = lp.A.shape
        model.num_col_ = n_col
        model.num_row_ = n_row
        model.col_cost_ = lp.c
        model.col_lower_ = _inf(lp.col_lower)
        model.col_upper_ = _inf(lp.col_upper)
        model.row_lower_ = _inf(lp.row_lower)
        model.row_upper_ = _inf(lp.row_upper)
        cols, rows = np.nonzero(nz.T)  # column-major order
        model.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        model.a_matrix_.start_ = np.concatenate(([0], np.cumsum(nz.sum(axis=0)))).astype(np.int32)
        model.a_matrix_.index_ = rows.astype(np.int32)
        model.a_matrix_.value_ = lp.A[rows, cols]
        self._highs.clearModel()
        self._highs.passModel(model)

    def _update(self, lp: LinearProgram, nz: NDArray[np.bool_], previous: FloatArray) -> None:
        h = self._highs
        n_row, n_col = lp.A.shape
        rows, cols = np.nonzero(nz & (lp.A != previous))
        for r, c in zip(rows.tolist(), cols.tolist()):
            h.changeCoeff(r, c, float(lp.A[r, c]))
        idx_c = np.arange(n_col, dtype=np.int32)
        h.changeColsCost(n_col, idx_c, lp.c)
        h.changeColsBounds(n_col, idx_c, _inf(lp.col_lower), _inf(lp.col_upper))
        if n_row:
            idx_r = np.arange(n_row, dtype=np.int32)
            h.changeRowsBounds(n_row, idx_r, _inf(lp.row_lower), _inf(lp.row_upper))


def _inf(values: FloatArray) -> FloatArray:
    """HiGHS's infinity for infinite entries."""
    return np.clip(np.asarray(values, dtype=np.float64), -highspy.kHighsInf, highspy.kHighsInf)
