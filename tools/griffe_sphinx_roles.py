"""A griffe extension for the documentation site: Sphinx roles in docstrings as code.

lpik's docstrings cross-reference with Sphinx roles (``:class:`~lpik.problem.Problem```),
which help() and IDEs show as they are. mkdocstrings renders Markdown, so the
roles become inline code here: ``Problem`` (``~``: the last part of the name),
else the name as written. tests/test_docs.py checks that every qualified name
a role gives resolves to an object of lpik.
"""

from __future__ import annotations

import re
from typing import Any

import griffe

#: A Sphinx cross-reference role: ``:class:`name```, ``:func:`~a.b```.
ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):`(~?)([^`]+)`")


def plain(text: str) -> str:
    """``text`` with every Sphinx role replaced by its name as inline code."""
    return ROLE.sub(lambda m: f"`{m.group(2).split('.')[-1] if m.group(1) else m.group(2)}`", text)


class SphinxRoles(griffe.Extension):
    """Rewrite each loaded object's docstring with :func:`plain`."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        """Called by griffe for every object it loads."""
        if obj.docstring is not None:
            obj.docstring.value = plain(obj.docstring.value)
