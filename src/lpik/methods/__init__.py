"""One-step inverse-kinematics methods: each takes one :class:`~lpik.problem.Problem`.

=========  ==================================================  ===============
name       what                                                paper
=========  ==================================================  ===============
pinv       Moore-Penrose pseudo-inverse                        eqs. 8-9
weighted   weighted least-norm step (M, f; Lambda, q_ref)      eq. 7, sec. 3.1
robust     Komainda's robust (damped) inverse                  eq. 19
lp1        Schlemmer's LP: max p, no criterion                 eqs. 11-14
l1         Ho's LP: min ||dq||_1                               sec. 2.3
lp2        max p with the quadratic criterion as LP rows       eqs. 15-18, 3.1-3.2
nlp        Schlemmer's nonlinear program (needs the model)     sec. 2.2
=========  ==================================================  ===============

:mod:`lpik.methods.registry` holds the table that every caller reads.
"""

from __future__ import annotations

from lpik.methods.classical import pinv, robust, weighted, yoshikawa_manipulability
from lpik.methods.l1 import l1
from lpik.methods.lp1 import lp1
from lpik.methods.lp2 import affine_solution, lp2, ratio_test
from lpik.methods.nlp import nlp
from lpik.methods.registry import ALL_METHODS, METHODS, MethodSpec, get_method, solve

__all__ = [
    "ALL_METHODS",
    "METHODS",
    "MethodSpec",
    "affine_solution",
    "get_method",
    "l1",
    "lp1",
    "lp2",
    "nlp",
    "pinv",
    "ratio_test",
    "robust",
    "solve",
    "weighted",
    "yoshikawa_manipulability",
]
