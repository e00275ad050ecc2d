"""Where a compiled engine registers its one-problem step, so the methods never import it.

The numpy methods (:func:`lpik.methods.lp2.lp2`, :func:`lpik.methods.lp2s.lp2s`)
offer ``path="compiled"``. The compiled engine lives in a layer above them
(:mod:`lpik.fast`, which needs numba: ``lpik[fast]``); like an optional solver
backend, it registers its step here when its module is imported
(:func:`register_compiled`), and :func:`compiled_step` imports that module by
name on first use. The methods layer thus names the engine's module but never
imports its code, and a missing numba is a clear :class:`MissingBackendError`.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable

from lpik.exceptions import MissingBackendError
from lpik.highs import HighsSolver
from lpik.problem import Problem
from lpik.result import Result

#: A compiled one-problem step: ``step(problem, solver) -> Result``.
CompiledStep = Callable[[Problem, "HighsSolver | None"], Result]
#: The module that registers the compiled engine when it is imported.
COMPILED_ENGINE_MODULE = "lpik.fast.batch"
_COMPILED: dict[str, CompiledStep] = {}


def register_compiled(method: str, step: CompiledStep) -> None:
    """Register ``step`` as the compiled engine's answer to ``method`` (``lp2``, ``lp2s``)."""
    _COMPILED[method] = step


def compiled_step(method: str) -> CompiledStep:
    """The compiled engine's step for ``method``, its module imported on first use.

    Raises:
        MissingBackendError: When numba (``lpik[fast]``) is not installed.
    """
    if method not in _COMPILED or COMPILED_ENGINE_MODULE not in sys.modules:
        try:
            importlib.import_module(COMPILED_ENGINE_MODULE)
        except ImportError:
            raise MissingBackendError("the compiled LP2 path (numba)", "fast") from None
    return _COMPILED[method]
