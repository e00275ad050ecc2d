"""LP2 at control-loop speed: compiled kernels (numba), batches, fused control steps.

Needs the optional package numba (``pip install "lpik[fast]"``); the kernels
are compiled on first use and cached on disk. Everything here returns the
same answers as the pure-numpy path of :func:`lpik.methods.lp2.lp2`.

- :mod:`lpik.fast.lp2_kernel`: LP2's ratio test (eqs. 15-18) as one kernel;
- :mod:`lpik.fast.kinematics`: a serial chain's pose, Jacobian and pose error;
- :mod:`lpik.fast.layout` and :mod:`lpik.fast.step`: the fused control step
  behind :class:`lpik.control.controller.Lp2Controller` and its state buffer,
  with the automatic multiplier bound (sec. 3.2) of :mod:`lpik.fast.autobound`;
- :mod:`lpik.fast.arrays` and :mod:`lpik.fast.batch`: one problem
  (``lp2(problem, path="compiled")``) and batches of problems (:func:`lp2_batch`);
- ``lpik compile`` (:mod:`lpik.cli.compile`): every kernel readied at once.
"""

from __future__ import annotations

from importlib.util import find_spec

from lpik.exceptions import MissingBackendError


def available() -> bool:
    """True when numba is installed, so the compiled path can run."""
    return find_spec("numba") is not None


if not available():
    raise MissingBackendError("lpik.fast (the compiled LP2 path)", "fast")

from lpik.fast.batch import BatchArrays, BatchResult, lp2_batch  # noqa: E402

__all__ = ["BatchArrays", "BatchResult", "available", "lp2_batch"]
