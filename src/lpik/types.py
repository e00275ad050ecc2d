"""Array types used in lpik's signatures."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

#: A float64 array (vector or matrix).
FloatArray = NDArray[np.float64]


class NotRealError(TypeError):
    """Numbers that are not real: booleans or complex numbers (:func:`real_array`)."""


def _flags_or_complex(value: object) -> str | None:
    """``"booleans"`` or ``"complex numbers"`` where a (nested) list or tuple holds one."""
    if isinstance(value, bool | np.bool_):
        return "booleans"
    if isinstance(value, complex | np.complexfloating):
        return "complex numbers"
    if isinstance(value, list | tuple):
        for item in value:
            found = _flags_or_complex(item)
            if found:
                return found
    return None


def real_array(value: object, order: str = "K") -> FloatArray:
    """``value`` as a new float64 array, refusing what numpy would turn into reals silently.

    numpy takes ``True`` as 1.0 (also inside a list of numbers) and drops the
    imaginary part of a complex number with only a warning: a switch or a
    complex result given for joint coordinates or limits would move the arm.

    Raises:
        NotRealError: For booleans or complex numbers, saying which.
        TypeError, ValueError: Where numpy cannot make floats of ``value`` at all.
    """
    arr = np.asarray(value)
    kind = arr.dtype.kind
    if kind == "b":
        raise NotRealError("booleans")
    if kind == "c":
        raise NotRealError("complex numbers")
    found = _flags_or_complex(value) if isinstance(value, list | tuple) else None
    if found:
        raise NotRealError(found)
    return np.array(arr, dtype=np.float64, order=order)


def numbers_of(name: str, value: Any, wanted: str = "numbers", order: str = "K") -> FloatArray:
    """``value`` as a new float64 array (:func:`real_array`), or a ValueError.

    Raises:
        ValueError: ``"<name>: must be <wanted>, got <what>"``, ``what`` the value's
            type, or the booleans or complex numbers it holds.
    """
    try:
        return real_array(value, order=order)
    except (TypeError, ValueError) as exc:
        what = str(exc) if isinstance(exc, NotRealError) else type(value).__name__
        raise ValueError(f"{name}: must be {wanted}, got {what}") from None
