"""One control step's inverse-kinematics problem as one validated value.

Everything a method needs for one step: the Jacobian ``J`` and commanded
end-effector displacement ``dw = w_desired - w0`` (eq. 2), the current joint
coordinates ``q0``, the weights of the quadratic criterion (``M``, ``f`` of
eq. 3; ``Lambda``, ``q_ref`` of sec. 3.1) and the technical limits: end-stops
(eq. 13), per-step bounds on ``q - q0`` from velocity and acceleration limits
(eq. 14), multiplier bounds (sec. 3.2) and extra linear rows ``G q <= h``
(obstacles). Internally every method works in ``dq = q - q0``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from lpik import bands, labels
from lpik.exceptions import InvalidProblemError
from lpik.tolerances import MAX_MAGNITUDE, PSD_RTOL, SYMMETRY_RTOL
from lpik.types import FloatArray, real_array

#: Default name of the limit that sets ``dq_min`` / ``dq_max`` (eq. 14).
STEP_BOUND_KIND = labels.VELOCITY_LIMIT


def reference_configuration(q_min: FloatArray, q_max: FloatArray, q0: FloatArray) -> FloatArray:
    """The default ``q_ref`` of sec. 3.1: the end-stops' midpoint where both are finite, else q0.

    A caller that does not know ``q0`` yet (a compiled controller) passes NaN
    there and gets NaN where ``q_ref`` is to follow ``q0``.
    """
    finite = np.isfinite(q_min) & np.isfinite(q_max)
    mid = 0.5 * (np.where(finite, q_min, 0.0) + np.where(finite, q_max, 0.0))
    return np.where(finite, mid, q0)


def _vector(name: str, value: Any, size: int, *, allow_inf: bool = False) -> FloatArray:
    """Convert ``value`` to a float vector of length ``size`` or raise naming ``name``."""
    try:
        nulls = [np.nan if v is None else v for v in value] if isinstance(value, list) else value
        arr = real_array(nulls)
    except (TypeError, ValueError) as exc:
        raise InvalidProblemError(name, f"must be a list of {size} numbers ({exc})") from None
    if arr.ndim == 0 and size == 1:
        arr = arr.reshape(1)
    if arr.shape != (size,):
        raise InvalidProblemError(name, f"must have length {size}, got shape {arr.shape}")
    if np.isnan(arr).any():
        raise InvalidProblemError(
            name, f"contains NaN or null at index {int(np.argmax(np.isnan(arr)))}"
        )
    if not allow_inf and not np.isfinite(arr).all():
        raise InvalidProblemError(
            name, f"contains inf at index {int(np.argmax(~np.isfinite(arr)))}"
        )
    check_magnitude(name, arr, bound=allow_inf)
    return arr


def check_magnitude(name: str, arr: FloatArray, *, bound: bool = False) -> None:
    """Raise naming ``name`` when a finite entry of ``arr`` exceeds ``MAX_MAGNITUDE`` in size.

    ``bound``: ``arr`` holds bounds, where inf means none (only finite entries count).
    """
    big = np.abs(arr) > MAX_MAGNITUDE
    if bound:
        big &= np.isfinite(arr)
    if big.any():
        index = np.unravel_index(int(np.argmax(big)), arr.shape)
        at = index[0] if arr.ndim == 1 else tuple(int(i) for i in index)
        hint = "; use null or inf for no bound" if bound else "; rescale the units"
        raise InvalidProblemError(
            name,
            f"entry {arr[index]:g} at index {at} is larger than {MAX_MAGNITUDE:g} in size "
            f"(the largest magnitude lpik accepts{hint})",
        )


def _bound_vector(name: str, value: Any, size: int, default: float) -> FloatArray:
    """A bound vector where ``None`` entries (JSON null) mean unbounded (``default``)."""
    if value is None:
        return np.full(size, default)
    if isinstance(value, list | tuple):
        value = [default if v is None else v for v in value]
    return _vector(name, value, size, allow_inf=True)


def _matrix(name: str, value: Any, n: int, default_diag: float) -> FloatArray:
    """An n x n matrix, given as a matrix, a diagonal vector or ``None``."""
    if value is None:
        return np.eye(n) * default_diag
    try:
        arr = real_array(value)
    except (TypeError, ValueError) as exc:
        raise InvalidProblemError(
            name, f"must be an {n} x {n} matrix or {n} numbers ({exc})"
        ) from None
    if arr.ndim == 1:
        if arr.shape != (n,):
            raise InvalidProblemError(
                name, f"as a diagonal must have length {n}, got {arr.shape[0]}"
            )
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise InvalidProblemError(
            name, f"must be {n} x {n} (or a diagonal of length {n}), got shape {arr.shape}"
        )
    if not np.isfinite(arr).all():
        raise InvalidProblemError(name, "contains NaN or inf")
    check_magnitude(name, arr)
    scale = max(1.0, float(np.abs(arr).max()))
    if np.abs(arr - arr.T).max() > SYMMETRY_RTOL * scale:
        raise InvalidProblemError(name, "must be symmetric")
    return arr


@dataclass(frozen=True, eq=False)
class Problem:
    """One step of inverse kinematics, validated on construction.

    Args:
        J: Task Jacobian at ``q0``, shape (m, n) (eq. 2).
        dw: Commanded task displacement ``w_desired - w0``, shape (m,) [m or rad].
        q0: Current joint coordinates, shape (n,) [rad or m].
        q_min: Lower end-stops, shape (n,); ``None`` entries or ``-inf`` mean unbounded (eq. 13).
        q_max: Upper end-stops, shape (n,); ``None`` entries or ``+inf`` mean unbounded (eq. 13).
        dq_min: Lower bound on ``q - q0`` for this step, shape (n,) (eq. 14: velocity
            limit times dt). The low-level form: one step's bounds, in radians
            (or metres), not per second. :func:`lpik.limits.build_problem` derives
            them from limits as data (``VelocityLimits`` in rad/s,
            ``AccelerationLimits``), as ``simulate`` and ``Lp2Controller`` do.
        dq_max: Upper bound on ``q - q0`` for this step, shape (n,) (eq. 14); as ``dq_min``.
        M: Positive definite weight matrix of eq. 3, (n, n) or its diagonal (n,); default identity.
        f: Weight vector (artificial generalised force) of eq. 3, shape (n,); default zero.
        Lambda: Positive semidefinite smoothing weight of sec. 3.1, (n, n) or diagonal;
            default zero.
        q_ref: Reference configuration of sec. 3.1, shape (n,); default the midpoint of the
            end-stops where both are finite, else ``q0``.
        lam_min: Lower bounds of the Lagrange multipliers (sec. 3.2), shape (m,); default unbounded.
        lam_max: Upper bounds of the Lagrange multipliers (sec. 3.2), shape (m,); default unbounded.
        G: Extra inequality rows ``G q <= h`` (e.g. obstacles), shape (r, n); default none.
        h: Right-hand side of the extra rows, shape (r,).
        row_labels: One label per extra row, used to name a binding row.
        k: Damping of the robust inverse (eq. 19); ``None`` means Yoshikawa's
            manipulability ``sqrt(det(J J^T))``.
        dq_min_kind: Which limit set each entry of ``dq_min`` (e.g. ``"velocity limit"``).
        dq_max_kind: Which limit set each entry of ``dq_max``.
        joint_names: Names used in binding labels; default ``"joint 1"`` ... ``"joint n"``.
        outside_limits: Labels of the rate limits the joints' motion is already
            outside of (a speed above its limit that the acceleration limits
            cannot bring back in one step), as :func:`lpik.limits.build_problem`
            finds them; the step is then ``recovering``. End-stops the state is
            outside of are found from ``q0`` (:meth:`recovering`).
        last: The motion to solve the step around, ``q0 - q_prev`` (n,): LP1, LP2
            and LP2 with saturation then solve the continuation form
            ``J (dq - last) = p (dw - J last)`` (:mod:`lpik.continuation`), as
            :func:`lpik.limits.build_problem` sets it under acceleration limits;
            default None: the paper's ``J dq = p dw`` (eq. 12).

    Raises:
        InvalidProblemError: (a ``ValueError``) naming the field that is wrong.
    """

    J: FloatArray
    dw: FloatArray
    q0: FloatArray
    q_min: Any = None
    q_max: Any = None
    dq_min: Any = None
    dq_max: Any = None
    M: Any = None
    f: Any = None
    Lambda: Any = None
    q_ref: Any = None
    lam_min: Any = None
    lam_max: Any = None
    G: Any = None
    h: Any = None
    row_labels: Sequence[str] | None = None
    k: float | None = None
    dq_min_kind: Sequence[str] | None = None
    dq_max_kind: Sequence[str] | None = None
    joint_names: Sequence[str] | None = None
    outside_limits: Sequence[str] | None = None
    last: Any = None
    _cache: dict[str, Any] = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        m, n = self._init_jacobian()
        set_ = object.__setattr__
        set_(self, "dw", _vector("dw", self.dw, m))
        set_(self, "q0", _vector("q0", self.q0, n))
        for lo_name, hi_name in (("q_min", "q_max"), ("dq_min", "dq_max")):
            lo = _bound_vector(lo_name, getattr(self, lo_name), n, -np.inf)
            hi = _bound_vector(hi_name, getattr(self, hi_name), n, np.inf)
            _check_ordered(lo_name, lo, hi_name, hi)
            set_(self, lo_name, lo)
            set_(self, hi_name, hi)
        self._init_weights(n)
        lam_min = _bound_vector("lam_min", self.lam_min, m, -np.inf)
        lam_max = _bound_vector("lam_max", self.lam_max, m, np.inf)
        _check_ordered("lam_min", lam_min, "lam_max", lam_max)
        set_(self, "lam_min", lam_min)
        set_(self, "lam_max", lam_max)
        self._init_rows(n)
        self._init_damping()
        self._init_labels(n)
        if self.last is not None:
            set_(self, "last", _vector("last", self.last, n))

    def _init_jacobian(self) -> tuple[int, int]:
        """Validate ``J``; returns its shape ``(m, n)``."""
        try:
            J = real_array(self.J)
        except (TypeError, ValueError) as exc:
            raise InvalidProblemError("J", f"must be an m x n matrix of numbers ({exc})") from None
        if J.ndim != 2 or J.shape[0] < 1 or J.shape[1] < 1:
            raise InvalidProblemError("J", f"must be a non-empty m x n matrix, got shape {J.shape}")
        if not np.isfinite(J).all():
            raise InvalidProblemError("J", "contains NaN or inf")
        check_magnitude("J", J)
        object.__setattr__(self, "J", J)
        return J.shape

    def _init_weights(self, n: int) -> None:
        """Validate the criterion: ``M``, ``f`` (eq. 3), ``Lambda`` and ``q_ref`` (sec. 3.1)."""
        set_ = object.__setattr__
        M = _matrix("M", self.M, n, 1.0)
        try:
            np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            raise InvalidProblemError("M", "must be positive definite") from None
        set_(self, "M", M)
        Lam = _matrix("Lambda", self.Lambda, n, 0.0)
        if np.linalg.eigvalsh(Lam).min() < -PSD_RTOL * max(1.0, float(np.abs(Lam).max())):
            raise InvalidProblemError("Lambda", "must be positive semidefinite")
        set_(self, "Lambda", Lam)
        set_(self, "f", np.zeros(n) if self.f is None else _vector("f", self.f, n))
        if self.q_ref is None:
            q_ref = reference_configuration(self.q_min, self.q_max, self.q0)
        else:
            q_ref = _vector("q_ref", self.q_ref, n)
        set_(self, "q_ref", q_ref)

    def _init_damping(self) -> None:
        """Validate ``k``, the robust inverse's damping (eq. 19), where given."""
        if self.k is None:
            return
        try:
            k = float(self.k)
        except (TypeError, ValueError):
            raise InvalidProblemError("k", f"must be a number, got {self.k!r}") from None
        if not np.isfinite(k) or k < 0 or k > MAX_MAGNITUDE:
            raise InvalidProblemError(
                "k", f"must be a finite number in [0, {MAX_MAGNITUDE:g}], got {k}"
            )
        object.__setattr__(self, "k", k)

    def _init_labels(self, n: int) -> None:
        """The names: the step bounds' kinds, the joints, the limits the state is outside of."""
        set_ = object.__setattr__
        set_(self, "dq_min_kind", _labels("dq_min_kind", self.dq_min_kind, n, STEP_BOUND_KIND))
        set_(self, "dq_max_kind", _labels("dq_max_kind", self.dq_max_kind, n, STEP_BOUND_KIND))
        names = labels.default_joint_names(n)
        set_(self, "joint_names", _labels("joint_names", self.joint_names, n, None) or names)
        outside = () if self.outside_limits is None else self.outside_limits
        if isinstance(outside, str):
            outside = (outside,)
        set_(self, "outside_limits", tuple(_outside_label(v) for v in outside))

    def _init_rows(self, n: int) -> None:
        set_ = object.__setattr__
        if self.G is None and self.h is None:
            set_(self, "G", np.zeros((0, n)))
            set_(self, "h", np.zeros(0))
            set_(self, "row_labels", ())
            return
        if self.G is None or self.h is None:
            raise InvalidProblemError(
                "G" if self.G is None else "h", "G and h must be given together"
            )
        try:
            G = real_array(self.G)
        except (TypeError, ValueError) as exc:
            raise InvalidProblemError("G", f"must be an r x {n} matrix ({exc})") from None
        if G.size == 0:
            G = np.zeros((0, n))
        elif G.shape == (n,):
            G = G.reshape(1, n)
        if G.ndim != 2 or G.shape[1] != n:
            raise InvalidProblemError("G", f"must be an r x {n} matrix, got shape {G.shape}")
        if not np.isfinite(G).all():
            raise InvalidProblemError("G", "contains NaN or inf")
        check_magnitude("G", G)
        r = G.shape[0]
        set_(self, "G", G)
        set_(self, "h", _vector("h", self.h, r))
        given = self.row_labels
        names = _labels("row_labels", given, r, None) or labels.default_row_labels(r)
        if given is not None and not isinstance(given, str):  # keep a row's kind (collision)
            names = tuple(g if isinstance(g, labels.Binding) else v for g, v in zip(given, names))
        set_(self, "row_labels", tuple(labels.row_label(j, v) for j, v in enumerate(names)))

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.J.shape[1])

    @property
    def m(self) -> int:
        """Number of task coordinates."""
        return int(self.J.shape[0])

    def step_bounds(self) -> tuple[FloatArray, FloatArray, tuple[str, ...], tuple[str, ...]]:
        """Bounds on ``dq = q - q0`` from end-stops and step bounds (eqs. 13-14).

        Normally the tighter of ``q_min - q0`` and ``dq_min`` (and of
        ``q_max - q0`` and ``dq_max``). A joint outside its end-stops moves back
        towards them within its step bounds: :func:`lpik.bands.stop_band`.

        Returns:
            ``(lower, upper, lower_labels, upper_labels)``, with the label of the
            limit that sets each bound, e.g. ``"joint 1 upper end-stop"``.
        """
        if "bounds" not in self._cache:
            n = self.n
            lower, upper = np.empty(n), np.empty(n)
            lower_labels, upper_labels, outside, kinds = [], [], [], []
            for i, name in enumerate(self.joint_names):
                lo, hi, lo_stop, hi_stop, out = bands.stop_band(
                    float(self.q0[i]),
                    float(self.q_min[i]),
                    float(self.q_max[i]),
                    float(self.dq_min[i]),
                    float(self.dq_max[i]),
                )
                lower[i], upper[i] = lo, hi
                lo_kind = labels.END_STOP if lo_stop else self.dq_min_kind[i]
                hi_kind = labels.END_STOP if hi_stop else self.dq_max_kind[i]
                kinds.append((lo_kind, hi_kind))
                lower_labels.append(labels.bound_label(name, "lower", lo_kind, i))
                upper_labels.append(labels.bound_label(name, "upper", hi_kind, i))
                if out:
                    side = "upper" if out > 0 else "lower"
                    outside.append(labels.bound_label(name, side, labels.END_STOP, i).outside())
            self._cache["bounds"] = (lower, upper, tuple(lower_labels), tuple(upper_labels))
            self._cache["outside"] = tuple(outside)
            self._cache["kinds"] = tuple(zip(*kinds)) if kinds else ((), ())
        return self._cache["bounds"]  # type: ignore[no-any-return]

    def step_bound_kinds(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """Which limit sets each of :meth:`step_bounds`' bounds: ``(lower, upper)`` kinds.

        A kind as ``dq_min_kind`` takes it: ``"end-stop"`` where the end-stop sets
        the bound, else the step bound's own kind (e.g. ``"velocity limit"``).
        """
        self.step_bounds()
        return self._cache["kinds"]  # type: ignore[no-any-return]

    @property
    def motion(self) -> FloatArray | None:
        """``last`` clipped to the step's bounds: the motion the step continues, or None.

        The continuation form (:mod:`lpik.continuation`) keeps this motion at
        ``p = 0``; clipped, so that it is always within the joints' bounds.
        """
        if self.last is None:
            return None
        lower, upper = self.step_bounds()[:2]
        return np.clip(self.last, lower, upper)

    def recovering(self) -> tuple[str, ...]:
        """Labels of the limits the state is outside of: end-stops past ``q0``, then rate limits.

        Empty for a state within its limits. A step from such a state has status
        ``recovering`` and names the first of them as its binding limit.
        """
        self.step_bounds()
        return self._cache["outside"] + tuple(self.outside_limits)

    def pinned(self) -> tuple[np.ndarray, FloatArray]:
        """Joints whose step is fixed, and that step: ``(mask, dq)``.

        A joint whose lower and upper bound on ``dq`` coincide (one outside its
        end-stops, :func:`lpik.bands.stop_band`, or with coinciding limits) can
        move by that amount only. LP2 resolves its criterion over the other
        joints (eqs. 15-18 over the free joints). ``dq`` is 0 where free.
        """
        lower, upper = self.step_bounds()[:2]
        mask = lower == upper
        return mask, np.where(mask, lower, 0.0)

    def multiplier_labels(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """Labels of the lower and upper multiplier bounds (sec. 3.2)."""
        return labels.multiplier_labels(self.m)

    def replace(self, **changes: Any) -> Problem:
        """A copy with some fields changed (validated again)."""
        fields = {
            name: getattr(self, name) for name in self.__dataclass_fields__ if name != "_cache"
        }
        fields.update(changes)
        return Problem(**fields)


def _outside_label(value: Any) -> str:
    """A limit the state is outside of, as a :class:`~lpik.labels.Binding` marked recovering.

    Plain words (a caller's own) stay words.
    """
    return value.outside() if isinstance(value, labels.Binding) else str(value)


def _check_ordered(lo_name: str, lo: FloatArray, hi_name: str, hi: FloatArray) -> None:
    bad = np.nonzero(lo > hi)[0]
    if bad.size:
        i = int(bad[0])
        raise InvalidProblemError(
            lo_name, f"{lo_name}[{i}] = {lo[i]:g} exceeds {hi_name}[{i}] = {hi[i]:g}"
        )
    if np.isposinf(lo).any():
        raise InvalidProblemError(lo_name, "a lower bound cannot be +inf")
    if np.isneginf(hi).any():
        raise InvalidProblemError(hi_name, "an upper bound cannot be -inf")


def _labels(
    name: str, value: Sequence[str] | None, size: int, default: str | None
) -> tuple[str, ...]:
    if value is None:
        return (default,) * size if default is not None else ()
    if isinstance(value, str):
        return (value,) * size
    try:
        labels = tuple(str(v) for v in value)
    except TypeError:
        raise InvalidProblemError(name, f"must be a list of {size} names") from None
    if len(labels) != size:
        raise InvalidProblemError(name, f"must have {size} entries, got {len(labels)}")
    return labels
