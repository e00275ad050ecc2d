"""A fused, compiled LP2 control step for a robot: the path a 1 kHz loop calls.

:class:`Lp2Controller` prepares everything that does not change between steps
(the chain's geometry, the limits, the weights) once; :meth:`Lp2Controller.step`
then runs forward kinematics, the Jacobian, the command law, the limits and
LP2's ratio test (eqs. 15-18) in one compiled call and returns the same
:class:`~lpik.result.Result` as building the problem with
:func:`lpik.limits.build_problem` and solving it with
:func:`lpik.methods.lp2.lp2` (tests hold the two equal). Steps the ratio test
cannot take (singular KKT matrix) go to the HiGHS path.
"""

from __future__ import annotations

from time import perf_counter
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike

from lpik import result as st
from lpik.fast import chain_kernels as CK
from lpik.fast import kernels as K
from lpik.fast.batch import BatchResult, is_diagonal
from lpik.limits import AccelerationLimits, LinearRows, build_problem, standard_limits
from lpik.methods.lp2 import lp2
from lpik.problem import Problem
from lpik.result import Result
from lpik.robots.base import FloatArray, TaskModel
from lpik.robots.planar import PlanarArm

# Building a Result from a dict of its fields skips the frozen dataclass's __init__,
# the largest Python cost of a step (the kernel checked the answer itself).
_new = object.__new__
_set_dict = object.__setattr__
#: The fields of an optimal compiled step that are the same on every step.
_OPTIMAL_FIELDS = {"status": st.OPTIMAL, "method": "lp2", "path": "compiled"}

ROW_INDEX = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5}


class Lp2Controller:
    """Compiled LP2 steps for one task model with fixed limits and weights.

    Args:
        model: A :class:`~lpik.robots.planar.PlanarArm`, or a task of
            :mod:`lpik.robots.tasks` over a :class:`~lpik.robots.chain.SerialChain`.
        dt: Control period [s].
        v_max: Largest commanded linear speed of the task point [m/s].
        w_max: Largest commanded angular speed of the task frame [rad/s].
        qdd_max: Symmetric joint acceleration limits [rad/s^2] (scalar or (n,)); none when None.
        velocity_limits: Whether the model's ``qd_max`` bounds each step (eq. 14).
        lambda_bound: Symmetric bound on every multiplier (sec. 3.2); none when None.
        M, f, Lambda, q_ref: Weights of the criterion (eq. 3, sec. 3.1), as in
            :class:`~lpik.problem.Problem`.
        G, h, row_labels: Extra rows ``G q <= h``.

    Raises:
        ValueError: For a model the compiled path does not support, or bad limits/weights.
    """

    def __init__(
        self,
        model: TaskModel,
        *,
        dt: float,
        v_max: float = 0.5,
        w_max: float = 1.0,
        qdd_max: ArrayLike | None = None,
        velocity_limits: bool = True,
        lambda_bound: float | None = None,
        M: Any = None,
        f: Any = None,
        Lambda: Any = None,
        q_ref: Any = None,
        G: Any = None,
        h: Any = None,
        row_labels: Any = None,
    ) -> None:
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt: must be a finite number > 0, got {dt}")
        if not (v_max > 0 and w_max > 0):
            raise ValueError("v_max, w_max: must be > 0")
        self.model = model
        self.dt, self.v_max, self.w_max = float(dt), float(v_max), float(w_max)
        n = model.n_joints
        self._kind, geometry, rows = _geometry(model)
        self._rows = np.array(rows, dtype=np.int64)
        m = len(rows)
        limits = standard_limits(model, velocity=velocity_limits, lambda_bound=lambda_bound)
        if qdd_max is not None:
            limits.append(AccelerationLimits(np.broadcast_to(np.asarray(qdd_max, float), (n,))))
        if G is not None or h is not None:
            limits.append(LinearRows(G, h, tuple(row_labels or ())))
        self.limits = tuple(limits)
        self._weights = {
            "M": M,
            "f": f,
            "Lambda": Lambda,
            "q_ref": q_ref,
            "joint_names": model.joint_names,
        }
        # One validated template problem checks every weight and limit once.
        template = self._problem(
            np.zeros((m, n)), np.zeros(m), np.clip(np.zeros(n), model.q_min, model.q_max), None
        )
        H = template.M + template.Lambda
        if q_ref is None:  # Problem's default: midpoint of finite end-stops, else q0 (NaN here)
            finite = np.isfinite(template.q_min) & np.isfinite(template.q_max)
            mid = 0.5 * (
                np.where(finite, template.q_min, 0.0) + np.where(finite, template.q_max, 0.0)
            )
            ref = np.where(finite, mid, np.nan)
        else:
            ref = template.q_ref
        qd = np.broadcast_to(np.asarray(model.qd_max, float), (n,)) if velocity_limits else \
            np.full(n, np.inf)  # fmt: skip
        qdd = np.full(n, np.inf) if qdd_max is None else np.broadcast_to(
            np.asarray(qdd_max, float), (n,))  # fmt: skip
        # (6, n): q_min, q_max, qd_min, qd_max, qdd_min, qdd_max.
        bounds = np.vstack([template.q_min, template.q_max, -qd, qd, -qdd, qdd])
        constants = (bounds, H, np.vstack([template.f, ref]), template.Lambda,
                     np.vstack([template.lam_min, template.lam_max]), template.G, template.h,
                     np.array([self.dt, self.v_max, self.w_max]))  # fmt: skip
        if self._kind == "planar":
            revolute = np.ones(n)
            self._kernel = CK.step_kernel("planar")
        else:
            origins, axes, revolute, tip = geometry
            geometry = (origins, axes, tip)
            self._kernel = CK.step_kernel("chain")
        self._state, o_out = CK.pack_state(revolute, rows, is_diagonal(H), geometry, constants)
        size = CK.out_size(n, m)
        self._out = self._state[o_out : o_out + size]  # the kernel writes here
        self._p, self._label_at, self._residual = size - 3, size - 2, size - 1
        self._n, self._m = n, m
        self._q_slice, self._dq_slice, self._lam_slice = slice(0, n), slice(n, 2 * n), \
            slice(2 * n, 2 * n + m)  # fmt: skip
        self._labels = _label_table(model.joint_names, m, template.row_labels)
        self._q_view = self._out[:n]  # the kernel's q, for step_into
        self._vector_shape = (n,)
        self._last: Result | None = None  # step_into's last outcome when not optimal
        self._last_code: int | None = None  # step_into's last kernel outcome

    def step(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Result:
        """One LP2 step from ``q0`` towards ``target`` (eqs. 15-18, compiled).

        The fastest call passes C-contiguous, writable float64 arrays; anything
        else (lists, other dtypes, strided or read-only arrays) is converted first.
        A controller is not re-entrant: give each thread its own.

        Args:
            q0: Joint coordinates now, (n,) [rad or m].
            target: Commanded task value: (x, y[, angle]) for the planar arm; xyz,
                a rotation (3, 3) or a pose (4, 4) for the 3-D tasks.
            q_prev: Joint coordinates one period ago (acceleration limits); ``None``: at rest.

        Returns:
            The same :class:`~lpik.result.Result` as ``lp2(self.problem(q0, target, q_prev))``.
            One case differs: when ``q_prev`` implies a last step the acceleration
            limits cannot bring back within the velocity limits in one period,
            :meth:`problem` rejects the crossed bounds (``ValueError``) while this
            returns the infeasible safe step naming both limits.

        Raises:
            ValueError: For a ``q0``, ``q_prev`` or ``target`` of the wrong shape, or
                non-finite values.
        """
        start = perf_counter()
        prev = q0 if q_prev is None else q_prev
        try:
            code = self._kernel(self._state, q0, prev, target)
        except TypeError:  # not C-contiguous writable float64 arrays: convert them
            q0, target, prev = self._converted(q0, target, q_prev)
            code = self._kernel(self._state, q0, prev, target)
        if code == K.OK:
            out = self._out.copy()
            label = out.item(self._label_at)
            fields = _OPTIMAL_FIELDS.copy()  # a Result without the dataclass __init__
            fields["q"] = out[self._q_slice]
            fields["dq"] = out[self._dq_slice]
            fields["p"] = out.item(self._p)
            fields["lam"] = out[self._lam_slice]
            fields["binding"] = None if label < 0 else self._labels[int(label)]
            fields["residual"] = out.item(self._residual)
            fields["solve_time"] = perf_counter() - start
            result = _new(Result)
            _set_dict(result, "__dict__", fields)
            return result
        return self._not_optimal(code, q0, target, q_prev, start)

    def step_into(
        self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None, *, out: FloatArray
    ) -> float:
        """:meth:`step` without building a :class:`~lpik.result.Result`: no allocation.

        For the tightest loops: the next joint coordinates go into ``out`` and the
        step's ``p`` is returned; :attr:`last_status` and :attr:`last_binding`
        tell the step's status and binding limit until the next step. The
        answers are those of :meth:`step`.

        Args:
            q0: Joint coordinates now, as for :meth:`step`.
            target: Commanded task value, as for :meth:`step`.
            q_prev: Joint coordinates one period ago, as for :meth:`step`.
            out: A float64 array of shape (n,) that receives ``q`` (``q0`` itself
                when no step is possible).

        Returns:
            The affine dexterity ``p`` of the step (0 for the safe step).

        Raises:
            ValueError: For a bad ``out``, and as :meth:`step`.
        """
        if getattr(out, "shape", None) != self._vector_shape or out.dtype != np.float64:
            raise ValueError(
                f"out: must be a float64 array of shape ({self._n},), got "
                f"{getattr(out, 'dtype', type(out).__name__)} {getattr(out, 'shape', '')}"
            )
        prev = q0 if q_prev is None else q_prev
        try:
            code = self._kernel(self._state, q0, prev, target)
        except TypeError:  # not C-contiguous writable float64 arrays: convert them
            q0, target, prev = self._converted(q0, target, q_prev)
            code = self._kernel(self._state, q0, prev, target)
        if code == K.OK:
            self._last_code = code
            out[...] = self._q_view
            return self._out.item(self._p)
        result = self._not_optimal(code, q0, target, q_prev, perf_counter())
        self._last, self._last_code = result, code
        out[...] = result.q
        return result.p

    @property
    def last_status(self) -> str | None:
        """Status of the last :meth:`step_into` (``None`` before the first)."""
        if self._last_code is None:
            return None
        return st.OPTIMAL if self._last_code == K.OK else self._last.status

    @property
    def last_binding(self) -> str | None:
        """The limit that bound the last :meth:`step_into` (``None``: none, or no step yet)."""
        if self._last_code is None:
            return None
        if self._last_code != K.OK:
            return self._last.binding
        label = self._out.item(self._label_at)
        return None if label < 0 else self._labels[int(label)]

    def step_batch(
        self, q0: ArrayLike, targets: ArrayLike, q_prev: ArrayLike | None = None
    ) -> BatchResult:
        """Many independent steps at once, one per row, in parallel (numba threads).

        Row ``b`` of the answer equals ``step(q0[b], targets[b], q_prev[b])``
        (tests hold them equal): for sweeps over configurations (how much of a
        command the arm can follow across its workspace), many robots, or
        sampled starts. Rows the ratio test cannot take go to the HiGHS path
        one by one, as in :meth:`step`.

        Args:
            q0: Joint coordinates, (B, n).
            targets: One commanded task value per row: (B, m) for the planar
                arm; (B, 3) xyz, (B, 3, 3) rotations or (B, 4, 4) poses for the
                3-D tasks.
            q_prev: Joint coordinates one period earlier, (B, n); ``None``: at rest.

        Returns:
            A :class:`~lpik.fast.batch.BatchResult`: stacked ``q``, ``dq``, ``p``
            and ``lam`` (NaN rows for safe steps), each row's status and binding
            limit (``status_of``, ``binding_of``) and ``result[b]`` as a
            :class:`~lpik.result.Result`.

        Raises:
            ValueError: For arrays of the wrong shape, rows that disagree in
                number, or values that are not finite (naming the row).
        """
        n, m = self._n, self._m
        Q0 = _rows("q0", q0, ((n,),))
        B = Q0.shape[0]
        Qp = Q0 if q_prev is None else _rows("q_prev", q_prev, ((n,),), B)
        shapes = ((m,),) if self._kind == "planar" else ((3,), (3, 3), (4, 4))
        T = _rows("targets", targets, shapes, B)
        outs = np.empty((B, self._out.shape[0]))
        codes = np.empty(B, dtype=np.int64)
        CK.step_batch_kernel(self._kind)(
            self._state, Q0, Qp, T, outs, codes, 4 * numba.get_num_threads()
        )
        if (codes == CK.BAD_INPUT).any():  # _rows checked every row: a bug if it happens
            raise ValueError(f"row {int(np.argmax(codes == CK.BAD_INPUT))}: rejected by the step")
        q, dq = outs[:, :n].copy(), outs[:, n : 2 * n].copy()
        lam, p = outs[:, 2 * n : 2 * n + m].copy(), outs[:, self._p].copy()
        labels = outs[:, self._label_at].astype(np.int64)
        infeasible = codes == K.INFEASIBLE
        q[infeasible], dq[infeasible], p[infeasible], lam[infeasible] = Q0[infeasible], 0, 0, np.nan
        fallback: dict[int, Result] = {}
        for b in np.nonzero((codes != K.OK) & ~infeasible)[0].tolist():  # the HiGHS path
            prev_b = None if q_prev is None else Qp[b]
            res = self._not_optimal(int(codes[b]), Q0[b], T[b], prev_b, perf_counter())
            fallback[b] = res
            q[b], dq[b], p[b] = res.q, res.dq, res.p
            lam[b] = np.nan if res.lam is None else res.lam
        table = self._labels
        return BatchResult(q=q, dq=dq, p=p, lam=lam, codes=codes, binding_codes=labels,
                           _labels=lambda b: table, _fallback=fallback)  # fmt: skip

    def _not_optimal(self, code: int, q0: Any, target: Any, q_prev: Any, start: float) -> Result:
        """The Result of a kernel outcome other than OK: infeasible, bad input or the HiGHS path."""
        if code == K.INFEASIBLE:
            label = self._out.item(self._label_at)
            return Result.trusted(
                q=np.array(q0, dtype=np.float64), dq=np.zeros(self._n), p=0.0, lam=None,
                status=st.INFEASIBLE, binding=self._labels[int(label)], method="lp2",
                solve_time=perf_counter() - start, residual=0.0, path="compiled",
            )  # fmt: skip
        if code == CK.BAD_INPUT:
            self._converted(q0, target, q_prev, check_finite=True)  # raises, naming the input
        return lp2(self.problem(q0, target, q_prev), path="highs")

    def _converted(
        self, q0: Any, target: Any, q_prev: Any, check_finite: bool = False
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``q0``, the target and ``q_prev`` as the kernel's arrays, or a ValueError naming them."""
        q0 = _vector("q0", q0, self._n, check_finite)
        prev = q0 if q_prev is None else _vector("q_prev", q_prev, self._n, check_finite)
        goal = _target(target, self._m if self._kind == "planar" else None, check_finite)
        return q0, goal, prev

    def _problem(
        self, J: FloatArray, dw: FloatArray, q0: FloatArray, q_prev: FloatArray | None
    ) -> Problem:
        return build_problem(J, dw, q0, self.limits, dt=self.dt, q_prev=q_prev, **self._weights)

    def problem(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Problem:
        """The step's :class:`~lpik.problem.Problem`, built by the pure-numpy layers."""
        q0 = np.asarray(q0, dtype=np.float64)
        for name, value in (("q0", q0), ("q_prev", q_prev), ("target", target)):
            if value is not None and not np.isfinite(np.asarray(value, dtype=np.float64)).all():
                raise ValueError(f"{name}: contains NaN or inf")
        model = self.model
        dw = np.asarray(model.difference(model.pose(q0), np.asarray(target, float)), float)
        rows = self._rows
        lin = float(np.linalg.norm(dw[rows < 3]))
        ang = float(np.linalg.norm(dw[rows >= 3]))
        scale = 1.0
        if lin > self.v_max * self.dt:
            scale = min(scale, self.v_max * self.dt / lin)
        if ang > self.w_max * self.dt:
            scale = min(scale, self.w_max * self.dt / ang)
        return self._problem(
            model.jacobian(q0),
            dw * scale,
            q0,
            None if q_prev is None else np.asarray(q_prev, float),
        )


def _geometry(model: TaskModel) -> tuple[str, tuple, tuple[int, ...]]:
    """Arrays of the compiled kinematics and the kept task rows, or a ValueError."""
    if isinstance(model, PlanarArm):
        rows = (0, 1) if model.task_dim == 2 else (0, 1, 3)
        return "planar", (np.ascontiguousarray(model.link_lengths),), rows
    chain = getattr(model, "kinematics", None)
    row_names = getattr(model, "row_names", None)
    joints = getattr(chain, "joints", None)
    if joints is None or row_names is None:
        raise ValueError(
            f"model: the compiled path supports PlanarArm and tasks over a SerialChain, not "
            f"{type(model).__name__}"
        )
    origins = np.ascontiguousarray(np.array([j.origin for j in joints], dtype=np.float64))
    axes = np.ascontiguousarray(np.array([j.axis for j in joints], dtype=np.float64))
    revolute = np.array([j.kind == "revolute" for j in joints])
    tip = np.ascontiguousarray(chain.tip_offset @ chain.tool)
    return "chain", (origins, axes, revolute, tip), tuple(ROW_INDEX[r] for r in row_names)


def _vector(name: str, value: Any, n: int, check_finite: bool) -> FloatArray:
    """A writable C-contiguous float64 copy of a joint vector of length ``n``."""
    try:
        v = np.array(value, dtype=np.float64, order="C")
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be {n} numbers, got {type(value).__name__}") from None
    if v.shape != (n,):
        raise ValueError(f"{name}: must have length {n}, got shape {v.shape}")
    if check_finite and not np.isfinite(v).all():
        raise ValueError(f"{name}: contains NaN or inf")
    return v


def _rows(
    name: str, value: Any, shapes: tuple[tuple[int, ...], ...], count: int | None = None
) -> FloatArray:
    """A C-contiguous float64 stack (B, *shape) of finite rows, or a ValueError naming them.

    ``shapes`` lists the accepted shapes of one row; ``count`` the required B.
    """
    try:
        arr = np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: must be numbers, got {type(value).__name__}") from None
    if arr.ndim == 0 or arr.shape[1:] not in shapes or arr.shape[0] == 0:
        wanted = " or ".join(str(("B",) + s).replace("'", "") for s in shapes)
        raise ValueError(f"{name}: must have shape {wanted} with B >= 1, got {arr.shape}")
    if count is not None and arr.shape[0] != count:
        raise ValueError(f"{name}: must have {count} rows (one per row of q0), got {arr.shape[0]}")
    finite = np.isfinite(arr).reshape(arr.shape[0], -1).all(axis=1)
    if not finite.all():
        raise ValueError(f"{name}: row {int(np.argmin(finite))} contains NaN or inf")
    return arr


def _target(target: Any, m: int | None, check_finite: bool) -> FloatArray:
    """A writable C-contiguous float64 copy of the target.

    (m,) for the planar arm (``m`` given), else xyz (3,), a rotation (3, 3) or a pose (4, 4).
    """
    try:
        t = np.array(target, dtype=np.float64, order="C")
    except (TypeError, ValueError):
        raise ValueError(f"target: must be numbers, got {type(target).__name__}") from None
    if m is not None and t.shape != (m,):
        raise ValueError(f"target: must have length {m}, got shape {t.shape}")
    if m is None and t.shape not in ((3,), (3, 3), (4, 4)):
        raise ValueError(
            f"target: must be xyz (3,), a rotation (3, 3) or a pose (4, 4), got {t.shape}"
        )
    if check_finite and not np.isfinite(t).all():
        raise ValueError("target: contains NaN or inf")
    return t


def _label_table(
    joint_names: tuple[str, ...] | list[str], m: int, row_labels: tuple[str, ...]
) -> tuple[str, ...]:
    """Every binding label a step can report.

    In the order of :func:`lpik.fast.chain_kernels.binding_label_index`.
    """
    kinds = ("end-stop", "velocity limit", "acceleration limit")
    labels = []
    for name in joint_names:
        for side in ("lower", "upper"):
            labels += [f"{name} {side} {kind}" for kind in kinds]
    for k in range(m):
        labels += [f"multiplier {k + 1} lower bound", f"multiplier {k + 1} upper bound"]
    for label in row_labels:
        labels += [label, label]
    for name in joint_names:
        labels += [f"{name} lower {low} / {name} upper {high}" for low in kinds for high in kinds]
    return tuple(labels)
