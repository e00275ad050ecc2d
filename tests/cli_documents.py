"""The command-line tests' shared inputs: a good ``lpik solve`` document and the output keys."""

from __future__ import annotations

import sys
from pathlib import Path

#: The installed ``lpik`` console script beside this interpreter.
LPIK = Path(sys.executable).with_name("lpik")

#: A valid problem document: the paper's planar arm, one pull-in step, with step bounds.
GOOD = {
    "method": "lp2",
    "J": [[-0.866, 0.0, 0.5, 0.5], [3.232, 2.732, 1.866, 0.866]],
    "dw": [-0.005, 0.0],
    "q0": [1.047, -0.524, -0.524, -0.524],
    "q_min": [-3.14, -3.14, -3.14, -3.14],
    "q_max": [1.658, 3.14, 3.14, 3.14],
    "dq_min": [-0.01, -0.01, -0.01, -0.01],
    "dq_max": [0.01, 0.01, 0.01, 0.01],
}

#: The keys of ``lpik solve``'s JSON answer.
OUTPUT_KEYS = {"q", "dq", "p", "lam", "status", "binding", "pull_scale"}
