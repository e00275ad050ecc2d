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
