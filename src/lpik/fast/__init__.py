"""LP2 at control-loop speed: compiled kernels (numba), batches, fused control steps.

Needs the optional package numba (``pip install "lpik[fast]"``); the kernels
are compiled on first use and cached on disk. Everything here returns the
same answers as the pure-numpy path of :func:`lpik.methods.lp2.lp2`.
"""

from __future__ import annotations

from importlib.util import find_spec

from lpik.exceptions import MissingBackendError


def available() -> bool:
    """True when numba is installed, so the compiled path can run."""
    return find_spec("numba") is not None


if not available():
    raise MissingBackendError("lpik.fast (the compiled LP2 path)", "fast")

from lpik.fast.batch import BatchArrays, BatchResult, lp2_batch, lp2_compiled  # noqa: E402

__all__ = ["BatchArrays", "BatchResult", "available", "lp2_batch", "lp2_compiled"]
