"""A fused, compiled LP2 control step for a robot: the path a 1 kHz loop calls.

:class:`Lp2Controller` prepares everything that does not change between steps
(the chain's geometry, the limits, the weights) once; :meth:`Lp2Controller.step`
then runs forward kinematics, the Jacobian, the command law, the limits and
LP2's ratio test (eqs. 15-18) in one compiled call (:mod:`lpik.fast.step`)
and returns the same :class:`~lpik.result.Result` as building the problem with
:func:`lpik.limits.build_problem` and solving it with
:func:`lpik.methods.lp2.lp2` (tests hold the two equal). Steps the ratio test
cannot take (singular KKT matrix) go to the HiGHS path.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from time import perf_counter
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from lpik.command import (
    DEFAULT_V_MAX,
    DEFAULT_W_MAX,
    commanded_displacement,
    second_order_term,
    task_rows,
)
from lpik.control.backend_step import fuses_kinematics, step_functions
from lpik.control.controller_steps import (
    auto_bound_block,
    batch_steps,
    bounded_step,
    not_optimal_step,
)
from lpik.control.inputs import (
    chain_arrays,
    controller_limits,
    joint_vector,
    positive_number,
    rate_limits,
    target_array,
    task_value,
)
from lpik.fast import layout
from lpik.fast.batch import BatchResult
from lpik.fast.lp2_kernel import OK
from lpik.labels import step_label_table
from lpik.limits import AutomaticMultiplierBounds, Limit, MultiplierBounds, build_problem
from lpik.methods.assembly import is_diagonal
from lpik.methods.lp2 import lp2
from lpik.methods.lp2s import lp2s
from lpik.methods.progress import StallWatch
from lpik.problem import Problem, reference_configuration
from lpik.result import OPTIMAL, Result
from lpik.robots.base import TaskModel
from lpik.robots.tasks import as_task_model
from lpik.tolerances import FULL_P
from lpik.types import FloatArray


class Lp2Controller:
    """Compiled LP2 steps for one task model with fixed limits and weights.

    Args:
        model: A task of :mod:`lpik.robots.tasks` (:func:`~lpik.robots.planar.planar_arm`,
            :func:`~lpik.robots.registry.load_robot`, ``make_task(load_urdf(...))``), or
            a chain alone (its pose task, :func:`~lpik.robots.tasks.as_task_model`). Over a
            :class:`~lpik.robots.chain.SerialChain` the step is one compiled call; over
            Pinocchio or MuJoCo their kinematics run first (:mod:`lpik.control.backend_step`).
        dt: Control period [s].
        v_max: Largest commanded linear speed of the task point [m/s].
        w_max: Largest commanded angular speed of the task frame [rad/s].
        limits: The limits, as :func:`~lpik.limits.build_problem` and ``simulate`` take
            them (:class:`~lpik.limits.EndStops`, ``VelocityLimits`` [rad/s],
            ``AccelerationLimits``, ``MultiplierBounds``, ``LinearRows``); default the
            model's end-stops and velocity limits. The keywords below add to them.
        qdd_max: Symmetric joint acceleration limits [rad/s^2] (scalar or (n,)); none when None.
        velocity_limits: Without ``limits``: whether the model's ``qd_max`` bounds each step.
        lambda_bound: ``"auto"`` (default): bounds chosen per step where they
            help (:mod:`lpik.methods.autobound`); a bound ``B`` on every
            multiplier (``|lam_i| <= B``) or a :class:`~lpik.limits.MultiplierBounds`
            (sec. 3.2); ``None``: unbounded (the paper's LP2 as stated).
        M: Weight matrix of the criterion (eq. 3), as in :class:`~lpik.problem.Problem`.
        f: Weight vector of the criterion (eq. 3).
        Lambda: Smoothing weight (sec. 3.1).
        q_ref: Reference configuration (sec. 3.1); default as :class:`~lpik.problem.Problem`'s.
        G: Extra rows ``G q <= h``, (r, n).
        h: Their right-hand side, (r,).
        row_labels: Their labels.
        saturate: LP2 with saturation in the null space (method ``lp2s``,
            :func:`lpik.methods.lp2s.lp2s`), the default: a joint whose bound
            stops the step is fixed there and the others carry the command on.
            ``False``: the paper's LP2 as stated (method ``lp2``), which stops
            at the first bound it meets.
        on_stall: Opt-in progress step (:mod:`lpik.methods.progress`, status
            ``off_direction``) after this many steps with ``p = 0``; ``None``: never.
        second_order: Take off each step's command the second-order term of the
            last step's task motion (:func:`lpik.command.second_order_term`,
            from ``q_prev`` to ``q0``; the default): the error each step leaves on a
            curved path is then third order in the step, not second. ``False``:
            the command law alone, as the paper's runs command it.

    Raises:
        ValueError: For a model the compiled path does not support, or bad limits/weights.
    """

    def __init__(
        self,
        model: TaskModel,
        *,
        dt: float,
        v_max: float = DEFAULT_V_MAX,
        w_max: float = DEFAULT_W_MAX,
        limits: Sequence[Limit] | None = None,
        qdd_max: ArrayLike | None = None,
        velocity_limits: bool = True,
        lambda_bound: float | str | MultiplierBounds | None = "auto",
        M: Any = None,
        f: Any = None,
        Lambda: Any = None,
        q_ref: Any = None,
        G: Any = None,
        h: Any = None,
        row_labels: Any = None,
        saturate: bool = True,
        on_stall: int | None = None,
        second_order: bool = True,
    ) -> None:
        self.model = model = as_task_model(model)
        self.dt = positive_number("dt", dt)
        self.v_max, self.w_max = positive_number("v_max", v_max), positive_number("w_max", w_max)
        if not isinstance(velocity_limits, bool | np.bool_):
            raise ValueError(f"velocity_limits: must be True or False, got {velocity_limits!r}")
        if not isinstance(saturate, bool | np.bool_):
            raise ValueError(f"saturate: must be True or False, got {saturate!r}")
        self.method = "lp2s" if saturate else "lp2"
        if not isinstance(second_order, bool | np.bool_):
            raise ValueError(f"second_order: must be True or False, got {second_order!r}")
        #: Whether the command takes off the last step's second-order term.
        self.second_order = bool(second_order)
        self._stall = StallWatch(on_stall)
        self._bound: FloatArray | None = None  # the automatic bound of a step under it
        self._fallback = lp2s if saturate else partial(lp2, path="highs")
        origins, axes, revolute, tip = chain_arrays(model)
        self._row_index = task_rows(model)
        n, m = model.n_joints, self._row_index.size
        self.limits = controller_limits(model, limits, velocity_limits=velocity_limits,
                                        qdd_max=qdd_max, lambda_bound=lambda_bound,
                                        rows=(G, h, row_labels))  # fmt: skip
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
        # NaN where q_ref follows q0 (Problem's default), filled in by the step.
        ref = template.q_ref if q_ref is not None else reference_configuration(
            template.q_min, template.q_max, np.full(n, np.nan))  # fmt: skip
        # (6, n): q_min, q_max, qd_min, qd_max, qdd_min, qdd_max.
        bounds = np.vstack([template.q_min, template.q_max, rate_limits(self.limits, n)])
        #: The automatic multiplier bound in force (lpik.methods.autobound), or None.
        self.automatic_bound = next(
            (lim for lim in self.limits if isinstance(lim, AutomaticMultiplierBounds)), None
        )
        self._state = layout.pack(
            n, m, template.G.shape[0],
            h_diag=is_diagonal(H), dt=self.dt, v_max=self.v_max, w_max=self.w_max,
            saturate=bool(saturate),
            revolute=revolute, row_index=self._row_index, origins=origins, axes=axes, tip=tip,
            limits=bounds, criterion=H, f_ref=np.vstack([template.f, ref]),
            Lambda=template.Lambda, lam_bounds=np.vstack([template.lam_min, template.lam_max]),
            G=template.G, h=template.h, auto_bound=auto_bound_block(self.automatic_bound, model),
            second_order=[float(self.second_order), 0.0],
        )  # fmt: skip
        #: The fields of an optimal compiled step that are the same on every step.
        self._optimal_fields = {"status": OPTIMAL, "method": self.method, "path": "compiled"}
        self._kernel, self._batch = step_functions(model, self._state)
        self._out = self._state[layout.out_range(self._state)]  # the kernel writes here
        fields = layout.out_fields(self._state)
        self._q, self._dq, self._lam = fields["q"], fields["dq"], fields["lam"]
        self._p, self._label_at = fields["p"].start, fields["label"].start
        self._residual = fields["residual"].start
        self._outside = fields["outside"].start
        self._bounded_at, self._bound_at = fields["bounded"].start, fields["bound"]
        self._n, self._m = n, m
        self._labels = step_label_table(model.joint_names, m, template.row_labels)
        self._q_view = self._out[self._q]  # the kernel's q, for step_into
        self._vector_shape = (n,)
        self._last: Result | None = None  # step_into's last outcome when not optimal
        self._last_code: int | None = None  # step_into's last kernel outcome (-1: see _last)
        # a Result for step_into: the automatic bound over a backend's kinematics (its probe)
        self._python_bound = self.automatic_bound is not None and not fuses_kinematics(model)

    def step(
        self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None, *, watch: bool = True
    ) -> Result:
        """One LP2 step from ``q0`` towards ``target`` (eqs. 15-18, compiled).

        The fastest call passes C-contiguous, writable float64 arrays; anything
        else (lists, other dtypes, strided or read-only arrays) is converted first.
        A controller is not re-entrant: give each thread its own.

        Args:
            q0: Joint coordinates now, (n,) [rad or m].
            target: Commanded task value: xyz (3,) [m], a rotation (3, 3) or a
                pose (4, 4); a planar arm's xyz has z = 0, its pose turns about z.
            q_prev: Joint coordinates one period ago (acceleration limits); ``None``: at rest.
            watch: Count the step for ``on_stall`` (batch rows, independent states, do not).

        Returns:
            The same :class:`~lpik.result.Result` as the controller's method
            (``self.method``: ``lp2s`` or ``lp2``) on ``self.problem(q0, target,
            q_prev)``, with the automatic multiplier bound of the step where it
            applies.

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
        if code == OK and self._out.item(self._outside) < 0:
            out = self._out.copy()
            label = out.item(self._label_at)
            fields = self._optimal_fields.copy()  # a Result without the dataclass __init__
            fields["q"] = out[self._q]
            fields["dq"] = out[self._dq]
            fields["p"] = out.item(self._p)
            fields["lam"] = out[self._lam]
            fields["binding"] = None if label < 0 else self._labels[int(label)]
            fields["residual"] = out.item(self._residual)
            fields["solve_time"] = perf_counter() - start
            result = Result.trusted(fields)
        else:
            result = self._not_optimal(code, q0, target, q_prev, start)
        if self.automatic_bound is not None and result.p < FULL_P:
            result = self._bounded(q0, target, q_prev, result)
        if self._stall.after is None or not watch:
            return result
        return self._stall.check(result, lambda: self.problem(q0, target, q_prev))

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
        if self._stall.after is not None or self._python_bound:  # a Result
            self._last, self._last_code = self.step(q0, target, q_prev), -1
            out[...] = self._last.q
            return self._last.p
        prev = q0 if q_prev is None else q_prev
        try:
            code = self._kernel(self._state, q0, prev, target)
        except TypeError:  # not C-contiguous writable float64 arrays: convert them
            q0, target, prev = self._converted(q0, target, q_prev)
            code = self._kernel(self._state, q0, prev, target)
        if code == OK and self._out.item(self._outside) < 0:
            self._last_code = code
            out[...] = self._q_view
            return self._out.item(self._p)
        result = self._not_optimal(code, q0, target, q_prev, perf_counter())
        self._last, self._last_code = self._bounded(q0, target, q_prev, result), -1
        out[...] = self._last.q
        return self._last.p

    @property
    def last_status(self) -> str | None:
        """Status of the last :meth:`step_into` (``None`` before the first)."""
        if self._last_code is None:
            return None
        return OPTIMAL if self._last_code == OK else self._last.status

    @property
    def last_binding(self) -> str | None:
        """The limit that bound the last :meth:`step_into` (``None``: none, or no step yet)."""
        if self._last_code is None:
            return None
        if self._last_code != OK:
            return self._last.binding
        label = self._out.item(self._label_at)
        return None if label < 0 else self._labels[int(label)]

    def step_batch(
        self, q0: ArrayLike, targets: ArrayLike, q_prev: ArrayLike | None = None
    ) -> BatchResult:
        """Many independent steps, one per row: in parallel over a SerialChain, else in turn.

        Row ``b`` of the answer equals ``step(q0[b], targets[b], q_prev[b])``
        (tests hold them equal): for sweeps over configurations (how much of a
        command the arm can follow across its workspace), many robots, or
        sampled starts. Rows the ratio test cannot take go to the HiGHS path
        one by one, as in :meth:`step` (:func:`lpik.control.controller_steps.batch_steps`).

        Args:
            q0: Joint coordinates, (B, n).
            targets: One commanded task value per row: (B, 3) xyz, (B, 3, 3)
                rotations or (B, 4, 4) poses.
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
        return batch_steps(self, q0, targets, q_prev)

    def _not_optimal(self, code: int, q0: Any, target: Any, q_prev: Any, start: float) -> Result:
        """The Result of a kernel outcome other than OK (:func:`not_optimal_step`)."""
        return not_optimal_step(self, code, q0, target, q_prev, start)

    def _bounded(self, q0: Any, target: Any, q_prev: Any, unbounded: Result) -> Result:
        """The automatic multiplier bound where the kernel did not apply it (a backend, HiGHS)."""
        if (self.automatic_bound is None or unbounded.p >= FULL_P or self._bound is not None
                or self._out.item(self._bounded_at) >= 0):  # fmt: skip
            return unbounded
        return bounded_step(self, q0, target, q_prev, unbounded)

    def _converted(
        self, q0: Any, target: Any, q_prev: Any, check_finite: bool = False
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``q0``, the target and ``q_prev`` as the kernel's arrays, or a ValueError naming them."""
        q0 = joint_vector("q0", q0, self._n, check_finite)
        prev = q0 if q_prev is None else joint_vector("q_prev", q_prev, self._n, check_finite)
        return q0, target_array(target, check_finite), prev

    def _problem(
        self, J: FloatArray, dw: FloatArray, q0: FloatArray, q_prev: FloatArray | None
    ) -> Problem:
        P = build_problem(J, dw, q0, self.limits, dt=self.dt, q_prev=q_prev, **self._weights)
        if self._bound is None:  # (else a step under the automatic bound: lpik.methods.autobound)
            return P
        return P.replace(lam_min=np.maximum(P.lam_min, -self._bound),
                         lam_max=np.minimum(P.lam_max, self._bound))  # fmt: skip

    def problem(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Problem:
        """The step's :class:`~lpik.problem.Problem`, built by the pure-numpy layers.

        The command is the one law of :mod:`lpik.command`: the
        displacement to the target (along the screw on a pose task), clamped
        to ``v_max dt`` and ``w_max dt``, less the last step's second-order
        term where ``second_order`` is on.
        """
        q0 = np.asarray(q0, dtype=np.float64)
        for name, value in (("q0", q0), ("q_prev", q_prev), ("target", target)):
            if value is not None and not np.isfinite(np.asarray(value, dtype=np.float64)).all():
                raise ValueError(f"{name}: contains NaN or inf")
        model = self.model
        dw = commanded_displacement(model, model.pose(q0), task_value(model, target), self.v_max,
                                    self.w_max, self.dt)  # fmt: skip
        if self.second_order and q_prev is not None:
            dw -= second_order_term(model, q_prev, q0)
        return self._problem(
            model.jacobian(q0),
            dw,
            q0,
            None if q_prev is None else np.asarray(q_prev, float),
        )
