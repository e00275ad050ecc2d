"""Technical limits as data: each turns one step's context into bounds or labelled rows.

This is the one way to give limits: the same values (:class:`EndStops`,
:class:`VelocityLimits` in rad/s, :class:`AccelerationLimits`,
:class:`MultiplierBounds`, :class:`LinearRows`) go to :func:`build_problem`,
:func:`lpik.control.simulate.simulate` and
:class:`~lpik.control.controller.Lp2Controller` (``limits=[...]``), and the
per-step bounds are derived from them here and in :mod:`lpik.bands` only.
:class:`~lpik.problem.Problem`'s ``dq_min``/``dq_max`` are the low-level form:
one step's bounds on ``q - q0``, already multiplied by ``dt``.

A limit is a small immutable value with an ``apply(context)`` method that
returns a :class:`Piece`: absolute bounds on ``q`` (end-stops), bounds on
``dq = q - q0`` for this step (velocity, acceleration), bounds on the
multipliers, or extra rows ``G q <= h``. :func:`build_problem` stacks the
pieces into one :class:`~lpik.problem.Problem`, keeping for every joint and
side the name of the limit that is tightest, so that a result can say which
limit binds.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from lpik import bands, labels
from lpik.continuation import fading_steps
from lpik.problem import Problem
from lpik.tolerances import MAX_MAGNITUDE, MIN_DT, SINGULAR_ACTIVATION
from lpik.types import FloatArray


@dataclass(frozen=True)
class StepContext:
    """What a limit may look at when it is applied to one step.

    Attributes:
        q0: Joint coordinates now, shape (n,).
        dt: Control period [s].
        q_prev: Joint coordinates one period ago (``None`` on the first step: at rest).
    """

    q0: FloatArray
    dt: float
    q_prev: FloatArray | None = None


@dataclass(frozen=True, eq=False)
class Piece:
    """One limit's contribution; unused parts are ``None``."""

    q_min: FloatArray | None = None
    q_max: FloatArray | None = None
    dq_min: FloatArray | None = None
    dq_max: FloatArray | None = None
    kind: str = ""
    qdd_min: FloatArray | None = None
    qdd_max: FloatArray | None = None
    lam_min: FloatArray | None = None
    lam_max: FloatArray | None = None
    G: FloatArray | None = None
    h: FloatArray | None = None
    row_labels: tuple[str, ...] = ()
    joint_names: tuple[str, ...] = ()
    #: Whether the rows are limits on ``q`` that a step brakes ahead of under acceleration
    #: limits, as the joints' end-stops (:func:`lpik.bands.braked_room`); a scene's
    #: damper rows bound a step's approach and are not.
    braked: bool = False


class Limit(Protocol):
    """Anything that turns a step context into a :class:`Piece`."""

    def apply(self, context: StepContext) -> Piece:
        """This limit's bounds or rows for the step in ``context``."""
        ...


def _vec(name: str, value: Any) -> FloatArray:
    arr = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if np.isnan(arr).any():
        raise ValueError(f"{name}: contains NaN")
    return arr


@dataclass(frozen=True, eq=False)
class EndStops:
    """Mechanical end-stops ``q_min <= q <= q_max`` (eq. 13) [rad or m].

    ``joint_names`` (optional) name the joints in binding labels when
    :func:`build_problem` is given no names of its own; :func:`standard_limits`
    passes the model's.
    """

    q_min: Any
    q_max: Any
    joint_names: tuple[str, ...] = ()

    def apply(self, context: StepContext) -> Piece:
        """Absolute bounds on ``q``."""
        q_min, q_max = _vec("q_min", self.q_min), _vec("q_max", self.q_max)
        return Piece(q_min=q_min, q_max=q_max, joint_names=tuple(self.joint_names))


@dataclass(frozen=True, eq=False)
class VelocityLimits:
    """Joint velocity limits (eq. 14): ``qd_min dt <= q - q0 <= qd_max dt``.

    Args:
        qd_max: Upper velocity limits [rad/s or m/s].
        qd_min: Lower velocity limits; default ``-qd_max``.
    """

    qd_max: Any
    qd_min: Any = None

    def apply(self, context: StepContext) -> Piece:
        """Bounds on ``dq`` for a step of ``context.dt`` seconds."""
        hi = _vec("qd_max", self.qd_max)
        lo = -hi if self.qd_min is None else _vec("qd_min", self.qd_min)
        return Piece(dq_min=lo * context.dt, dq_max=hi * context.dt, kind=labels.VELOCITY_LIMIT)


@dataclass(frozen=True, eq=False)
class AccelerationLimits:
    """Joint acceleration limits: ``qdd_min <= (qd_new - qd_prev) / dt <= qdd_max``.

    With ``qd_prev = (q0 - q_prev) / dt`` and ``qd_new = dq / dt`` this bounds
    ``dq`` to ``(q0 - q_prev) + [qdd_min, qdd_max] dt^2``. On the first step
    (no ``q_prev``) the arm is taken to be at rest. These limits take precedence
    over the velocity limits and the end-stops when they cannot all hold, and
    add the braking distance to the end-stops as a bound on the speed now
    (:mod:`lpik.bands`).

    Args:
        qdd_max: Upper acceleration limits [rad/s^2 or m/s^2].
        qdd_min: Lower acceleration limits; default ``-qdd_max``.
    """

    qdd_max: Any
    qdd_min: Any = None

    def apply(self, context: StepContext) -> Piece:
        """The acceleration limits, which :func:`build_problem` turns into bounds on ``dq``."""
        hi = _vec("qdd_max", self.qdd_max)
        lo = -hi if self.qdd_min is None else _vec("qdd_min", self.qdd_min)
        return Piece(qdd_min=lo, qdd_max=hi, kind=labels.ACCELERATION_LIMIT)


@dataclass(frozen=True, eq=False)
class MultiplierBounds:
    """Bounds on the Lagrange multipliers (sec. 3.2): ``lam_min <= lam <= lam_max``.

    Use :meth:`symmetric` for ``-B <= lam <= B``.
    """

    lam_min: Any
    lam_max: Any

    @classmethod
    def symmetric(cls, bound: float) -> MultiplierBounds:
        """``-bound <= lam_i <= bound`` for every multiplier."""
        if not bound > 0:
            raise ValueError(f"lambda bound: must be > 0, got {bound}")
        return cls(-float(bound), float(bound))

    def apply(self, context: StepContext) -> Piece:
        """Bounds on ``lam`` (broadcast to every multiplier when scalar)."""
        return Piece(lam_min=_vec("lam_min", self.lam_min), lam_max=_vec("lam_max", self.lam_max))


@dataclass(frozen=True, eq=False)
class AutomaticMultiplierBounds:
    """Multiplier bounds (sec. 3.2) chosen per step where they help (:mod:`lpik.methods.autobound`).

    A problem alone carries no bound from it (:meth:`apply` adds nothing): the
    closed loop (:func:`lpik.control.simulate.simulate`) and
    :class:`~lpik.control.controller.Lp2Controller` solve LP2 unbounded and, where
    that step would race towards a singularity, again with the bounds it chooses.

    Attributes:
        approach_time: Time constant [s] of the approach to a singular
            configuration the command pushes towards.
        activation: Below this ``sigma_min / sigma_max`` of ``J`` the rule acts.
        floor: The bound is 0 at ``sigma_min = floor sigma_max``: the arm stops there.
        probe: Length [rad] of the step along ``dq`` that tells whether it leaves
            the singularity.
    """

    approach_time: float = 0.05
    activation: float = SINGULAR_ACTIVATION
    floor: float = 1e-3
    probe: float = 1e-7

    def __post_init__(self) -> None:
        for name in ("approach_time", "activation", "floor", "probe"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
        if not self.floor < self.activation < 1:
            raise ValueError(
                f"floor, activation: need floor < activation < 1, got {self.floor}, "
                f"{self.activation}"
            )

    def apply(self, context: StepContext) -> Piece:
        """Nothing on a problem alone: the loop applies the bound (class docstring)."""
        return Piece()


@dataclass(frozen=True, eq=False)
class LinearRows:
    """Extra rows ``G q <= h`` with one label each (e.g. obstacle half-spaces).

    ``kind`` is what a binding row is called in its :class:`~lpik.labels.Binding`:
    ``"row"``, or ``"collision"`` for distance rows. Under acceleration limits each
    row keeps a stop ahead, as an end-stop does: a step's room ``h - G q0`` is at
    most what the joints can still brake from (:func:`lpik.bands.braked_room`,
    applied by :func:`build_problem`).
    """

    G: Any
    h: Any
    labels: tuple[str, ...] = field(default=())
    kind: str = "row"

    def apply(self, context: StepContext) -> Piece:
        """The rows as they are."""
        G = np.atleast_2d(np.asarray(self.G, dtype=np.float64))
        h = _vec("h", self.h)
        names = self.labels or labels.default_row_labels(h.size)
        rows = tuple(labels.row_label(j, v, self.kind) for j, v in enumerate(names))
        return Piece(G=G, h=h, row_labels=rows, braked=True)


#: What ``lambda_bound`` may be, wherever a step takes it.
LambdaBound = float | str | MultiplierBounds | AutomaticMultiplierBounds | None


def multiplier_limit(
    lambda_bound: LambdaBound, *, field: str = "lambda_bound"
) -> MultiplierBounds | AutomaticMultiplierBounds | None:
    """The multiplier limit (sec. 3.2) that ``lambda_bound`` names: its one reading.

    ``"auto"``: :class:`AutomaticMultiplierBounds` (bounds chosen per step where
    the arm would race towards a singularity); a finite number ``B > 0``:
    ``|lam_i| <= B`` (:meth:`MultiplierBounds.symmetric`); a
    :class:`MultiplierBounds` or :class:`AutomaticMultiplierBounds`: itself;
    ``None``: unbounded (the paper's LP2 as stated).

    Raises:
        ValueError: Naming ``field``, for anything else.
    """
    if lambda_bound is None or isinstance(
        lambda_bound, MultiplierBounds | AutomaticMultiplierBounds
    ):
        return lambda_bound
    if isinstance(lambda_bound, str):
        if lambda_bound == "auto":
            return AutomaticMultiplierBounds()
    elif isinstance(lambda_bound, numbers.Real) and not isinstance(lambda_bound, bool):
        if math.isfinite(lambda_bound) and 0 < lambda_bound <= MAX_MAGNITUDE:
            return MultiplierBounds.symmetric(float(lambda_bound))
    raise ValueError(
        f"{field}: must be a number > 0 (at most {MAX_MAGNITUDE:g}), 'auto' or None, "
        f"got {lambda_bound!r}"
    )


def standard_limits(
    model: Any, *, velocity: bool = True, lambda_bound: LambdaBound = "auto"
) -> list[Limit]:
    """A robot model's end-stops, velocity limits and multiplier bounds (automatic by default).

    Args:
        model: Anything with ``q_min``, ``q_max`` and ``qd_max`` (e.g. a task model).
        velocity: Whether the model's ``qd_max`` bounds each step (eq. 14).
        lambda_bound: The multiplier bound, as :func:`multiplier_limit` reads it
            (default ``"auto"``, LP2's default).
    """
    limits: list[Limit] = [EndStops(model.q_min, model.q_max, tuple(model.joint_names))]
    if velocity and np.isfinite(model.qd_max).any():
        limits.append(VelocityLimits(model.qd_max))
    bound = multiplier_limit(lambda_bound)
    if bound is not None:
        limits.append(bound)
    return limits


def control_period(dt: Any) -> float:
    """``dt`` as a float when it is a control period a step takes, else a ValueError naming it.

    A real number (no boolean) from :data:`~lpik.tolerances.MIN_DT` to
    :data:`~lpik.tolerances.MAX_MAGNITUDE` [s]: the one rule of every way to set up steps
    (:func:`build_problem`, the stepper and the controller, ``simulate``).
    """
    real = isinstance(dt, numbers.Real) and not isinstance(dt, bool)
    if not (real and MIN_DT <= dt <= MAX_MAGNITUDE):  # (NaN fails the comparison)
        raise ValueError(f"dt: must be a number in [{MIN_DT:g}, {MAX_MAGNITUDE:g}] [s], got {dt!r}")
    return float(dt)


def build_problem(
    J: Any,
    dw: Any,
    q0: Any,
    limits: Sequence[Limit],
    *,
    dt: float,
    q_prev: Any = None,
    continuation: bool = False,
    motion_before: Any = None,
    singular_steps: float = math.inf,
    brake_rows: bool = True,
    **weights: Any,
) -> Problem:
    """Stack the limits' pieces into one validated :class:`~lpik.problem.Problem`.

    Args:
        J: Task Jacobian at ``q0``, shape (m, n).
        dw: Commanded task displacement, shape (m,).
        q0: Current joint coordinates, shape (n,).
        limits: The limits in force.
        dt: Control period [s] (> 0).
        q_prev: Joint coordinates one period ago, for acceleration limits.
        continuation: Under acceleration limits, with the arm moving, give the
            problem ``last = q0 - q_prev``: LP1 and LP2 then solve the step around
            the current motion (:mod:`lpik.continuation`), as the controllers do.
        motion_before: ``J(q_prev) (q0 - q_prev)``, the last step's motion in the
            task at ``q_prev``: with ``continuation``, a motion that stops paying
            within the joints' braking distance is braked in time
            (:func:`lpik.continuation.fading_steps`, :func:`lpik.bands.fading_band`),
            as the controllers do; None: it is not.
        singular_steps: With ``motion_before``, in how many steps the motion reaches
            the automatic multiplier bound's floor near a singular configuration
            (:func:`lpik.methods.autobound.singular_steps`), a stop ahead the
            joints keep the room to stop at, as the controllers do; ``inf``: none.
        brake_rows: Under acceleration limits, each row of a :class:`LinearRows`
            keeps a stop ahead, as the end-stops do (:func:`lpik.bands.braked_room`):
            its room for the step is at most what the joints can still brake from;
            False: the rows as given (a compiled controller's template).
        **weights: ``M``, ``f``, ``Lambda``, ``q_ref``, ``k`` of the problem, and
            ``joint_names``, the names binding labels use (default: the names an
            :class:`EndStops` carries, as :func:`standard_limits` gives them, else
            ``"joint 1"`` ... ``"joint n"``).

    Raises:
        ValueError: Naming the bad argument or field.
    """
    dt = control_period(dt)
    q0 = np.asarray(q0, dtype=np.float64)
    n = q0.size
    context = StepContext(
        q0=q0, dt=float(dt), q_prev=None if q_prev is None else np.asarray(q_prev, dtype=np.float64)
    )
    stack = _Stack(n, np.atleast_2d(np.asarray(J)).shape[0])
    for limit in limits:
        stack.add(limit.apply(context))
    if not weights.get("joint_names") and len(stack.named) == n:
        weights = {**weights, "joint_names": stack.named}
    names = weights.get("joint_names") or labels.default_joint_names(n)
    last = np.zeros(n) if context.q_prev is None else context.q0 - context.q_prev
    outside: list[str] = []
    accelerations = np.isfinite(stack.qdd_min).any() or np.isfinite(stack.qdd_max).any()
    if accelerations:
        _rate_bands(q0, last, (stack.q_min, stack.q_max, stack.dq_min, stack.dq_max,
                               stack.qdd_min, stack.qdd_max), dt,
                    (stack.lo_kind, stack.hi_kind), names, outside)  # fmt: skip
        if continuation and motion_before is not None and last.any():
            _fading_bands(np.atleast_2d(np.asarray(J, dtype=np.float64)),
                          np.asarray(dw, dtype=np.float64), q0, last,
                          np.asarray(motion_before, dtype=np.float64), stack, dt,
                          singular_steps)  # fmt: skip
    return Problem(
        J=J,
        dw=dw,
        q0=q0,
        q_min=stack.q_min,
        q_max=stack.q_max,
        dq_min=stack.dq_min,
        dq_max=stack.dq_max,
        dq_min_kind=stack.lo_kind,
        dq_max_kind=stack.hi_kind,
        lam_min=stack.lam_min,
        lam_max=stack.lam_max,
        outside_limits=outside,
        last=last if continuation and accelerations and last.any() else None,
        **stack.rows(q0, dt, brake_rows and accelerations),
        **weights,
    )


class _Stack:
    """The limits' pieces stacked: per joint and side the tightest bound (and its kind), rows."""

    def __init__(self, n: int, m: int) -> None:
        self.n, self.m = n, m
        self.q_min, self.q_max = np.full(n, -np.inf), np.full(n, np.inf)
        self.dq_min, self.dq_max = np.full(n, -np.inf), np.full(n, np.inf)
        self.qdd_min, self.qdd_max = np.full(n, -np.inf), np.full(n, np.inf)
        self.lo_kind, self.hi_kind = [labels.VELOCITY_LIMIT] * n, [labels.VELOCITY_LIMIT] * n
        self.lam_min, self.lam_max = np.full(m, -np.inf), np.full(m, np.inf)
        self.G: list[Any] = []
        self.h: list[Any] = []
        self.row_labels: list[str] = []
        self.braked: list[bool] = []
        self.named: tuple[str, ...] = ()

    def add(self, piece: Piece) -> None:
        """Tighten the bounds by ``piece``'s and append its rows."""
        n, m = self.n, self.m
        self.named = self.named or piece.joint_names
        self.q_min = _tighter(np.maximum, self.q_min, piece.q_min, n)
        self.q_max = _tighter(np.minimum, self.q_max, piece.q_max, n)
        if piece.dq_min is not None:
            new = np.broadcast_to(piece.dq_min, (n,))
            self.lo_kind = [piece.kind if b > a else k
                            for a, b, k in zip(self.dq_min, new, self.lo_kind)]  # fmt: skip
            self.dq_min = np.maximum(self.dq_min, new)
        if piece.dq_max is not None:
            new = np.broadcast_to(piece.dq_max, (n,))
            self.hi_kind = [piece.kind if b < a else k
                            for a, b, k in zip(self.dq_max, new, self.hi_kind)]  # fmt: skip
            self.dq_max = np.minimum(self.dq_max, new)
        self.qdd_min = _tighter(np.maximum, self.qdd_min, piece.qdd_min, n)
        self.qdd_max = _tighter(np.minimum, self.qdd_max, piece.qdd_max, n)
        self.lam_min = _tighter(np.maximum, self.lam_min, piece.lam_min, m)
        self.lam_max = _tighter(np.minimum, self.lam_max, piece.lam_max, m)
        if piece.G is not None and piece.h is not None:
            self.G.append(piece.G)
            self.h.append(piece.h)
            start, count = len(self.row_labels), np.atleast_2d(piece.G).shape[0]
            self.braked.extend([piece.braked] * count)
            self.row_labels.extend(
                piece.row_labels or labels.default_row_labels(start + count)[start:]
            )

    def rows(self, q0: FloatArray, dt: float, brake: bool) -> dict[str, Any]:
        """The stacked rows as the problem's ``G``, ``h`` and ``row_labels`` (none: empty).

        ``brake``: under acceleration limits, each row of a braked piece keeps a stop
        ahead (:func:`lpik.bands.braked_room` of its room ``h - G q0``).
        """
        if not self.G:
            return {}
        G, h = np.vstack(self.G), np.concatenate(self.h).astype(np.float64)
        if brake and any(self.braked):
            for j in np.flatnonzero(self.braked):
                room = h[j] - G[j] @ q0
                deceleration = bands.row_deceleration(G[j], 1.0, self.qdd_min, self.qdd_max, dt)
                h[j] += bands.braked_room(room, deceleration) - room
        return {"G": G, "h": h, "row_labels": self.row_labels}


def _tighter(pick: Any, current: FloatArray, value: Any, size: int) -> FloatArray:
    """``current`` tightened by ``value`` (broadcast to ``size``) with ``pick``; None: as it is."""
    return current if value is None else pick(current, np.broadcast_to(value, (size,)))


def _fading_bands(
    J: FloatArray, dw: FloatArray, q0: FloatArray, last: FloatArray, before: FloatArray,
    stack: _Stack, dt: float, singular_steps: float,
) -> None:  # fmt: skip
    """Brake a motion that stops paying ahead, or nears a singularity (the nearer), in place.

    :func:`lpik.bands.fading_band`; a bound that the stop ahead sets is labelled
    as the acceleration limit's. A joint outside its end-stops keeps its band
    (:func:`lpik.bands.beyond_stops`).
    """
    own = fading_steps(J, dw, last, before)
    steps = min(own, singular_steps)
    if not steps < np.inf:
        return
    for i in range(last.size):
        if bands.beyond_stops(float(q0[i]), float(stack.q_min[i]), float(stack.q_max[i])):
            continue
        lo, hi, lo_fades, hi_fades = bands.fading_band(
            float(last[i]), steps, float(stack.dq_min[i]), float(stack.dq_max[i]),
            float(stack.qdd_min[i]), float(stack.qdd_max[i]), dt, own,
        )  # fmt: skip
        stack.dq_min[i], stack.dq_max[i] = lo, hi
        if lo_fades:
            stack.lo_kind[i] = labels.ACCELERATION_LIMIT
        if hi_fades:
            stack.hi_kind[i] = labels.ACCELERATION_LIMIT


def _rate_bands(
    q0: FloatArray,
    last: FloatArray,
    bounds: tuple[FloatArray, ...],
    dt: float,
    kinds: tuple[list[str], list[str]],
    names: Sequence[str],
    outside: list[str],
) -> None:
    """Fold the acceleration limits into ``dq_min``/``dq_max`` by :func:`lpik.bands.rate_band`.

    ``bounds`` is ``(q_min, q_max, dq_min, dq_max, qdd_min, qdd_max)``; the step
    bounds and ``kinds`` are updated in place, and the labels of limits the
    motion is outside of are appended to ``outside``.
    """
    q_min, q_max, dq_min, dq_max, qdd_min, qdd_max = bounds
    lo_kind, hi_kind = kinds
    for i in range(q0.size):
        lo, hi, k_lo, k_hi, verdict = bands.rate_band(
            float(last[i]), float(q_min[i] - q0[i]), float(q_max[i] - q0[i]),
            float(dq_min[i]), float(dq_max[i]),
            float(qdd_min[i]), float(qdd_max[i]), dt,
        )  # fmt: skip
        # kind code 1 is the step bound given (velocity limit or a custom kind)
        lo_kind[i] = lo_kind[i] if k_lo == 1 else labels.BOUND_KINDS[k_lo]
        hi_kind[i] = hi_kind[i] if k_hi == 1 else labels.BOUND_KINDS[k_hi]
        dq_min[i], dq_max[i] = lo, hi
        if verdict != bands.MET:
            side = "upper" if verdict == bands.UPPER_YIELDED else "lower"
            kind = hi_kind[i] if verdict == bands.UPPER_YIELDED else lo_kind[i]
            outside.append(labels.bound_label(str(names[i]), side, kind, i).outside())
