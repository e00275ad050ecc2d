"""Binding labels: which limit keeps ``p`` below 1, as a value and as words.

Every path (the numpy methods, the compiled kernels, batches, the controller,
``lpik simulate``'s CSV and ``lpik solve``'s JSON) names a limit with the
functions of this module, so that one limit has one label everywhere. A label
is a :class:`Binding`: a string (the words below, which the JSON key and the
CSV column carry) that also says what it names, so that a program can ask
which joint, which kind and which side without reading the words:

- a joint's bound on ``dq`` (eqs. 13-14): ``"<joint> lower end-stop"``,
  ``"<joint> upper velocity limit"``, ``"<joint> lower acceleration limit"``
  (``kind`` ``"end-stop"``, ``"velocity"``, ``"acceleration"``; ``index`` the
  joint, ``name`` its name, ``side`` ``"lower"`` or ``"upper"``);
- a multiplier bound (sec. 3.2): ``"multiplier 2 upper bound"`` (``kind``
  ``"multiplier"``, ``index`` the task row);
- an extra row ``G q <= h``: the row's own label (default ``"row 1"``;
  ``kind`` ``"row"``); a distance row of collision avoidance:
  ``"collision panda_link5 - shelf"`` (``kind`` ``"collision"``);
- ``p < 1`` with no limit active (``J`` cannot produce ``dw``): ``"singularity"``;
  a joint held at one value whose motion ``J`` needs along a direction the free
  joints have lost is named instead (:func:`lpik.methods.singular.held_joint_code`).

A step from a state outside its limits (status ``recovering``) names the
limit the state is outside of, with ``recovering = True``.

No binding limit is written one way: ``None`` in Python (a
:class:`~lpik.result.Result`, a :class:`~lpik.control.log.SimulationLog`, the
controller, a batch), ``null`` in ``lpik solve``'s JSON and an empty field in
``lpik simulate``'s CSV (which has no other way to write nothing).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

#: What can set a joint's bound on ``dq``, in the order of the compiled kernels' kind codes.
BOUND_KINDS = ("end-stop", "velocity limit", "acceleration limit")
END_STOP, VELOCITY_LIMIT, ACCELERATION_LIMIT = BOUND_KINDS
#: The sides of a bound, lower first (binding code ``2 k`` is lower, ``2 k + 1`` upper).
SIDES = ("lower", "upper")

#: The kinds of limit a :class:`Binding` can name.
KINDS = ("end-stop", "velocity", "acceleration", "multiplier", "row", "collision", "singularity")
#: A joint bound's words (:data:`BOUND_KINDS`) to its :attr:`Binding.kind`.
_KIND_OF_BOUND = dict(zip(BOUND_KINDS, KINDS[:3]))


class Binding(str):
    """The limit that keeps ``p`` below 1: its label, a string, and what it names.

    A ``Binding`` *is* its label (it compares, hashes and prints as the words,
    and is written as them to JSON and CSV); its attributes say what the words
    say. It is immutable.

    Attributes:
        kind: One of :data:`KINDS` (a custom step bound keeps its own word).
        index: The joint (0-based) for a joint's bound, the task row for a
            multiplier bound, the row of ``G q <= h`` for a row; ``None`` for
            a singularity.
        name: The joint's name, or the row's label; ``None`` otherwise.
        side: ``"lower"`` or ``"upper"`` (a row ``G q <= h`` is an upper
            bound); ``None`` for a singularity.
        recovering: True when the state is outside this limit (status ``recovering``).
    """

    kind: str
    index: int | None
    name: str | None
    side: str | None
    recovering: bool

    def __new__(
        cls,
        label: str,
        kind: str,
        index: int | None = None,
        name: str | None = None,
        side: str | None = None,
        recovering: bool = False,
    ) -> Binding:
        """A label and what it names (see the class's attributes)."""
        obj = super().__new__(cls, label)
        fields = {"kind": kind, "index": index, "name": name, "side": side}
        fields["recovering"] = bool(recovering)
        obj.__dict__.update(fields)
        return obj

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"a Binding is immutable: cannot set {name!r}")

    def __delattr__(self, name: str) -> None:
        raise AttributeError(f"a Binding is immutable: cannot delete {name!r}")

    def __reduce__(self) -> tuple[Any, ...]:
        return (Binding, (self.label, self.kind, self.index, self.name, self.side, self.recovering))

    def __repr__(self) -> str:
        extra = ", recovering=True" if self.recovering else ""
        return (
            f"Binding({self.label!r}, kind={self.kind!r}, index={self.index!r}, "
            f"name={self.name!r}, side={self.side!r}{extra})"
        )

    @property
    def label(self) -> str:
        """The words, as a plain string (what JSON and CSV carry)."""
        return str.__str__(self)

    def outside(self) -> Binding:
        """The same limit, named as one the state is outside of (``recovering = True``)."""
        return Binding(self.label, self.kind, self.index, self.name, self.side, True)

    def as_dict(self) -> dict[str, Any]:
        """The fields by name, with the label: ``label, kind, index, name, side, recovering``."""
        return {"label": self.label, **self.__dict__}


#: Label when ``p < 1`` although no limit is active (paper sec. 3.2).
SINGULARITY = Binding("singularity", "singularity")


def default_joint_names(n: int) -> tuple[str, ...]:
    """``"joint 1"`` ... ``"joint n"``: the names of joints that have none."""
    return tuple(f"joint {i + 1}" for i in range(n))


def default_row_labels(r: int) -> tuple[str, ...]:
    """``"row 1"`` ... ``"row r"``: the labels of extra rows that have none."""
    return tuple(f"row {i + 1}" for i in range(r))


def bound_label(joint: str, side: str, kind: str, index: int | None = None) -> Binding:
    """Joint ``index``'s bound on ``dq``, e.g. ``"joint 1 upper end-stop"``.

    ``kind`` is one of :data:`BOUND_KINDS` (or a custom step bound's word).
    """
    return Binding(f"{joint} {side} {kind}", _KIND_OF_BOUND.get(kind, kind), index, joint, side)


def multiplier_label(index: int, side: str) -> Binding:
    """The bound of multiplier ``index`` (0-based), e.g. ``"multiplier 1 upper bound"``."""
    return Binding(f"multiplier {index + 1} {side} bound", "multiplier", index, None, side)


def row_label(index: int | None, label: str, kind: str = "row") -> Binding:
    """Row ``index`` of ``G q <= h``, named by its label (``kind`` ``"row"`` or ``"collision"``).

    ``index`` None: a pair that has no row (:func:`lpik.collision.recovery.unmovable`).

    A label that is already a :class:`Binding` keeps its kind.
    """
    if isinstance(label, Binding):
        return Binding(label.label, label.kind, index, label.name or label.label, "upper")
    return Binding(label, kind, index, label, "upper")


def multiplier_labels(m: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Labels of the lower and of the upper bounds of ``m`` multipliers."""
    return tuple(multiplier_label(k, "lower") for k in range(m)), tuple(
        multiplier_label(k, "upper") for k in range(m)
    )


def code_labels(
    lower_labels: Sequence[str], upper_labels: Sequence[str], m: int, row_labels: Sequence[str]
) -> tuple[str, ...]:
    """Labels indexed by the LP2 kernel's binding codes.

    Constraint ``k`` runs over the joints, then the ``m`` multipliers, then the
    rows; code ``2 k`` is its lower side and ``2 k + 1`` its upper side. The
    two codes after them spell :data:`SINGULARITY`.
    """
    lam_lo, lam_hi = multiplier_labels(m)
    labels: list[str] = []
    for lo, hi in zip((*lower_labels, *lam_lo), (*upper_labels, *lam_hi)):
        labels += [lo, hi]
    for j, row in enumerate(row_labels):
        labels += [row_label(j, row)] * 2
    # LP2's singular path: p held by a direction J cannot move in
    # (lpik.methods.singular.singularity_code)
    return (*labels, SINGULARITY, SINGULARITY)


def step_label_table(
    joint_names: Sequence[str], m: int, row_labels: Sequence[str]
) -> tuple[str, ...]:
    """Every label a fused control step can report, in the order of its label index.

    For each joint and side, one label per kind in :data:`BOUND_KINDS` (index
    ``3 (2 k + side) + kind``); then the multipliers' and rows' labels of
    :func:`code_labels` (from ``6 n``).
    """
    joints: list[str] = []
    for i, name in enumerate(joint_names):
        for side in SIDES:
            joints += [bound_label(name, side, kind, i) for kind in BOUND_KINDS]
    rest = code_labels((), (), m, row_labels)
    return (*joints, *rest)


#: First word of the label of a pair of bodies that a distance row or the field watches.
COLLISION = "collision"


def pair_name(body: str, other: str) -> str:
    """A pair of bodies, e.g. ``"panda_link5 - shelf"`` (the robot's link first)."""
    return f"{body} - {other}"


def collision_label(body: str, other: str) -> Binding:
    """The distance row of a pair of bodies, e.g. ``"collision panda_link5 - shelf"``.

    A :class:`Binding` of kind ``"collision"`` whose ``name`` is the pair
    (:func:`row_label` keeps the kind and gives it its row's index).
    """
    pair = pair_name(body, other)
    return Binding(f"{COLLISION} {pair}", "collision", None, pair, "upper")
