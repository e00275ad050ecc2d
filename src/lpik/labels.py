"""Binding labels: the words a step uses to say which limit keeps ``p`` below 1.

Every path (the numpy methods, the compiled kernels, batches, the controller,
``lpik simulate``'s CSV and ``lpik solve``'s JSON) spells a limit with the
functions of this module, so that one limit has one label everywhere:

- a joint's bound on ``dq`` (eqs. 13-14): ``"<joint> lower end-stop"``,
  ``"<joint> upper velocity limit"``, ``"<joint> lower acceleration limit"``;
- a multiplier bound (sec. 3.2): ``"multiplier 2 upper bound"``;
- an extra row ``G q <= h``: the row's own label (default ``"row 1"``);
- ``p < 1`` with no limit active (``J`` cannot produce ``dw``): ``"singularity"``.
"""

from __future__ import annotations

from collections.abc import Sequence

#: What can set a joint's bound on ``dq``, in the order of the compiled kernels' kind codes.
BOUND_KINDS = ("end-stop", "velocity limit", "acceleration limit")
END_STOP, VELOCITY_LIMIT, ACCELERATION_LIMIT = BOUND_KINDS
#: The sides of a bound, lower first (binding code ``2 k`` is lower, ``2 k + 1`` upper).
SIDES = ("lower", "upper")
#: Label when ``p < 1`` although no limit is active (paper sec. 3.2).
SINGULARITY = "singularity"


def default_joint_names(n: int) -> tuple[str, ...]:
    """``"joint 1"`` ... ``"joint n"``: the names of joints that have none."""
    return tuple(f"joint {i + 1}" for i in range(n))


def default_row_labels(r: int) -> tuple[str, ...]:
    """``"row 1"`` ... ``"row r"``: the labels of extra rows that have none."""
    return tuple(f"row {i + 1}" for i in range(r))


def bound_label(joint: str, side: str, kind: str) -> str:
    """A joint's bound on ``dq``, e.g. ``"joint 1 upper end-stop"``."""
    return f"{joint} {side} {kind}"


def multiplier_label(index: int, side: str) -> str:
    """The bound of multiplier ``index`` (0-based), e.g. ``"multiplier 1 upper bound"``."""
    return f"multiplier {index + 1} {side} bound"


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
    for row in row_labels:
        labels += [row, row]
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
    for name in joint_names:
        for side in SIDES:
            joints += [bound_label(name, side, kind) for kind in BOUND_KINDS]
    rest = code_labels((), (), m, row_labels)
    return (*joints, *rest)
