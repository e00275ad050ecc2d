"""A griffe extension for the documentation site: defaults shown as their values.

lpik writes its defaults once, as named constants (``v_max: float = DEFAULT_V_MAX``
in :mod:`lpik.command`). griffe reads the source, so the site would show the
name; a reader wants the number. This extension replaces every default (of a
function's parameter, or of a dataclass field, which becomes the default of
its ``__init__``) that names something by the value it has in its module:

1. by evaluating it in the imported module (the value the code runs with);
2. where that module cannot be imported here (e.g. numba is missing), by
   following the names through griffe's own tree to a literal.

Only values that read back as the same Python literal are shown (numbers,
strings, booleans, None and tuples of them); anything else (a call, an object)
stays as written in the source. tests/test_docs.py checks that the reference
page shows no constant's name where a default stands.
"""

from __future__ import annotations

import ast
import importlib
from typing import Any

import griffe

#: Longest value shown in place of a name (a longer one stays as written).
MAX_SHOWN = 60


def literal(value: Any) -> str | None:
    """``repr(value)`` when it reads back as the same literal and is short, else None."""
    text = repr(value)
    if len(text) > MAX_SHOWN:
        return None
    try:
        same = ast.literal_eval(text) == value
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        return None
    return text if same is True else None


def names_only(source: str) -> bool:
    """Whether ``source`` is an expression of names, attributes, constants and operators."""
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError:
        return False
    allowed = (ast.Expression, ast.Name, ast.Attribute, ast.Constant, ast.Load, ast.BinOp,
               ast.UnaryOp, ast.Tuple, ast.operator, ast.unaryop)  # fmt: skip
    has_name = any(isinstance(node, ast.Name) for node in ast.walk(tree))
    return has_name and all(isinstance(node, allowed) for node in ast.walk(tree))


def imported_value(module: str, source: str) -> str | None:
    """``source`` evaluated in the imported ``module``, as a literal (None if it cannot be)."""
    try:
        namespace = vars(importlib.import_module(module))
        return literal(eval(source, dict(namespace)))  # noqa: S307 (names of lpik's own modules)
    except Exception:  # an optional dependency missing, a name not at module level
        return None


def static_value(obj: griffe.Object, source: str, depth: int = 0) -> str | None:
    """A single name ``source`` followed through griffe's tree to a literal (None if not)."""
    if depth > 8 or not source.isidentifier():
        return None
    try:
        target = obj.module.members[source]
        target = target.final_target if target.is_alias else target
    except Exception:  # not a member of the module, or an alias that does not resolve
        return None
    value = getattr(target, "value", None)
    if value is None:
        return None
    text = str(value)
    try:
        return literal(ast.literal_eval(text))
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        return static_value(target, text, depth + 1)


def shown(obj: griffe.Object, default: Any) -> str | None:
    """The value to show for ``default`` (an expression of ``obj``'s module), or None."""
    if default is None or isinstance(default, str):
        return None  # a literal already (griffe keeps those as strings) or no default
    source = str(default)
    if not names_only(source):
        return None
    return imported_value(obj.module.path, source) or static_value(obj, source)


class DefaultValues(griffe.Extension):
    """Replace named defaults by their values once the package is loaded."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        """Called by griffe once the package is loaded (before the dataclasses extension)."""
        self._visit(pkg, set())

    def _visit(self, obj: griffe.Object, seen: set[str]) -> None:
        if obj.path in seen:
            return
        seen.add(obj.path)
        for member in list(obj.members.values()):
            if member.is_alias:
                continue  # shown where it is defined
            if member.is_function:
                for parameter in member.parameters:
                    value = shown(member, parameter.default)
                    if value is not None:
                        parameter.default = value
            elif member.is_attribute and obj.is_class and "class-attribute" in member.labels:
                value = shown(member, member.value)
                if value is not None:
                    member.value = value
            if member.is_class or member.is_module:
                self._visit(member, seen)
