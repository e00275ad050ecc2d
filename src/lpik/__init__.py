"""lpik: inverse kinematics of redundant manipulators as small linear programs.

Every step reports the affine dexterity ``p`` (how much of the command the
robot follows, 0..1) and the limit that stops it. What a user needs is here:

- one step: :class:`Problem`, :func:`solve`, :class:`Result` (its binding limit a
  :class:`Binding`), with limits as data
  (:class:`EndStops`, :class:`VelocityLimits`, :class:`AccelerationLimits`,
  :class:`MultiplierBounds`, :class:`LinearRows`) stacked by :func:`build_problem`;
- robots: :func:`load_robot` (bundled arms), :func:`load_urdf` and :func:`make_task`
  (your own), :func:`planar_arm` (the paper's planar arm);
- the closed loop: :func:`simulate` with :class:`ClampedTarget`;
- at control-loop speed (numba, ``pip install "lpik[fast]"``, imported on first
  use): :class:`Lp2Controller`, :func:`lp2_batch`, :class:`BatchArrays`.

``docs/architecture.md`` maps the packages behind these names.
"""

from typing import Any

from lpik.control import ClampedTarget, SimulationLog, simulate
from lpik.exceptions import InvalidProblemError, LpikError, MissingBackendError
from lpik.labels import Binding
from lpik.limits import (
    AccelerationLimits,
    EndStops,
    LinearRows,
    MultiplierBounds,
    VelocityLimits,
    build_problem,
    standard_limits,
)
from lpik.methods import ALL_METHODS, METHODS, solve
from lpik.problem import Problem
from lpik.result import STATUSES, Result
from lpik.robots import home_configuration, load_robot, load_urdf, make_task, planar_arm
from lpik.version import __version__

#: Names that need numba, imported when first asked for: name -> module.
_COMPILED = {
    "Lp2Controller": "lpik.control.controller",
    "lp2_batch": "lpik.fast.batch",
    "BatchArrays": "lpik.fast.batch",
    "BatchResult": "lpik.fast.batch",
}

__all__ = [
    "ALL_METHODS",
    "METHODS",
    "STATUSES",
    "AccelerationLimits",
    "BatchArrays",
    "BatchResult",
    "Binding",
    "ClampedTarget",
    "EndStops",
    "InvalidProblemError",
    "LinearRows",
    "Lp2Controller",
    "LpikError",
    "MissingBackendError",
    "MultiplierBounds",
    "Problem",
    "Result",
    "SimulationLog",
    "VelocityLimits",
    "__version__",
    "build_problem",
    "home_configuration",
    "load_robot",
    "load_urdf",
    "lp2_batch",
    "make_task",
    "planar_arm",
    "simulate",
    "solve",
    "standard_limits",
]


def __getattr__(name: str) -> Any:
    if name in _COMPILED:
        import importlib

        return getattr(importlib.import_module(_COMPILED[name]), name)
    raise AttributeError(f"module 'lpik' has no attribute {name!r}")
