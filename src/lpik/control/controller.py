"""The compiled engine: one LP2 control step in one compiled call, the path a 1 kHz loop calls.

:class:`Lp2Controller` runs the stages of :mod:`lpik.control.stepper`
(kinematics, command, limits, LP2 or LP2 with saturation, the automatic
multiplier bound) fused into one compiled call (:mod:`lpik.fast.step`) over a
state buffer prepared once (:mod:`lpik.fast.layout`), and returns the same
:class:`~lpik.result.Result` as the numpy engine,
:class:`~lpik.control.stepper.Stepper`, on the same limits and weights (tests
hold the two equal). The controller owns such a stepper: every step the
kernel does not answer itself goes to its stages (the HiGHS path where the KKT
matrix is singular, the bound policy over a backend's kinematics, the stall
stage), and :meth:`Lp2Controller.problem` is its problem.

Over a :class:`~lpik.robots.chain.SerialChain` the kinematics are compiled
into the step; over Pinocchio or MuJoCo their kinematics run first
(:mod:`lpik.control.backend_step`). With a scene, the velocity damper's
distance rows are one more limit: rows of the state's ``ROWS_G``/``ROWS_H``
block, computed inside the compiled step (:mod:`lpik.fast.avoiding_step`) or
written from coal before it (:class:`SceneRows`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from time import perf_counter
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike

from lpik.collision import CollisionAvoidance
from lpik.collision.avoidance import INACTIVE_RHS, with_force
from lpik.collision.model import as_avoidance
from lpik.collision.recovery import (
    RECOVERY,
    demanding_rows,
    inside_pairs,
    is_stop,
    keeps_direction,
    kept_within_rows,
    marked_recovering,
    recovery_motion,
    recovery_result,
    rows_kept,
)
from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX, TargetMotion
from lpik.continuation import through_rest
from lpik.control.backend_step import fuses_kinematics, step_functions
from lpik.control.commanded import REPORTED_AS_FAULT
from lpik.control.inputs import (
    TARGET_SHAPES,
    chain_arrays,
    joint_vector,
    numbers_of,
    rate_limits,
    stacked_rows,
    target_array,
    task_value,
)
from lpik.control.stepper import Stepper
from lpik.control.warmup import Warmup, cached, compile_mode, compile_now, warmup
from lpik.defaults import DEFAULT_MODE, DEFAULT_ON_STALL
from lpik.fast import layout
from lpik.fast.autobound import bound_in_state, floor_in_state, settings
from lpik.fast.batch import BatchResult
from lpik.fast.lp2_kernel import INFEASIBLE as KERNEL_INFEASIBLE
from lpik.fast.lp2_kernel import OK
from lpik.fast.outcome import compiled_result
from lpik.fast.progress import (
    NOT_STALLED,
    SOLVED,
    STALLED,
    further_stage,
    largest_share_lp,
    least_error,
    least_l1_in_state,
    stall_stage,
    state_rows,
)
from lpik.fast.step import BAD_INPUT, brake_rows
from lpik.labels import Binding, row_label, step_label_table
from lpik.limits import LambdaBound, Limit, Piece, StepContext
from lpik.methods.assembly import is_diagonal
from lpik.methods.autobound import floor_row
from lpik.methods.l1 import past_criterion, scaled_status
from lpik.methods.progress import (
    STALLS,
    held_by_acceleration,
    held_by_row,
    held_by_velocity,
    progress_result,
    stall_limit,
)
from lpik.problem import Problem, check_magnitude, reference_configuration
from lpik.result import INFEASIBLE, OPTIMAL, RECOVERING, SCALED, Result
from lpik.robots.base import TaskModel
from lpik.tolerances import FULL_P, STALL_P
from lpik.types import FloatArray

__all__ = ["Lp2Controller", "SceneRows", "StateRows"]


@dataclass(frozen=True, eq=False)
class StateRows:
    """The rows the last step left in the state buffer, as a limit of the numpy layers.

    Attributes:
        G: View of the state's rows block, (r, n).
        h: View of their right-hand side, (r,).
        labels: One label per row.
    """

    G: FloatArray
    h: FloatArray
    labels: tuple[str, ...]

    def apply(self, context: StepContext) -> Piece:
        """The rows as they are now (copies)."""
        return Piece(G=self.G.copy(), h=self.h.copy(), row_labels=self.labels)


class SceneRows:
    """A scene's distance rows as rows of a controller's state: one row per pair it watches.

    Robot-obstacle pairs, then the self-collision pairs; each step fills the
    rows of the pairs within the influence distance with the velocity
    damper's rows (Faverjon and Tournassoud 1987,
    :class:`lpik.collision.DistanceRows`) and leaves the others as
    ``0 q <= INACTIVE_RHS``, which never binds. With the potential field
    (the paper's eq. 3, after Khatib 1986) :meth:`write` also sets the step's ``f``.

    Args:
        model: The task model.
        avoidance: The scene's collision avoidance.
    """

    def __init__(self, model: TaskModel, avoidance: CollisionAvoidance) -> None:
        self.avoidance = avoidance
        #: Whether the compiled step computes the distances, rows and force itself.
        self.in_kernel = False
        probe = avoidance.proximities.at(
            np.clip(np.zeros(model.n_joints), model.q_min, model.q_max)
        )
        #: Each row's pair, spelled as a binding names it.
        self.labels = tuple(p.label for p in probe)
        self.model = model

    def reserved(self) -> tuple[FloatArray, FloatArray, tuple[str, ...]]:
        """The rows to reserve in the state: ``(G, h, labels)``, every row inactive."""
        r, n = len(self.labels), self.model.n_joints
        return np.zeros((r, n)), np.full(r, INACTIVE_RHS), self.labels

    def attach(self, state: FloatArray, stepper: Stepper) -> None:
        """Read and write the rows, and ``f``, in ``state``; ``stepper``'s limits read them.

        Afterwards :attr:`G` (r, n) and :attr:`h` (r,) are views of the state's rows.
        """
        r, n = len(self.labels), self.model.n_joints
        g0, h0, f0 = (int(state[slot]) for slot in (layout.ROWS_G, layout.ROWS_H, layout.F_REF))
        self.G, self.h = state[g0 : g0 + r * n].reshape(r, n), state[h0 : h0 + r]
        self._f, self._stepper = state[f0 : f0 + n], stepper
        # with the field alone the pairs inside d_s; under acceleration limits also the
        # pairs beyond d_i that must brake ahead of it
        self._rows = self.avoidance.rows(stepper.accelerations)
        f = stepper.weights.get("f")
        self._f0 = np.zeros(n) if f is None else np.broadcast_to(np.asarray(f, float), (n,)).copy()
        stepper.limits = (*stepper.limits[:-1], StateRows(self.G, self.h, self.labels))

    def write(self, q0: FloatArray, target: Any, q_prev: Any) -> None:
        """This step's rows (and force) by coal into the state buffer.

        The field's force is scaled within the step's own room (:meth:`field_weights`).
        Where the compiled step computes the distances itself (:attr:`in_kernel`), it
        adds the field to its criterion itself, and only the numpy engine's ``f``
        holds it.
        """
        self.G[:] = 0.0
        self.h[:] = INACTIVE_RHS
        before = None if q_prev is None else np.asarray(q_prev, dtype=np.float64)
        pairs, G, h = self._rows.pair_rows(q0, self._stepper.dt, before)
        self.G[pairs] = G
        self.h[pairs] = h
        f = self.field_weights(q0, target, q_prev)
        if not self.in_kernel:
            self._f[:] = f

    def field_weights(self, q0: FloatArray, target: Any, q_prev: Any) -> FloatArray:
        """The criterion's ``f`` with the field's force at ``q0``: the numpy engine's, returned.

        The force is scaled within the step's own room
        (:func:`lpik.collision.avoidance.with_force`), read off the numpy engine's
        problem for this step over the rows the state holds, its acceleration bands
        included (as :meth:`lpik.collision.CollisionAvoidance.with_field` does on the
        numpy engine).
        """
        force = self.avoidance.field_at(q0, self._stepper.dt)
        f = self._f0
        if force is not None:  # its share of this step's room: the numpy engine's problem
            self._stepper.weights["f"] = self._f0
            f = with_force(self._stepper.problem(q0, target, q_prev), force).f
        self._stepper.weights["f"] = f
        return f


def compiled_least_error(*arrays: Any) -> tuple[str, FloatArray]:
    """:func:`lpik.fast.progress.least_error` as the recovery's LP takes it: ``(status, dq)``.

    ``arrays``: ``J, target, lower, upper, G, g`` (:data:`lpik.collision.recovery.LeastError`).
    """
    code, dq = least_error(*arrays)
    return (OPTIMAL if code == SOLVED else INFEASIBLE), dq


def compiled_largest_share(*arrays: Any) -> float | None:
    """:func:`lpik.fast.progress.largest_share_lp` as the recovery takes it: the share or None.

    ``arrays``: ``G, b, demand, lower, upper`` (:data:`lpik.collision.recovery.LargestShare`).
    """
    code, share = largest_share_lp(*(np.ascontiguousarray(a, dtype=np.float64) for a in arrays))
    return float(share) if code == SOLVED else None


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
        on_stall: The progress step (:mod:`lpik.methods.progress`, compiled in
            :mod:`lpik.fast.progress`; status ``off_direction``, ``p = 0``) after this
            many stalled steps in a row (:func:`lpik.methods.progress.is_stall`); default
            :data:`lpik.defaults.DEFAULT_ON_STALL` (1); ``None``: never, the paper's
            strict steps (the direction or no motion).
        mode: ``"exact"`` (default): keep the commanded direction (the paper's
            contract); ``"progress"``: after every exact step with ``p < 1``, spend
            what the limits leave on the task error that remains (compiled,
            :func:`lpik.fast.progress.further_progress`; status ``off_direction``,
            ``p`` the exact step's).
        second_order: Take off each step's command the second-order term of the
            last step's task motion (:func:`lpik.command.second_order_term`,
            from ``q_prev`` to ``q0``; the default): the error each step leaves on a
            curved path is then third order in the step, not second. ``False``:
            the command law alone, as the paper's runs command it.
        continuation: Under acceleration limits (the default ``True``), solve
            each step around the current motion, ``J (dq - last) = p (dw - J last)``
            with ``last = q0 - q_prev`` (:mod:`lpik.continuation`: ``p`` is the
            share of the commanded change of the task motion), and slow the
            command down in time to stop on its target
            (:func:`lpik.command.braking_scale`). ``False``: the paper's step
            through ``dq = 0`` and the command law alone.
        scene: Obstacles to keep clear of, as one more limit: a
            :class:`~lpik.collision.Scene` (the velocity damper's rows) or a
            :class:`~lpik.collision.CollisionAvoidance` (rows, field or both). Not
            with ``G``, ``h``, ``row_labels``: the rows are the scene's.
        home: With a Scene: a configuration at which touching self-collision
            pairs are dropped; None: only the pairs that touch everywhere are
            (:func:`lpik.collision.distance.robot_bodies`).
        compiled_distances: Compute the distances, the damper's rows and the potential
            field's force inside the compiled step (``False``: through coal in Python).
        compile: When the kernels compile (:mod:`lpik.control.warmup`): ``"background"``
            (the default, :data:`lpik.defaults.DEFAULT_COMPILE`, or ``LPIK_COMPILE``
            in the environment): loaded from numba's disk cache when it has them,
            else the steps run on the numpy engine (the same answers; each step
            some hundred microseconds) while a child process compiles them, and
            compiled from the first step after it is done; ``"now"``: compiled
            when the controller is built (about a minute on an empty cache). With
            a ``scene`` they always compile when it is built.

    Raises:
        ValueError: For a model the compiled path does not support, or bad limits/weights.
    """

    #: The typed kernel that keeps the fused step's memory of the target's motion after a
    #: corrected ``q_prev`` (:func:`lpik.fast.commanded.follow_kernel`); None until loaded.
    _follow_kernel: Any = None
    #: The velocity fault the last :meth:`step_into`'s state had and its memory replaced
    #: (``CommandedMotion.fault``), reported by :attr:`last_status`.
    _fault: Binding | None = None

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
        lambda_bound: LambdaBound = "auto",
        M: Any = None,
        f: Any = None,
        Lambda: Any = None,
        q_ref: Any = None,
        G: Any = None,
        h: Any = None,
        row_labels: Any = None,
        saturate: bool = True,
        on_stall: int | None = DEFAULT_ON_STALL,
        mode: str = DEFAULT_MODE,
        second_order: bool = True,
        continuation: bool = True,
        scene: Any = None,
        home: ArrayLike | None = None,
        compiled_distances: bool = True,
        compile: str | None = None,
    ) -> None:
        if not isinstance(saturate, bool | np.bool_):
            raise ValueError(f"saturate: must be True or False, got {saturate!r}")
        scene_rows = self._scene_rows(model, scene, home, (G, h, row_labels))
        #: The numpy engine over the same limits and weights: the stages the kernel hands on.
        self.stepper = Stepper(
            model, dt=dt, method="lp2s" if saturate else "lp2", limits=limits,
            weights={"M": M, "f": f, "Lambda": Lambda, "q_ref": q_ref}, v_max=v_max,
            w_max=w_max, lambda_bound=lambda_bound, qdd_max=qdd_max,
            velocity_limits=velocity_limits,
            rows=(G, h, row_labels) if scene_rows is None else scene_rows.reserved(),
            second_order=second_order, on_stall=on_stall, warm_start=False,
            continuation=continuation, mode=mode,
        )  # fmt: skip
        s = self.stepper
        self.model, self.dt, self.method = s.model, s.dt, s.method
        self.v_max, self.w_max, self.second_order = s.v_max, s.w_max, s.second_order
        #: The automatic multiplier bound in force (lpik.methods.autobound), or None.
        self.automatic_bound = s.automatic_bound
        self._fallback_path = None if saturate else "highs"
        self._bound: FloatArray | None = None  # the automatic bound of a step under it
        self._state = self._packed(bool(saturate), scene_rows is None)
        # compiled (or loaded) for the target the task takes; another kind when first given
        self._target_axes = (2,) if (np.asarray(s.task_rows) >= 3).any() else (1,)
        self._read_out_blocks()
        self._watch_stall = s.stall_watch.after is not None
        self._further = s.mode == "progress"  # mode="progress"'s second stage after each step
        #: The stall stage's kernels beside the fused step (:data:`lpik.control.warmup.STAGES`).
        self._stages = (
            (("progress",) if self._watch_stall or self._further else ())
            + (("further",) if self._further else ())
            + (("recovery",) if scene_rows is not None else ())
            + (("bound",) if self.automatic_bound is not None and fuses_kinematics(model) else ())
            + (("motion",) if s.motion is not None else ())
        )
        #: The last step answered, against which a measured loop's next state is checked
        #: (:mod:`lpik.control.commanded`; the numpy engine's own), or None.
        self.motion = s.motion
        self._warmup: Warmup | None = None  # the child compiling the kernels, if one is
        # the steps go to the numpy engine: while the child compiles, and for good if it failed
        self._on_numpy_engine = False
        self._numpy_inputs: tuple[Any, Any, Any] | None = None  # the numpy engine's last step
        background = compile_mode(compile) == "background" and scene_rows is None
        if background and not cached(self._target_axes, self._stages):
            self._warmup = warmup(self._target_axes, self._stages)
            self._on_numpy_engine = True
        else:  # before the scene's rows: a compiled scene step replaces the kernel
            self._load_kernels()
        #: The scene's rows in the state (:class:`SceneRows`), or None without a scene.
        self.scene_rows = scene_rows
        #: Each pair's distance, witness points and normal after the last step (P, 10).
        self.found: FloatArray | None = None
        if scene_rows is not None:
            scene_rows.attach(self._state, s)
            if bool(compiled_distances):
                self._compile_distances(scene_rows.avoidance)
        self._coal_rows = scene_rows is not None and self.found is None  # rows written first
        self._last: Result | None = None  # step_into's last outcome when not optimal
        self._last_code: int | None = None  # step_into's last kernel outcome (-1: see _last)
        # a Result for step_into: the automatic bound over a backend's kinematics (its probe)
        self._python_bound = self.automatic_bound is not None and not fuses_kinematics(model)

    def _load_kernels(self) -> None:
        """Compile (or load) the fused step and the stall stage's kernels: not inside a loop."""
        compile_now(self._target_axes, self._stages)
        self._kernel, self._batch = step_functions(self.model, self._state, self._target_axes)
        if self.motion is not None:
            from lpik.fast.commanded import follow_kernel, motion_kernels

            self.motion.compiled(*motion_kernels())
            self._follow_kernel = follow_kernel()

    @property
    def engine(self) -> str:
        """The engine the next step runs on: ``"compiled"`` or ``"numpy"``.

        ``"numpy"`` while the kernels compile in the background
        (:mod:`lpik.control.warmup`), or where that compile failed.
        """
        return "numpy" if self._on_numpy_engine else "compiled"

    def _on_numpy(self) -> bool:
        """Whether this step goes to the numpy engine; moves to the compiled one when ready.

        Checked before each step while a child compiles: once it has exited and the
        kernels load from the disk cache, they are loaded, the last numpy step is
        taken again by the fused step (so its memory of the target's motion is the
        stepper's), and every later step is compiled. A child that failed leaves the
        controller on the numpy engine, with a warning.
        """
        if self._warmup is None:  # compiled, or for good on numpy (the child failed)
            return self._on_numpy_engine
        if not self._warmup.finished():
            return True
        if cached(self._target_axes, self._stages):
            self._warmup, self._on_numpy_engine = None, False
            self._load_kernels()
            if self._numpy_inputs is not None:
                self._run(*self._numpy_inputs)
            return False
        failure = self._warmup.failure()
        if failure is None:  # done, but not with every kernel now wanted (a new target kind)
            self._warmup = warmup(self._target_axes, self._stages)
            return True
        self._warmup = None
        warnings.warn(f"{failure}; the controller goes on with the numpy engine",
                      RuntimeWarning, stacklevel=3)  # fmt: skip
        return True

    def _numpy_step(self, q0: Any, target: Any, q_prev: Any) -> Result:
        """The numpy engine's step on the state :meth:`step` has checked, remembered.

        :meth:`lpik.control.stepper.Stepper._step_as_given`: no second check, no second hold.
        """
        result = self.stepper._step_as_given(q0, target, q_prev)
        q, goal, prev = self._converted(q0, target, q_prev)  # copies: the caller may reuse them
        self._numpy_inputs = (q.copy(), goal.copy(), prev.copy())
        return result

    @property
    def limits(self) -> tuple[Limit, ...]:
        """The limits every step holds (those of :attr:`stepper`)."""
        return self.stepper.limits

    @property
    def compiled(self) -> bool:
        """Whether a scene's distances and rows are computed inside the compiled step."""
        return self.found is not None

    @property
    def avoidance(self) -> CollisionAvoidance | None:
        """The scene's collision avoidance, or None."""
        return None if self.scene_rows is None else self.scene_rows.avoidance

    @property
    def pair_labels(self) -> tuple[str, ...]:
        """The scene's pairs, one per reserved row (empty without a scene)."""
        return () if self.scene_rows is None else self.scene_rows.labels

    # -- setting up -----------------------------------------------------------------------

    @staticmethod
    def _scene_rows(model: Any, scene: Any, home: Any, rows: tuple[Any, ...]) -> SceneRows | None:
        if scene is None:
            return None
        for key, value in zip(("G", "h", "row_labels"), rows):
            if value is not None:
                raise ValueError(f"{key}: the rows of a controller with a scene are the scene's")
        home_q = None if home is None else np.asarray(home, dtype=np.float64)
        return SceneRows(model, as_avoidance(model, scene, home_q))

    def _packed(self, saturate: bool, rows_braked: bool) -> FloatArray:
        """The state buffer: the template problem's limits and weights, checked once.

        ``rows_braked``: the rows are the user's, limits on ``q`` kept with a stop ahead
        under acceleration limits (not a scene's).
        """
        model, n = self.model, self.model.n_joints
        m = model.task_dim
        template = self.stepper.limited(np.clip(np.zeros(n), model.q_min, model.q_max),
                                        np.zeros(m), None, np.zeros((m, n)),
                                        brake_rows=False)  # fmt: skip
        H = template.M + template.Lambda
        # NaN where q_ref follows q0 (Problem's default), filled in by the step.
        ref = template.q_ref
        if self.stepper.weights.get("q_ref") is None:
            ref = reference_configuration(template.q_min, template.q_max, np.full(n, np.nan))
        origins, axes, revolute, tip = chain_arrays(model)
        self._n, self._m = n, m
        self._floor = np.empty(n + 1)  # the bound's floor as the progress step's row (_on_floor)
        self._residual_out = np.empty(1)  # the stall stage's residual (_stalled)
        self._labels = step_label_table(model.joint_names, m, template.row_labels)
        #: An optimal step's fields as :func:`compiled_result` decodes them; the fast
        #: path of :meth:`step` copies it and fills in the numbers.
        self._optimal_fields = dict(
            compiled_result(OK, np.empty(0), np.empty(0), 0.0, None, None, None, self.method,
                            0.0, 0.0, 1.0).__dict__
        )  # fmt: skip
        #: A stalled step's fields (:func:`~lpik.methods.progress.progress_result`'s
        #: progress step); :meth:`_stalled` copies it and fills in the numbers.
        self._progress_fields = dict(
            progress_result(np.zeros(n), np.ones(n), np.zeros((0, n)), np.zeros(0), 1.0, 0.0,
                            None, 0.0, "compiled").__dict__
        )  # fmt: skip
        #: The criterion stage's step's fields (Ho's LP past the full displacement);
        #: :meth:`_scaled` copies it and fills in the numbers.
        self._scaled_fields = dict(
            Result(q=np.zeros(n), dq=np.zeros(n), p=0.0, lam=None, status=SCALED, binding=None,
                   method="l1", path="compiled").__dict__
        )  # fmt: skip
        return layout.pack(
            n, m, template.G.shape[0],
            h_diag=is_diagonal(H), dt=self.dt, v_max=self.v_max, w_max=self.w_max,
            saturate=saturate, revolute=revolute, row_index=self.stepper.task_rows,
            origins=origins, axes=axes, tip=tip,
            limits=np.vstack([template.q_min, template.q_max, rate_limits(self.limits, n)]),
            criterion=H, f_ref=np.vstack([template.f, ref]), Lambda=template.Lambda,
            lam_bounds=np.vstack([template.lam_min, template.lam_max]), G=template.G,
            h=template.h, rows_braked=[float(rows_braked)],
            auto_bound=settings(self.automatic_bound, fuses_kinematics(model)),
            second_order=[float(self.second_order), 0.0],
            continuation=[float(self.stepper.continues)], chain=[float(fuses_kinematics(model))],
        )  # fmt: skip

    def _read_out_blocks(self) -> None:
        """Where the kernel writes each out block, for the step's decoding."""
        self._out = self._state[layout.out_range(self._state)]
        fields = layout.out_fields(self._state)
        self._q, self._dq, self._lam = fields["q"], fields["dq"], fields["lam"]
        self._p, self._label_at = fields["p"].start, fields["label"].start
        self._residual, self._outside = fields["residual"].start, fields["outside"].start
        self._pull_scale_at = fields["pull_scale"].start
        self._bounded_at, self._bound_at = fields["bounded"].start, fields["bound"]
        self._dw = fields["dw"]
        self._q_view = self._out[self._q]  # the kernel's q, for step_into
        self._vector_shape = (self._n,)
        self._singular_at = int(self._state[layout.SINGULAR])  # the stop ahead, for _on_floor

    def _compile_distances(self, avoidance: CollisionAvoidance) -> None:
        """The fused step with the scene's distances, rows and field inside (fast.avoiding_step)."""
        from lpik.fast.avoiding_step import avoiding_kernel, pack_bodies

        field = avoidance.mechanism != "rows"
        arrays = pack_bodies(avoidance.proximities, self.dt, avoidance.approach_speed,
                             avoidance.field_gain if field else 0.0,
                             avoidance.mechanism == "field")  # fmt: skip
        self.found = arrays[6]
        self.scene_rows.in_kernel = True
        self._kernel = partial(avoiding_kernel(self._target_axes), *arrays)

    # -- one step -------------------------------------------------------------------------

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
                Where it is the ``q0`` of the last step and the step it implies differs
                from the one answered by more than the acceleration limits allow in a
                period (a measured loop's noise), it is taken at the nearest step the
                drives could have made (:attr:`motion`, :mod:`lpik.control.commanded`).
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
        motion = self.motion
        if motion is None or not watch:
            return self._step(q0, target, q_prev, watch)
        taken = motion.admit(q0, q_prev)
        if taken is not q_prev:
            self._follow(q0, q_prev, taken)
        result = motion.reported(self._step(q0, target, taken, True))
        motion.hold(q0, result.q)
        return result

    def _follow(self, q0: Any, q_prev: Any, taken: FloatArray) -> None:
        """The check took ``taken`` for ``q_prev``: the step still follows the last one.

        The memories that feed the target's motion forward, the fused step's (once its
        kernels are loaded) and the numpy layers' (the numpy engine's, and the problems
        the fallbacks build), are keyed by ``taken`` (:func:`lpik.command.continues_with`).
        """
        q, prev = (np.ascontiguousarray(v, dtype=np.float64) for v in (q0, q_prev))
        if self._follow_kernel is not None:
            self._follow_kernel(self._state, q, prev, taken)
        self.stepper.target_motion.follow(q, prev, taken)

    def _step(self, q0: Any, target: Any, q_prev: Any, watch: bool = True) -> Result:
        """:meth:`step` on the state as given (no check against the last answer)."""
        start = perf_counter()
        if self._on_numpy_engine:  # the kernels are not ready yet
            if self._on_numpy():
                return self._numpy_step(q0, target, q_prev)
        if self._coal_rows:
            code = self._run(q0, target, q_prev)
        else:  # the kernel straight away: its fast path
            try:
                code = self._kernel(self._state, q0, q0 if q_prev is None else q_prev, target)
            except TypeError:  # not C-contiguous writable float64 arrays: convert them
                code = self._run(q0, target, q_prev)
        out = self._out
        if code == OK and out.item(self._outside) < 0:
            out = out.copy()
            label = out.item(self._label_at)
            fields = self._optimal_fields.copy()  # compiled_result's decoding, numbers filled in
            fields["q"] = out[self._q]
            fields["dq"] = out[self._dq]
            fields["p"] = out.item(self._p)
            fields["lam"] = out[self._lam]
            fields["binding"] = None if label < 0 else self._labels[int(label)]
            fields["residual"] = out.item(self._residual)
            fields["pull_scale"] = out.item(self._pull_scale_at)
            fields["solve_time"] = perf_counter() - start
            result = Result.trusted(fields)
        else:
            result = self._not_optimal(code, q0, target, q_prev, start)
        if self.automatic_bound is not None and result.p < FULL_P:
            result = self._bounded(q0, target, q_prev, result)
        if watch and (self._watch_stall or self._further):
            result = self._stalled(result, q0, q_prev, count=True)
        if watch and result.status == INFEASIBLE:
            result = self._unanswered(q0, target, q_prev, result)
        if self.scene_rows is not None:
            result = self._recovered(q0, target, q_prev, result)
        if watch and result.p == 0.0:  # a stop may break a row (most steps move: p > 0)
            result = self._within_rows(q0, q_prev, result)
        return result

    def _unanswered(self, q0: Any, target: Any, q_prev: Any, safe: Result) -> Result:
        """A safe step after the stall stage: the through-rest stage, then the criterion stage."""
        return self._scaled(q0, q_prev, self._through_rest(q0, target, q_prev, safe))

    def _through_rest(self, q0: Any, target: Any, q_prev: Any, around: Result) -> Result:
        """The through-rest stage (:meth:`Stepper.rested <lpik.control.stepper.Stepper.rested>`).

        A moving arm's safe step after the stall stage: the fused step again with
        the state's ``continuation`` block at -1 (the same command, the paper's line
        within the same bounds, the stops ahead kept, the automatic bound as that
        step takes it: :func:`lpik.fast.step.stops_ahead`), chosen by
        :func:`lpik.continuation.through_rest`. With the stall stage only.
        """
        flag = int(self._state[layout.CONTINUATION])
        if (not self._watch_stall or self._on_numpy_engine or q_prev is None
                or self._state[flag] == 0.0
                or np.array_equal(np.asarray(q0), np.asarray(q_prev))):  # fmt: skip
            return around  # (the numpy engine's step has had its own stage)
        ahead = self._state.item(self._singular_at)  # the step's stop before a singular one
        self._state[flag] = -1.0
        try:
            rest = self._step(q0, target, q_prev, watch=False)
        finally:
            self._state[flag] = 1.0
        chosen = through_rest(around, rest)
        if chosen is around:  # the state's step is the one around the motion (_scaled reads it)
            self._state[self._singular_at] = ahead
        return chosen

    def _recovered(self, q0: Any, target: Any, q_prev: Any, result: Result) -> Result:
        """The recovery stage: from inside the scene's safety distance the distance grows back.

        The rule of :mod:`lpik.collision.recovery` on the rows and LP inputs the
        compiled step left in the state (:meth:`_recovered_in_state`), its LPs
        compiled (:mod:`lpik.fast.progress`); on the step's problem
        (:meth:`lpik.collision.CollisionAvoidance.recovered`) where a pair inside
        has no row there (the field's) or no LP answers; ``result`` where no pair is inside.
        """
        avoidance = self.avoidance
        inside = {} if avoidance is None else self.inside(q0)
        if not inside:
            return result
        rows = self._inside_rows(q0, inside)
        if rows is not None and result.method != RECOVERY:
            stepped = self._recovered_in_state(q0, q_prev, result, rows)
            if stepped is not None:
                return stepped
        problem = self._stepped_problem(q0, target, q_prev, self._bound)
        return avoidance.recovered(problem, result, self.dt, compiled_least_error, inside,
                                   compiled_largest_share)  # fmt: skip

    def _within_rows(self, q0: Any, q_prev: Any, result: Result) -> Result:
        """The rows stage (:meth:`Stepper.within_rows <lpik.control.stepper.Stepper.within_rows>`).

        :func:`lpik.collision.recovery.kept_within_rows` on the bounds and rows the
        compiled step left in its state (:func:`lpik.fast.progress.state_rows`), its
        LPs compiled; the numpy engine's step has had the stepper's own stage.
        """
        r = int(self._state[layout.R])
        if not is_stop(result) or self._on_numpy_engine or not r:
            return result
        q = np.ascontiguousarray(q0, dtype=np.float64)
        G, h = layout.matrix_at(self._state, layout.ROWS_G, r, self._n), layout.vector(
            self._state, layout.ROWS_H)  # fmt: skip
        g = h - G @ q
        brake_rows(self._state, q, g)  # a user's rows: with their stops ahead
        if rows_kept(G, g, result.dq):  # most stops: no bounds recomputed
            return result
        prev = q if q_prev is None else np.ascontiguousarray(q_prev, dtype=np.float64)
        J, _, lower, upper, G, g = state_rows(self._state, q, prev, True, False)  # own bands
        return kept_within_rows(result, q, J, lower, upper, G, g, compiled_least_error,
                                compiled_largest_share)  # fmt: skip

    def _inside_rows(self, q0: Any, inside: dict[str, float]) -> list[int] | None:
        """The state's rows that demand an increase of an ``inside`` pair's distance.

        :func:`~lpik.collision.recovery.demanding_rows`, deepest first. None (the numpy
        rule on the step's problem decides) where no row demands, or where a pair inside
        has no such row and the numpy rule would add it (the potential field alone writes
        no rows); with the damper's rows the state holds every row there is (a pair whose
        segments cross has no gradient, and no row on any path).
        """
        labels, G = self.scene_rows.labels, self.scene_rows.G
        g = self.scene_rows.h - G @ np.asarray(q0, dtype=np.float64)
        rows = demanding_rows(labels, G, g, inside)
        complete = self.scene_rows.avoidance.mechanism != "field"
        if not rows or not (complete or {labels[j] for j in rows} == set(inside)):
            return None
        return rows

    def _recovered_in_state(
        self, q0: Any, q_prev: Any, result: Result, rows: list[int]
    ) -> Result | None:
        """The recovery rule (:func:`lpik.collision.recovery.recovered`) on the state's arrays.

        ``result`` marked ``recovering`` where it keeps the direction and the rows
        (:func:`~lpik.collision.recovery.keeps_direction`,
        :func:`~lpik.collision.recovery.rows_kept`); else the recovery step
        (:func:`~lpik.collision.recovery.recovery_motion`) on the step's ``J``,
        ``dw``, bounds and rows as the compiled step left them
        (:func:`lpik.fast.progress.state_rows`), no numpy problem built. None where
        no LP answers (the problem's safe step is the answer then).
        """
        start = perf_counter()
        q = np.ascontiguousarray(q0, dtype=np.float64)
        labels = self.scene_rows.labels
        binding = row_label(rows[0], labels[rows[0]]).outside()
        prev = q if q_prev is None else np.ascontiguousarray(q_prev, dtype=np.float64)
        J, dw, lower, upper, G, g = state_rows(self._state, q, prev, True, True)
        if keeps_direction(result) and rows_kept(G[rows], g[rows], result.dq):
            return marked_recovering(result, binding)
        dq = recovery_motion(J, dw, lower, upper, G, g, rows, compiled_least_error,
                             compiled_largest_share)  # fmt: skip
        if dq is None:
            return None
        return recovery_result(q, dq, J, binding, perf_counter() - start)

    def _stepped_problem(self, q0: Any, target: Any, q_prev: Any, bound: Any) -> Problem:
        """The :class:`~lpik.problem.Problem` of the step the kernel has just run at ``q0``.

        Its scene rows are read from the state, where that step left them (the
        kernel's distances, or coal's written before it), not computed again
        (:meth:`problem` computes them).
        """
        q0, target, q_prev = self._checked(q0, target, q_prev)
        if self.found is not None and self.avoidance.mechanism != "rows":  # the field's f at q0
            self.scene_rows.field_weights(np.asarray(q0, dtype=np.float64), target, q_prev)
        return self.stepper.problem(q0, target, q_prev, bound=bound)

    def inside(self, q0: ArrayLike) -> dict[str, float]:
        """The pairs inside the safety distance at ``q0``, just stepped from: label -> distance.

        Read from the compiled step's distances where it computes them, else from
        coal's (which the step's rows have just asked for at ``q0``); empty without a scene.
        """
        avoidance = self.avoidance
        if avoidance is None:
            return {}
        if self.found is None:
            return avoidance.inside(np.asarray(q0, dtype=np.float64))
        return inside_pairs(self.pair_labels, self.found[:, 0], avoidance.scene.safety_distance)

    def _run(self, q0: Any, target: Any, q_prev: Any) -> int:
        """The kernel on the step's inputs (converted where they are not its arrays)."""
        if self._coal_rows:  # the scene's rows from coal, before the kernel
            q0 = np.ascontiguousarray(q0, dtype=np.float64)
            if q0.shape != self._vector_shape or not np.isfinite(q0).all():
                raise ValueError(f"q0: must be {self._n} finite coordinates")
            self.scene_rows.write(q0, target, q_prev)
        prev = q0 if q_prev is None else q_prev
        try:
            return self._kernel(self._state, q0, prev, target)
        except TypeError:  # not C-contiguous writable float64 arrays: convert them
            q0, target, prev = self._converted(q0, target, q_prev)
            self._ready_for(target.ndim)
            return self._kernel(self._state, q0, prev, target)

    def _ready_for(self, target_axes: int) -> None:
        """The compiled step readied for targets of ``target_axes`` axes too (compiled once)."""
        if target_axes in self._target_axes:
            return
        self._target_axes = (*self._target_axes, target_axes)
        if self._on_numpy_engine:  # the switch readies them all
            return
        if self.found is not None:  # the step with the scene's distances inside
            from lpik.fast.avoiding_step import avoiding_kernel

            avoiding_kernel((target_axes,))  # the same dispatcher as self._kernel's
        else:
            step_functions(self.model, self._state, (target_axes,))

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
        motion = self.motion
        if motion is not None:
            taken = motion.admit(q0, q_prev)
            if taken is not q_prev:
                self._follow(q0, q_prev, taken)
            q_prev = taken
        p = self._step_into(q0, target, q_prev, out)
        if self.scene_rows is not None and self.inside(q0):
            self._last, self._last_code = self._step(q0, target, q_prev), -1  # the recovery stage
            out[...] = self._last.q
            p = self._last.p
        if motion is not None:
            motion.hold(q0, out)
            self._fault = motion.fault
        return p

    def _step_into(self, q0: Any, target: Any, q_prev: Any, out: FloatArray) -> float:
        """:meth:`step_into` but for the recovery stage."""
        if self._further or self._python_bound or self._on_numpy_engine:  # a Result
            self._last, self._last_code = self._step(q0, target, q_prev), -1
            out[...] = self._last.q
            return self._last.p
        if self._coal_rows:
            code = self._run(q0, target, q_prev)
        else:
            try:
                code = self._kernel(self._state, q0, q0 if q_prev is None else q_prev, target)
            except TypeError:  # not C-contiguous writable float64 arrays: convert them
                code = self._run(q0, target, q_prev)
        if code == OK and self._out.item(self._outside) < 0:
            p = self._out.item(self._p)
            # no stall: the kernel's step stands (within the band the stall stage decides)
            if not self._watch_stall or p > stall_limit(self.stepper.stall_watch.engaged):
                self.stepper.stall_watch.clear()
                self._last_code = code
                out[...] = self._q_view
                return p
        result = self._not_optimal(code, q0, target, q_prev, perf_counter())
        self._last, self._last_code = self._bounded(q0, target, q_prev, result), -1
        if self._watch_stall:
            self._last = self._stalled(self._last, q0, q_prev, count=True)
        if self._last.status == INFEASIBLE:
            self._last = self._unanswered(q0, target, q_prev, self._last)
        self._last = self._within_rows(q0, q_prev, self._last)
        out[...] = self._last.q
        return self._last.p

    @property
    def last_status(self) -> str | None:
        """Status of the last :meth:`step_into` (``None`` before the first)."""
        if self._last_code is None:
            return None
        status = OPTIMAL if self._last_code == OK else self._last.status
        return RECOVERING if self._faulted(status) else status

    @property
    def last_binding(self) -> str | None:
        """The limit that bound the last :meth:`step_into` (``None``: none, or no step yet)."""
        if self._last_code is None:
            return None
        status = OPTIMAL if self._last_code == OK else self._last.status
        if self._faulted(status):
            return self._fault
        if self._last_code != OK:
            return self._last.binding
        label = self._out.item(self._label_at)
        return None if label < 0 else self._labels[int(label)]

    def _faulted(self, status: str) -> bool:
        """Whether the last :meth:`step_into` reports its state's velocity fault, not ``status``.

        As :meth:`~lpik.control.commanded.CommandedMotion.reported` does for a Result.
        """
        return self._fault is not None and status in REPORTED_AS_FAULT

    # -- steps the kernel hands on ------------------------------------------------------------

    def _not_optimal(self, code: int, q0: Any, target: Any, q_prev: Any, start: float) -> Result:
        """The Result of a kernel outcome other than an optimal step from within the limits.

        A step from outside the limits (``recovering``) and the kernel's safe step
        (``infeasible``) are read from the state's out blocks; bad input raises a
        ValueError naming it; anything else goes to the stepper's HiGHS path.
        """
        if code in (OK, KERNEL_INFEASIBLE):
            out, outside = self._out.copy(), int(self._out.item(self._outside))
            label = int(out.item(self._label_at))
            return compiled_result(
                code, out[self._q], out[self._dq], out.item(self._p), out[self._lam],
                None if label < 0 else self._labels[label],
                self._labels[outside].outside() if outside >= 0 else None, self.method,
                out.item(self._residual), perf_counter() - start, out.item(self._pull_scale_at),
            )  # fmt: skip
        if code == BAD_INPUT:
            self._converted(q0, target, q_prev, check_finite=True)  # raises, naming the input
        bound = self._bound
        if bound is None and self._out.item(self._bounded_at) > 0:  # the fused step's own bound
            bound = self._out[self._bound_at].copy()
        problem = self._stepped_problem(q0, target, q_prev, bound)
        return self.stepper.solve(problem, path=self._fallback_path)

    def _scaled(self, q0: Any, q_prev: Any, result: Result) -> Result:
        """The criterion stage (:meth:`Stepper.scaled <lpik.control.stepper.Stepper.scaled>`).

        Where LP2's conditions admit no step (the kernel's safe step), Ho's LP past
        the full displacement on the step the kernel left in the state, compiled
        (:func:`lpik.fast.progress.least_l1_in_state`); the numpy engine's step has
        had the stepper's own stage. With the stall stage only, from within the limits.
        """
        if (not self._watch_stall or self._on_numpy_engine or not past_criterion(result)
                or self._out.item(self._outside) >= 0):  # fmt: skip
            return result
        start = perf_counter()
        q = np.ascontiguousarray(q0, dtype=np.float64)
        prev = q if q_prev is None else np.ascontiguousarray(q_prev, dtype=np.float64)
        dq = np.empty(self._n)
        code, p, label = least_l1_in_state(self._state, q, prev, dq, self._residual_out)
        if code != SOLVED:
            return result
        fields = self._scaled_fields.copy()
        fields["q"], fields["dq"], fields["p"] = q + dq, dq, p
        fields["status"] = scaled_status(p)  # p >= FULL_P exactly where LP1's largest is
        fields["binding"] = None if label < 0 else self._labels[int(label)]
        fields["residual"] = self._residual_out.item(0)
        fields["solve_time"] = perf_counter() - start
        return Result.trusted(fields)

    def _stalled(self, result: Result, q0: Any, q_prev: Any, *, count: bool) -> Result:
        """The stall stage, compiled (:func:`lpik.fast.progress.stall_stage`), on the step.

        The rule is the stepper's (:class:`~lpik.methods.progress.StallWatch`,
        :func:`~lpik.methods.progress.stalls`), decided in one compiled call;
        ``count=False`` (a batch row, an independent state without history) takes
        the progress step only where one stalled step is enough (``on_stall=1``). In
        ``mode="progress"`` a step that did not stall gets the second stage. ``J``
        and ``dw`` are the step's, as the kernel left them in the state; the bounds
        are recomputed from ``q0`` and ``q_prev``.
        """
        watch = self.stepper.stall_watch
        further = self._further and result.status == OPTIMAL and result.p < 1.0
        may_stall = (watch.after is not None and result.status in STALLS
                     and result.p <= stall_limit(watch.engaged))  # fmt: skip
        if not (may_stall or further):  # nearly every step: nothing more to do
            if count:
                watch.clear()
            return result
        start = perf_counter()
        q = np.ascontiguousarray(q0, dtype=np.float64)
        prev = q if q_prev is None else np.ascontiguousarray(q_prev, dtype=np.float64)
        if may_stall:
            dq = np.empty(self._n)
            decision = stall_stage(
                self._state, q, prev, np.ascontiguousarray(result.dq, dtype=np.float64),
                result.p, held_by_acceleration(result.binding), held_by_velocity(result.binding),
                held_by_row(result.binding),
                count and watch.engaged_at(q),
                self._on_floor(q), dq, self._residual_out,
            )  # fmt: skip
            stall = decision != NOT_STALLED
            stalled = watch.count(stall) if count else watch.after == 1 and stall
            if stalled and decision == STALLED:  # p 0; binding: what stopped the direction
                return self._progress_step(q, dq, 0.0, result.binding, start)
            if stalled or not further:
                return result
        return self._further_step(result, q, prev, start)

    def _further_step(self, exact: Result, q: FloatArray, prev: FloatArray, start: float) -> Result:
        """``mode="progress"``'s second stage after the exact step (:func:`further_stage`)."""
        dq = np.empty(self._n)
        dq1 = np.ascontiguousarray(exact.dq, dtype=np.float64)
        if not further_stage(self._state, q, prev, dq1, dq, self._residual_out):
            return exact
        return self._progress_step(q, dq, exact.p, exact.binding, start)  # the exact step's p

    def _progress_step(
        self, q: FloatArray, dq: FloatArray, p: float, binding: Any, start: float
    ) -> Result:
        """The stage's step from ``q`` as a Result (status ``off_direction``).

        Its residual is the one the stage's kernel left in ``self._residual_out``.
        """
        fields = self._progress_fields.copy()
        fields["q"], fields["dq"], fields["p"], fields["binding"] = q + dq, dq, p, binding
        fields["residual"] = self._residual_out.item(0)
        fields["solve_time"] = perf_counter() - start
        return Result.trusted(fields)

    def _on_floor(self, q: FloatArray) -> FloatArray:
        """The bound's floor as the progress step's row, where the step's motion reached it.

        :meth:`Stepper.on_floor <lpik.control.stepper.Stepper.on_floor>`'s rule on the
        state: where the stop ahead found the floor 0 steps away (the ``singular``
        block), :func:`lpik.methods.autobound.floor_row`, compiled over a SerialChain
        (:func:`lpik.fast.autobound.floor_in_state`), else over the backend's Jacobian.
        Returns the row and its right-hand side (last entry; inf: none).
        """
        n, floor = self._n, self._floor
        floor[n] = math.inf
        limit = self.automatic_bound
        if limit is None or self._state.item(self._singular_at) != 0.0:
            return floor
        if fuses_kinematics(self.model):
            floor[n] = floor_in_state(self._state, q, floor)
        else:
            J = layout.matrix_at(self._state, layout.JACOBIAN, self._m, n)
            floor[n] = floor_row(J, self.model.jacobian, q, limit.activation, limit.floor,
                                 limit.probe, self.dt, floor)  # fmt: skip
        return floor

    def _bounded(self, q0: Any, target: Any, q_prev: Any, unbounded: Result) -> Result:
        """The bound policy where the kernel did not apply it (a backend's kinematics, HiGHS).

        The rule is :func:`lpik.methods.autobound.automatic_bound`: compiled over
        a SerialChain (:func:`lpik.fast.autobound.bound_in_state`), else the
        stepper's :meth:`~lpik.control.stepper.Stepper.bound_of`. The bound is
        written into the state's multiplier bounds for one compiled step (the
        step's own rule switched off, and into the problem of its HiGHS path),
        then restored.
        """
        if (self.automatic_bound is None or unbounded.p >= FULL_P or self._bound is not None
                or self._out.item(self._bounded_at) >= 0 or not unbounded.moved):  # fmt: skip
            return unbounded
        q = np.ascontiguousarray(q0, dtype=np.float64)
        if fuses_kinematics(self.model):  # the rule, compiled, on the step the state holds
            dq = np.ascontiguousarray(unbounded.dq, dtype=np.float64)
            bound = self._out[self._bound_at].copy() if bound_in_state(self._state, q, dq) else None
        else:
            start = int(self._state[layout.JACOBIAN])  # the step's J, as the kernel left it
            J = self._state[start : start + self._m * self._n].reshape(self._m, self._n).copy()
            bound = self.stepper.bound_of(q, J, unbounded)
        if bound is None:
            return unbounded
        block = layout.matrix_at(self._state, layout.LAM_BOUNDS, 2, self._m)
        on = int(self._state[layout.AUTO_BOUND])
        saved, saved_on = block.copy(), self._state[on]
        block[0], block[1] = np.maximum(saved[0], -bound), np.minimum(saved[1], bound)
        self._state[on], self._bound = -1.0, bound  # -1: solved under a bound given to it
        try:
            return self._step(q0, target, q_prev, watch=False)
        finally:
            block[...], self._state[on], self._bound = saved, saved_on, None

    # -- many steps -----------------------------------------------------------------------

    def step_batch(
        self, q0: ArrayLike, targets: ArrayLike, q_prev: ArrayLike | None = None
    ) -> BatchResult:
        """Many independent steps, one per row: in parallel over a SerialChain, else in turn.

        Row ``b`` of the answer equals ``step(q0[b], targets[b], q_prev[b])``
        (tests hold them equal): for sweeps over configurations (how much of a
        command the arm can follow across its workspace), many robots, or
        sampled starts. Rows the ratio test cannot take go to the HiGHS path
        one by one, as in :meth:`step`; so do the rows from outside the limits,
        the safe steps (the stall and through-rest stages) and, where the
        automatic multiplier bound applies outside the kernel, the rows with
        ``p < 1``. With a scene every row is a :meth:`step`.

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
        n = self._n
        Q0 = stacked_rows("q0", q0, ((n,),))
        B = Q0.shape[0]
        Qp = Q0 if q_prev is None else stacked_rows("q_prev", q_prev, ((n,),), B)
        T = stacked_rows("targets", targets, TARGET_SHAPES, B)
        check_magnitude("targets", T)  # as checked_target does for one target
        task_value(self.model, T[0])  # every row has the same shape: it must fit the task
        self._ready_for(T.ndim - 1)
        outs, codes = np.empty((B, self._out.shape[0])), np.empty(B, dtype=np.int64)
        numpy_engine = self._on_numpy_engine and self._on_numpy()
        if self.scene_rows is None and not numpy_engine:
            self._batch(self._state, Q0, Qp, T, outs, codes, 4 * numba.get_num_threads())
            if (codes == BAD_INPUT).any():  # every row was checked: a bug if it happens
                raise ValueError(f"row {int(np.argmax(codes == BAD_INPUT))}: rejected by the step")
            again = self._rows_again(outs, codes)
        else:
            outs[:], codes[:], again = -1.0, BAD_INPUT, np.ones(B, dtype=bool)
        return self._batch_result(outs, codes, again, Q0, T, None if q_prev is None else Qp,
                                  numpy_engine)  # fmt: skip

    def _rows_again(self, outs: FloatArray, codes: Any) -> Any:
        """The rows to step one by one: those the kernel does not answer itself."""
        infeasible = codes == KERNEL_INFEASIBLE
        again = (codes != OK) & ~infeasible | (outs[:, self._outside] >= 0)
        # a safe step: the stall and through-rest stages, and with rows the rows stage
        if self._watch_stall or self._state[layout.R] > 0:
            again |= infeasible
        if self.automatic_bound is not None:
            p = outs[:, self._p]
            again |= ~infeasible & (p < FULL_P) & (outs[:, self._bounded_at] < 0)
        if self._further:  # mode="progress": every row with p < 1 gets the second stage
            again |= outs[:, self._p] < 1.0
        elif self.stepper.stall_watch.after == 1:  # a row that may stall: the stall stage
            again |= outs[:, self._p] <= STALL_P  # (a row has no progress step before it)
        return again

    def _batch_result(
        self, outs: FloatArray, codes: Any, again: Any, Q0: Any, T: Any, Qp: Any,
        numpy_engine: bool = False,
    ) -> BatchResult:  # fmt: skip
        q, dq = outs[:, self._q].copy(), outs[:, self._dq].copy()
        lam, p = outs[:, self._lam].copy(), outs[:, self._p].copy()
        residual = outs[:, self._residual].copy()
        pull_scale = outs[:, self._pull_scale_at].copy()
        infeasible = codes == KERNEL_INFEASIBLE
        p[infeasible], lam[infeasible] = 0, np.nan  # q, dq: the kernel's safe step
        pull_scale[infeasible] = 1.0
        fallback: dict[int, Result] = {}
        for b in np.nonzero(again)[0].tolist():
            prev = None if Qp is None else Qp[b]
            self.reset()  # rows are independent: no target motion between them
            if numpy_engine:  # the stepper's own stall stage: one stalled step counted
                res = self._numpy_step(Q0[b], T[b], prev)
            else:
                res = self._step(Q0[b], T[b], prev, watch=False)
            if (self._watch_stall or self._further) and not numpy_engine:  # row by row
                res = self._stalled(res, Q0[b], prev, count=False)
            if res.status == INFEASIBLE:
                res = self._unanswered(Q0[b], T[b], prev, res)
            fallback[b] = res = self._within_rows(Q0[b], prev, res)
            q[b], dq[b], p[b], residual[b] = res.q, res.dq, res.p, res.residual
            pull_scale[b] = res.pull_scale
            lam[b] = np.nan if res.lam is None else res.lam
        if numpy_engine:  # as after the kernel's rows: nothing counted, nothing remembered
            self.reset()
        table = self._labels
        return BatchResult(
            q=q, dq=dq, p=p, lam=lam, codes=codes,
            binding_codes=outs[:, self._label_at].astype(np.int64), _labels=lambda b: table,
            _fallback=fallback, residual=residual, method=self.method, pull_scale=pull_scale,
        )  # fmt: skip

    def reset(self) -> None:
        """Forget the last step: the next one starts a new loop.

        It has no target motion to feed forward (:class:`~lpik.command.TargetMotion`),
        no last answer to check the next state's motion against (:attr:`motion`), and
        the count of stalled steps (``on_stall``) starts again. For a controller
        moved to an unrelated state, or stepping independent states one by one.
        """
        self._state[int(self._state[layout.MEMORY])] = 0.0
        self.stepper.target_motion = TargetMotion()
        self.stepper.stall_watch.clear()
        if self.motion is not None:  # no last answer to check the next state against
            self.motion.forget()
        self._numpy_inputs = None

    # -- inputs and the problem -----------------------------------------------------------

    def _converted(
        self, q0: Any, target: Any, q_prev: Any, check_finite: bool = False
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``q0``, the target and ``q_prev`` as the kernel's arrays, or a ValueError naming them."""
        q0 = joint_vector("q0", q0, self._n, check_finite)
        prev = q0 if q_prev is None else joint_vector("q_prev", q_prev, self._n, check_finite)
        if check_finite:  # the step refused its input: name what is wrong
            task_value(self.model, target)
        return q0, target_array(target, check_finite), prev

    def _checked(self, q0: Any, target: Any, q_prev: Any) -> tuple[Any, Any, Any]:
        for name, value in (("q0", q0), ("q_prev", q_prev), ("target", target)):
            if value is None:
                continue
            if not np.isfinite(numbers_of(name, value)).all():
                raise ValueError(f"{name}: contains NaN or inf")
        return q0, target, q_prev

    def problem(self, q0: ArrayLike, target: Any, q_prev: ArrayLike | None = None) -> Problem:
        """The step's :class:`~lpik.problem.Problem`, built by the numpy engine's stages.

        The command is the one law of :mod:`lpik.command`: the displacement to
        the target (along the screw on a pose task), clamped to ``v_max dt`` and
        ``w_max dt``, less the last step's second-order term where
        ``second_order`` is on. With a scene whose distances are compiled, the
        rows are computed by coal for this problem.
        """
        q0, target, q_prev = self._checked(q0, target, q_prev)
        if self.scene_rows is not None:
            self.scene_rows.write(np.asarray(q0, dtype=np.float64), target, q_prev)
        return self.stepper.problem(q0, target, q_prev, bound=self._bound)
