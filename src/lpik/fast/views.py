"""Strided views of a flat float buffer, for the compiled kernels.

A kernel keeps its arrays in one contiguous float64 buffer (a workspace, a
controller's state) and looks at parts of it through these views. Each is the
same array as ``buf[offset : offset + size].reshape(shape)``, but numba's
``reshape`` calls a C helper on every view, which adds up over the few dozen
views of a step, while a strided view costs nothing. The strides are computed
from the buffer's itemsize.

Each view is compiled for one signature (:data:`MATRIX_SIGNATURE`, ...) when
the module is imported: a kernel passes block constants and literal sizes
(``matrix(buf, 0, 4, 4)``), which numba would otherwise type as literals and
compile the view again for each combination.
"""

from __future__ import annotations

from numba import njit
from numpy.lib.stride_tricks import as_strided

#: The one signature of :func:`matrix`: a (rows, cols) view of a float64 buffer.
MATRIX_SIGNATURE = "float64[:, :](float64[::1], int64, int64, int64)"
#: The one signature of :func:`tensor3`.
TENSOR3_SIGNATURE = "float64[:, :, :](float64[::1], int64, int64, int64, int64)"


@njit(MATRIX_SIGNATURE, cache=True)
def matrix(buf, offset, rows, cols):
    """The C-ordered (rows, cols) view of the contiguous 1-D ``buf`` from ``offset``."""
    size = buf.itemsize
    return as_strided(buf[offset:], shape=(rows, cols), strides=(cols * size, size))


@njit(TENSOR3_SIGNATURE, cache=True)
def tensor3(buf, offset, d0, d1, d2):
    """The C-ordered (d0, d1, d2) view of the contiguous 1-D ``buf`` from ``offset``."""
    size = buf.itemsize
    return as_strided(buf[offset:], shape=(d0, d1, d2), strides=(d1 * d2 * size, d2 * size, size))


@njit(cache=True)
def flat(a):
    """The C-contiguous array ``a`` (any number of axes) as a 1-D view."""
    return as_strided(a, shape=(a.size,), strides=(a.itemsize,))
