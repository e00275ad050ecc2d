"""Compiled twins: functions compiled as they are, with the helpers they call rebound.

Some rules are written once, as plain loops over small arrays, in the numpy
layers (:mod:`lpik.bands`, :mod:`lpik.methods.singular`) and run there as
Python. :func:`compiled_twin` compiles the function's own code object (not a
copy of its source) with the helpers it calls bound to their compiled twins,
so the numpy path and the fused step run the same code.

:func:`inlined_twin` does the same for a kernel's own parts, inlined into
their caller at numba's IR level: a part compiled on its own is optimised
again, with everything it calls, inside every compiled function that calls
it, so a deep chain of parts costs its compile time several times over
(the first-call table of ``docs/benchmarks.md``).
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from numba import njit


def rebound(function: Callable[..., Any], **helpers: Any) -> types.FunctionType:
    """``function``'s own code with ``helpers`` in place of its globals of those names."""
    function = getattr(function, "py_func", function)  # a numba dispatcher: its Python function
    scope = dict(function.__globals__)
    scope.update(helpers)
    return types.FunctionType(function.__code__, scope, function.__name__, function.__defaults__)


def compiled_twin(function: Callable[..., Any], **helpers: Any) -> Any:
    """``function`` compiled (numba, cached on disk), with ``helpers`` replacing its globals."""
    return njit(cache=True)(rebound(function, **helpers))


def inlined_twin(function: Callable[..., Any], **helpers: Any) -> Any:
    """``function`` (or a dispatcher's), inlined into each compiled caller; ``helpers`` rebound."""
    return njit(inline="always")(rebound(function, **helpers))
