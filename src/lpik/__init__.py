"""lpik: inverse kinematics of redundant manipulators as small linear programs.

The top level holds what one step needs: :class:`Problem`, :func:`solve` and
:class:`Result`. Limits are in :mod:`lpik.limits`, robot models in
:mod:`lpik.robots`, the closed loop in :mod:`lpik.simulate`, the compiled
path in :mod:`lpik.fast`.
"""

from lpik.exceptions import InvalidProblemError, LpikError, MissingBackendError
from lpik.methods import ALL_METHODS, solve
from lpik.problem import Problem
from lpik.result import STATUSES, Result

__version__ = "0.1.0"

__all__ = [
    "ALL_METHODS",
    "STATUSES",
    "InvalidProblemError",
    "LpikError",
    "MissingBackendError",
    "Problem",
    "Result",
    "__version__",
    "solve",
]
