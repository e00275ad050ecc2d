"""Compiled kernels that take a few argument types only, each compiled when first asked for.

A kernel a control loop calls (the fused step) must never compile in the middle
of the loop: a call with other argument types raises ``TypeError`` (the caller
converts its arguments), as a dispatcher compiled for explicit signatures does.
But compiling every signature up front costs the first controller the compile
time of the ones it never calls (a position task's xyz target, a pose task's
4x4), so :func:`typed_kernel` compiles (or loads from numba's disk cache) only
the signatures asked for, and more of them when asked again.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from numba import njit

_KERNELS: dict[str, Any] = {}


def typed_kernel(name: str, function: Callable[..., Any], signatures: Iterable[Any]) -> Any:
    """The dispatcher of ``function`` (one per ``name``), ready for each of ``signatures``.

    A signature is a tuple of argument types (as numba keys its disk cache when
    a caller compiles the kernel, so that both find one entry). Signatures it
    already has cost nothing; a new one is compiled, or loaded from the disk
    cache. Calls with argument types of no readied signature raise ``TypeError``.
    """
    dispatcher = _dispatcher(name, function)
    dispatcher.disable_compile(False)
    try:
        for signature in signatures:
            dispatcher.compile(signature)  # returns at once for one it has
    finally:
        if dispatcher.signatures:
            dispatcher.disable_compile(True)
    return dispatcher


def _dispatcher(name: str, function: Callable[..., Any]) -> Any:
    """The one dispatcher of ``function`` for ``name`` in this process (made lazily)."""
    dispatcher = _KERNELS.get(name)
    if dispatcher is None:
        dispatcher = _KERNELS[name] = njit(cache=True)(function)
    return dispatcher


def loaded_kernel(name: str) -> Any:
    """The dispatcher :func:`typed_kernel` made for ``name`` in this process, or None."""
    return _KERNELS.get(name)


def load_cached(dispatcher: Any, signature: tuple[Any, ...]) -> bool:
    """Whether ``dispatcher`` has ``signature``, loading it from numba's disk cache; never compiles.

    numba offers no public "load, but do not compile": this does what
    ``Dispatcher.compile`` does before it compiles (its cache's
    ``load_overload``, under numba's compiler lock). Any failure there (another
    numba, an unreadable cache) counts as not cached, and the caller compiles
    as it would have.
    """
    args = tuple(signature)
    if args in dispatcher.overloads:
        return True
    try:
        from numba.core.compiler_lock import global_compiler_lock

        with global_compiler_lock:
            compiled = dispatcher._cache.load_overload(args, dispatcher.targetctx)
            if compiled is None:
                return False
            dispatcher.targetctx.insert_user_function(
                compiled.entry_point, compiled.fndesc, [compiled.library]
            )
            dispatcher.add_overload(compiled)
    except Exception:  # any failure: not cached, compile as before
        return False
    return True


def cached_kernel(name: str, function: Callable[..., Any], signatures: Iterable[Any]) -> Any:
    """:func:`typed_kernel`'s dispatcher if every signature loads without compiling, else None."""
    dispatcher = _dispatcher(name, function)
    if not all(load_cached(dispatcher, tuple(signature)) for signature in signatures):
        return None
    dispatcher.disable_compile(True)
    return dispatcher
