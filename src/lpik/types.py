"""Array types used in lpik's signatures."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: A float64 array (vector or matrix).
FloatArray = NDArray[np.float64]
