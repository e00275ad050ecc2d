"""Looking things up by name, with an error that lists the names there are."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TypeVar

T = TypeVar("T")


def lookup(table: Mapping[str, T], name: str, unknown: str) -> T:
    """``table[name]``, or a ``ValueError`` reading ``"<unknown> 'name'; available: a, b"``.

    Args:
        table: The named things.
        name: The name asked for.
        unknown: How the message starts, e.g. ``"scenario: unknown scenario"``.
    """
    try:
        return table[name]
    except KeyError:
        raise ValueError(f"{unknown} {name!r}; available: {', '.join(table)}") from None


def renamed_keyword(new: T | None, old: T | None, old_name: str, new_name: str) -> T | None:
    """The value of a keyword argument that was renamed: ``new``, or ``old`` with a warning.

    Raises:
        ValueError: When both are given.
    """
    if old is None:
        return new
    if new is not None:
        raise ValueError(f"{old_name}: renamed {new_name}; give {new_name} only")
    import warnings

    warnings.warn(f"{old_name} is renamed {new_name}", DeprecationWarning, stacklevel=3)
    return old
