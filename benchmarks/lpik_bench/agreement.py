"""Agreement checks: answers that must agree, held together with stated tolerances.

See :func:`agreement_checks` for what is compared, on which steps, and why the
tolerances are what they are.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lpik_bench import cases as C
from lpik_bench.peers import RTB_DAMPING, PeerSet
from lpik_bench.records import Record
from lpik_bench.workload import Workload

FloatArray = NDArray[np.float64]

#: Tolerances of the agreement checks (see :func:`agreement_checks`).
TOL_SAME_ALGORITHM = 1e-12  # rad: compiled vs numpy ratio test, batch vs single
TOL_HIGHS = 1e-7  # relative: ratio test vs the HiGHS LP (HiGHS tolerances are 1e-10)
TOL_DRAKE = 1e-8  # relative: Drake's QP (OSQP eps 1e-8) vs LP2 with M = I, no limit binding
TOL_DRAKE_DEFAULT = 2e-2  # relative: the same with Drake's default OSQP tolerances (as timed)
TOL_SE3_LOG = 5e-3  # relative: pink/mink's SE(3)-log task vs lpik's command along the screw


@dataclass(frozen=True)
class Agreement:
    """The outcome of one agreement check.

    Attributes:
        library: Whose answer was checked.
        method: Its method.
        compared: What was compared with what, and on which steps.
        cases: Number of steps compared.
        max_error: Largest error over those steps (unit in ``compared``).
        tolerance: The largest error allowed (for per-step tolerances, the largest of them).
        worst_ratio: Largest ``error / tolerance`` over the steps (<= 1: passed).
        note: Anything else worth knowing.
    """

    library: str
    method: str
    compared: str
    cases: int
    max_error: float
    tolerance: float
    worst_ratio: float
    note: str = ""

    @property
    def passed(self) -> bool:
        """True when at least one step was compared and every error is within tolerance."""
        return self.cases > 0 and self.worst_ratio <= 1.0

    def record(self) -> Record:
        """As a JSON record of kind ``agreement``."""
        return Record(
            self.library,
            self.method,
            "agreement",
            kind="agreement",
            extra={
                "compared": self.compared,
                "cases": self.cases,
                "max_error": self.max_error,
                "tolerance": self.tolerance,
                "passed": self.passed,
                "note": self.note,
            },
        )


def relative_errors(reference: ArrayLike, other: ArrayLike) -> FloatArray:
    """Per row ``|other - reference|_2 / |reference|_2`` (0 when both are 0; inf for NaN)."""
    ref = np.atleast_2d(np.asarray(reference, dtype=np.float64))
    oth = np.atleast_2d(np.asarray(other, dtype=np.float64))
    diff = np.linalg.norm(oth - ref, axis=1)
    size = np.linalg.norm(ref, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.where(diff == 0.0, 0.0, diff / size)
    return np.where(np.isnan(err), np.inf, err)


def check_agreement(
    library: str,
    method: str,
    compared: str,
    errors: ArrayLike,
    mask: ArrayLike,
    tolerance: float | ArrayLike,
    note: str = "",
) -> Agreement:
    """Errors on the masked steps against a tolerance (a number or one per step).

    Args:
        library: Whose answer is checked.
        method: Its method.
        compared: What is compared, on which steps, in which unit.
        errors: Error of every step, (N,).
        mask: Which steps count, (N,) bool.
        tolerance: Largest allowed error, scalar or (N,).
        note: Anything else worth knowing.
    """
    err = np.asarray(errors, dtype=np.float64)
    keep = np.asarray(mask, dtype=bool)
    tol = np.broadcast_to(np.asarray(tolerance, dtype=np.float64), err.shape)
    e, t = err[keep], tol[keep]
    if e.size == 0:
        return Agreement(library, method, compared, 0, float("nan"), float("nan"), np.inf, note)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(e == 0.0, 0.0, e / t)
    return Agreement(
        library,
        method,
        compared,
        int(e.size),
        float(e.max()),
        float(t.max()),
        float(np.nan_to_num(ratio, nan=np.inf).max()),
        note,
    )


def dls_tolerance(jacobians: ArrayLike, damping: float) -> FloatArray:
    """Bound on ``|dq_DLS - dq_pinv| / |dq_pinv|``: ``damping / sigma_min(J)^2`` per step.

    With ``dq_DLS = J^T (J J^T + damping I)^-1 e`` and ``dq_pinv = J^+ e``, each
    singular direction is shrunk by ``sigma^2 / (sigma^2 + damping)``, so the
    relative difference is at most ``damping / sigma_min^2`` (2-norm). 1 % and
    1e-12 are added for rounding.
    """
    J = np.asarray(jacobians, dtype=np.float64)
    smallest = np.linalg.svd(J, compute_uv=False)[..., -1]
    with np.errstate(divide="ignore"):
        return 1.01 * damping / smallest**2 + 1e-12


def agreement_checks(
    workload: Workload,
    problems: Sequence[Any],
    peers: PeerSet,
    batch: Any,
) -> list[Agreement]:
    """Every agreement check of the run.

    - lpik's fused step equals ``build_problem`` + :func:`lpik.methods.lp2.lp2`
      (numpy ratio test) on every step, with and without acceleration limits:
      the same algorithm, so ``max |dq_fused - dq_numpy|`` [rad] <= 1e-12 and
      the same binding label;
    - LP2's ratio test equals the general HiGHS LP (relative ``|dq|``, 1e-7);
    - :func:`lpik.fast.lp2_batch` equals ``lp2(problem, path="compiled")`` one by one
      (``max |dq|`` [rad] <= 1e-12), and ``Lp2Controller.step_batch`` equals
      ``step`` row by row (with acceleration limits; the same binding label);
    - each peer against LP2 with ``M = I`` on the steps where LP2 reaches
      ``p = 1`` (no limit binds), relative 2-norm error of ``dq``. There the
      answer is the least-norm step ``J^+ dw``: Drake's program attains
      ``alpha = 1`` with a zero null-space term, so it must equal it to its
      solver's accuracy: 1e-8 with OSQP solved to 1e-8; Drake's default OSQP
      tolerances (the timed step) are checked to 2e-2, counting the steps
      within 1e-8 in the note (the others have a bound within a fraction of a
      percent of being active, where OSQP stops early). Drake and the
      Robotics Toolbox command the chord ``p_target - p``, so they are held
      to LP2 on that command; lpik commands the displacement along the screw
      (:func:`lpik.command.along_screw`). pink and mink solve least
      squares on the SE(3) logarithm of the pose error, the same screw, but
      with the derivative of the logarithm as the task Jacobian, which differs
      from ``J`` at first order in the error (relative O(|dr|), |dr| <= 0.5
      mrad here), and daqp stops at its own tolerance: 5e-3. The Robotics Toolbox's
      damped least squares differs from ``J^+ dw`` by at most
      ``lambda^2 / sigma_min(J)^2`` relative, checked per step. Where a limit
      binds the libraries solve different problems and are not compared.
    """
    plain, acc = C.controllers(workload)
    return [
        *_fused_agreement(workload, plain, acc),
        _step_batch_agreement(workload, acc),
        _highs_agreement(problems),
        _lp2_batch_agreement(problems, batch),
        *_peer_agreement(workload, plain, peers),
    ]


def _fused_agreement(workload: Workload, plain: Any, acc: Any) -> list[Agreement]:
    """The fused step against ``build_problem`` + numpy's ``lp2``, without and with ``qdd_max``."""
    from lpik.methods.lp2 import lp2

    N = len(workload)
    out = []
    limits = (("end-stops, velocity", plain, None), ("+ acceleration", acc, workload.q_prev))
    for label, controller, prevs in limits:
        err = np.empty(N)
        for i in range(N):
            prev = None if prevs is None else prevs[i]
            controller.reset()  # independent states: no last answer to check them against
            fused = controller.step(workload.q[i], workload.targets[i], prev)
            ref = lp2(controller.problem(workload.q[i], workload.targets[i], prev))
            same = fused.binding == ref.binding and fused.status == ref.status
            err[i] = np.abs(fused.dq - ref.dq).max() if same else np.inf
        out.append(
            check_agreement(
                "lpik",
                "lp2 fused (compiled)",
                f"max |dq_fused - dq_numpy| [rad] vs build_problem + lp2 ({label}), every "
                "step; a different status or binding label counts as inf",
                err,
                np.ones(N, bool),
                TOL_SAME_ALGORITHM,
            )
        )
    return out


def _step_batch_agreement(workload: Workload, acc: Any) -> Agreement:
    """``Lp2Controller.step_batch`` against ``step`` row by row (with acceleration limits)."""
    N = len(workload)
    rows = acc.step_batch(workload.q, workload.targets, workload.q_prev)
    err = np.empty(N)
    for i in range(N):
        acc.reset()  # rows are independent states (no target motion from the row before)
        one = acc.step(workload.q[i], workload.targets[i], workload.q_prev[i])
        same = (rows.status_of(i), rows.binding_of(i)) == (one.status, one.binding)
        err[i] = np.abs(rows.dq[i] - one.dq).max() if same else np.inf
    return check_agreement(
        "lpik",
        "lp2 fused step_batch (compiled)",
        "max |dq_batch - dq_step| [rad] vs Lp2Controller.step row by row (+ acceleration); "
        "a different status or binding label counts as inf",
        err,
        np.ones(N, bool),
        TOL_SAME_ALGORITHM,
    )


def _highs_agreement(problems: Sequence[Any]) -> Agreement:
    """LP2's ratio test against the general HiGHS LP on every step."""
    from lpik.methods.lp2 import lp2

    ratio = [lp2(p) for p in problems]
    highs = [lp2(p, path="highs") for p in problems]
    err = relative_errors([r.dq for r in ratio], [h.dq for h in highs])
    p_err = np.abs(np.array([r.p for r in ratio]) - np.array([h.p for h in highs]))
    return check_agreement(
        "lpik",
        "lp2 (ratio test)",
        "relative |dq_ratio - dq_highs|_2 vs the HiGHS LP, every step",
        err,
        np.ones(len(problems), bool),
        TOL_HIGHS,
        note=f"max |p_ratio - p_highs| = {p_err.max():.2e}",
    )


def _lp2_batch_agreement(problems: Sequence[Any], batch: Any) -> Agreement:
    """:func:`lpik.fast.lp2_batch` against ``lp2(problem, path="compiled")`` one by one."""
    from lpik.fast import lp2_batch
    from lpik.methods.lp2 import lp2

    single = np.array([lp2(p, path="compiled").dq for p in problems])
    result = lp2_batch(batch, method="lp2")
    B = len(problems)
    return check_agreement(
        "lpik",
        "lp2_batch (compiled)",
        'max |dq_batch - dq_single| [rad] vs lp2(path="compiled") one by one',
        np.abs(result.dq[:B] - single).max(axis=1),
        np.ones(B, bool),
        TOL_SAME_ALGORITHM,
    )


def _chord_step(controller: Any, q: FloatArray, target: FloatArray) -> FloatArray:
    """LP2's step on the command Drake takes: the chord ``p_target - p``, not lpik's screw."""
    from lpik.command import clamp_command, task_rows
    from lpik.methods.lp2 import lp2

    model = controller.model
    dw = np.array(model.difference(model.pose(q), target), dtype=np.float64)
    clamp_command(dw, task_rows(model), controller.v_max, controller.w_max, controller.dt, math.inf)
    return lp2(controller.problem(q, target).replace(dw=dw)).dq


def _peer_agreement(workload: Workload, controller: Any, peers: PeerSet) -> list[Agreement]:
    N = len(workload)
    results = [controller.step(workload.q[i], workload.targets[i]) for i in range(N)]
    screw = np.array([r.dq for r in results])
    chord = np.array([_chord_step(controller, workload.q[i], workload.targets[i])
                      for i in range(N)])  # fmt: skip
    free = np.array([r.binding is None and r.p >= 1.0 - 1e-9 for r in results])
    bound = int(N - free.sum())
    jacobians = None
    out = []
    checked = list(peers.steps)
    if any(p.library == "drake" for p in checked):
        from lpik_bench.peers import drake_peer

        at = next(i for i, p in enumerate(checked) if p.library == "drake")
        checked.insert(at, drake_peer(workload, tight=True)[0])
    for peer in checked:
        dq = np.array([peer.step(workload.q[i], workload.targets[i]) for i in range(N)])
        # Drake's V and the Toolbox's error take the chord p_target - p; lpik, pink and
        # mink command the screw (lpik.command.along_screw, the SE(3) logarithm)
        err = relative_errors(chord if peer.library in ("drake", "rtb") else screw, dq)
        where = f"on the {int(free.sum())} of {N} steps where LP2 has p = 1"
        note = f"not compared: {bound} steps where a limit binds (different problems there)"
        if peer.library == "drake" and peer.method.endswith("(OSQP eps 1e-8)"):
            tol: Any = TOL_DRAKE
        elif peer.library == "drake":
            tol = TOL_DRAKE_DEFAULT
            strict = int((err[free] <= TOL_DRAKE).sum())
            note += (
                f"; as timed, with Drake's default OSQP tolerances: {strict} of "
                f"{int(free.sum())} steps within {TOL_DRAKE:g}, the rest where a bound is "
                "nearly active"
            )
        elif peer.library in ("pink", "mink"):
            tol = TOL_SE3_LOG
            note += "; SE(3)-log error, as lpik's command along the screw"
        elif peer.library == "rtb":
            if jacobians is None:
                jacobians = np.array([workload.model.jacobian(q) for q in workload.q])
            tol = dls_tolerance(jacobians, RTB_DAMPING)
            note += f"; per-step tolerance {RTB_DAMPING:g} / sigma_min(J)^2 (DLS bias)"
        else:
            tol = TOL_SE3_LOG
        out.append(
            check_agreement(
                peer.library,
                peer.method,
                f"relative |dq - dq_LP2|_2 vs LP2 (M = I) {where}",
                err,
                free,
                tol,
                note=note,
            )
        )
    return out
