"""Control: the command law, the closed loop, and the controller a 1 kHz loop calls.

- :mod:`lpik.command`: the one command law (``v_max`` linear, ``w_max`` angular);
- :mod:`lpik.control.simulate` and :mod:`lpik.control.log`: the closed loop and its record;
- :mod:`lpik.control.controller`: :class:`Lp2Controller`, the fused compiled LP2
  step (needs numba: ``pip install "lpik[fast]"``; imported on first use).
"""

from __future__ import annotations

from typing import Any

from lpik.command import DEFAULT_V_MAX, DEFAULT_W_MAX, ClampedTarget, CommandLaw
from lpik.control.log import RunMetrics, SimulationLog
from lpik.control.simulate import Progress, simulate

__all__ = [
    "DEFAULT_V_MAX",
    "DEFAULT_W_MAX",
    "ClampedTarget",
    "CommandLaw",
    "Lp2Controller",
    "Progress",
    "RunMetrics",
    "SimulationLog",
    "simulate",
]


def __getattr__(name: str) -> Any:
    if name == "Lp2Controller":  # numba is optional: import the compiled path on first use
        from lpik.control.controller import Lp2Controller

        return Lp2Controller
    raise AttributeError(f"module 'lpik.control' has no attribute {name!r}")
