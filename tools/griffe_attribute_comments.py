"""A griffe extension for the documentation site: ``#:`` comments as attributes' docstrings.

lpik documents its constants and data the Sphinx way, with ``#:`` comment
lines right above the assignment (``#: Every method, by name, ...`` above
``METHODS = ...``), which Sphinx's autodoc and IDEs read. griffe reads only a
string after the assignment, so without this the reference page would show
``METHODS`` with no words. An attribute that has no docstring of its own
takes the ``#:`` lines right above its first line.
"""

from __future__ import annotations

from typing import Any

import griffe

#: The prefix of a documentation comment line (after indentation).
PREFIX = "#:"


def comment_above(lines: list[str], lineno: int) -> str | None:
    """The ``#:`` lines right above line ``lineno`` (1-based), joined; None when there are none."""
    found: list[str] = []
    k = lineno - 2
    while k >= 0 and lines[k].lstrip().startswith(PREFIX):
        found.append(lines[k].lstrip()[len(PREFIX) :].strip())
        k -= 1
    return "\n".join(reversed(found)) or None


class AttributeComments(griffe.Extension):
    """Give every attribute without a docstring the ``#:`` comment above it."""

    def on_attribute_instance(self, *, attr: griffe.Attribute, **kwargs: Any) -> None:
        """Called by griffe for every attribute it loads."""
        if attr.docstring is not None or attr.lineno is None:
            return
        try:
            lines = attr.module.lines
        except Exception:  # no source (a compiled module): nothing to read
            return
        text = comment_above(lines, attr.lineno)
        if text is not None:
            attr.docstring = griffe.Docstring(text, lineno=attr.lineno - 1, parent=attr)
