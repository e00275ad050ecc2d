"""Compiled twins: functions of the numpy layers compiled as they are.

Some rules are written once, as plain loops over small arrays, in the numpy
layers (:mod:`lpik.bands`, :mod:`lpik.methods.singular`) and run there as
Python. :func:`compiled_twin` compiles the function's own code object (not a
copy of its source) with the helpers it calls bound to their compiled twins,
so the numpy path and the fused step run the same code.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from numba import njit


def compiled_twin(function: Callable[..., Any], **helpers: Any) -> Any:
    """``function`` compiled (numba, cached on disk), with ``helpers`` replacing its globals."""
    scope = dict(function.__globals__)
    scope.update(helpers)
    clone = types.FunctionType(function.__code__, scope, function.__name__, function.__defaults__)
    return njit(cache=True)(clone)
