"""The runs of the paper's section 4, the multiplier bound derived from them, their figures.

Seven runs of the two scenarios (:mod:`lpik.paper.scenarios`), two of them
beyond the paper (saturation in the null space; the automatic multiplier
bound of :mod:`lpik.methods.autobound`, which needs no run to derive it).
:mod:`lpik.paper.reproduce` writes them, their figures (:data:`FIGURES`) and
the summary of :mod:`lpik.paper.report`:

==================================  =====================================  =========
run                                 method, multipliers                    figures
==================================  =====================================  =========
``pull-in-lp1``                     LP1, every step's LP solved on its own  3, 4a
``pull-in-lp1-warm-start``          LP1, HiGHS warm-started across steps   4a'
``pull-in-lp2``                     LP2, unbounded                         4b, 5, 6
``pull-in-lp2s``                    LP2 with saturation in the null space  10
``edge-singularity-lp2-unbounded``  LP2, unbounded                         7, 8
``edge-singularity-lp2-bounded``    LP2, ``|lam_i| <= B``                  9
``edge-singularity-lp2-auto``       LP2, the automatic bound               -
==================================  =====================================  =========

LP1's optimum is not unique (any vertex with the largest p is optimal), so
which vertex a step gets depends on the solver's starting basis. Solving each
step's LP on its own, as the paper states the method, is the reference run of
Figs. 3 and 4a; the warm-started run shows what a solver that keeps its basis
across steps does with the same LPs.

The bound ``B`` is not typed in: :func:`choose_lambda_bound` derives it from
the unbounded run's multiplier history (twice the largest ``|lam|`` seen while
the command is still followed in full, rounded up to one significant digit).
A sweep over a few bounds around it shows how the result depends on the choice.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from lpik.control.log import RunMetrics, SimulationLog
from lpik.paper.scenarios import get_scenario
from lpik.paper.setup import PAPER_COMMAND
from lpik.tolerances import FULL_P

#: The multiplier bound is this factor above the largest |lam| of the free motion.
BOUND_MARGIN = 2.0
#: Bounds run for the sweep table, besides the chosen one.
SWEEP_BOUNDS = (0.01, 1.0, 2.0, 10.0)

#: Figure file -> (what it shows, runs behind it).
FIGURES: dict[str, tuple[str, tuple[str, ...]]] = {
    "fig3-lp1-xy.png": ("Fig. 3: x-y motion under LP1", ("pull-in-lp1",)),
    "fig4-joint-motion.png": (
        "Fig. 4: joint motion under a) LP1, a') LP1 warm-started, b) LP2",
        ("pull-in-lp1", "pull-in-lp1-warm-start", "pull-in-lp2"),
    ),
    "fig5-lp2-xy.png": ("Fig. 5: x-y motion under LP2", ("pull-in-lp2",)),
    "fig6-dexterity.png": ("Fig. 6: affine dexterity under LP2", ("pull-in-lp2",)),
    "fig7-edge-singularity-xy.png": (
        "Fig. 7: displacement to the edge singularity",
        ("edge-singularity-lp2-unbounded",),
    ),
    "fig8-unbounded-multipliers.png": (
        "Fig. 8: joint motion near the singularity, unbounded multipliers",
        ("edge-singularity-lp2-unbounded",),
    ),
    "fig9-bounded-multipliers.png": (
        "Fig. 9: dexterity and joint motion, bounded multipliers",
        ("edge-singularity-lp2-bounded",),
    ),
    "fig10-saturation.png": (
        "Fig. 10 (beyond the paper): joint motion while pulling in, LP2 and LP2 with "
        "saturation in the null space",
        ("pull-in-lp2", "pull-in-lp2s"),
    ),
}

Progress = Callable[[str], None]


def round_up_1sig(value: float) -> float:
    """``value`` (> 0) rounded up to one significant digit, e.g. 0.094 -> 0.1, 0.23 -> 0.3."""
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"value: must be a finite number > 0, got {value!r}")
    exponent = math.floor(math.log10(value))
    scale = 10.0**exponent
    return float(f"{math.ceil(round(value / scale, 9)) * scale:.1g}")


@dataclass(frozen=True)
class BoundChoice:
    """The multiplier bound and the history it was derived from.

    Attributes:
        bound: The chosen symmetric bound B on every multiplier.
        free_max: Largest ``max_i |lam_i|`` while the command was followed in full (p = 1).
        free_until: Time of the last step with p = 1 [s].
        peak: Largest ``max_i |lam_i|`` of the run.
        peak_time: When the peak occurred [s].
        late_median: Median ``max_i |lam_i|`` over the last quarter of the run.
    """

    bound: float
    free_max: float
    free_until: float
    peak: float
    peak_time: float
    late_median: float


def choose_lambda_bound(log: SimulationLog, margin: float = BOUND_MARGIN) -> BoundChoice:
    """Derive a multiplier bound from an unbounded run's ``|lam|`` history.

    With ``M = I`` the multipliers are ``lam = -(J J^T)^-1 p dw``: they grow like
    ``1 / sigma_min(J)^2`` as the arm approaches a singularity. The bound is
    ``margin`` times the largest ``|lam|`` seen while the command is followed in
    full (``p = 1``), rounded up to one significant digit: it never restricts
    that free motion, and it caps the growth near the singularity.

    Raises:
        ValueError: When the log has no multipliers or no step with ``p = 1``.
    """
    if not np.isfinite(log.lam).any():
        raise ValueError(f"log: method {log.method!r} has no multipliers to derive a bound from")
    lam = np.nanmax(np.abs(log.lam), axis=1)
    free = log.p >= FULL_P
    if not free.any():
        raise ValueError("log: no step followed the command in full (p = 1)")
    peak = int(np.nanargmax(lam))
    free_max = float(np.nanmax(lam[free]))
    return BoundChoice(
        bound=round_up_1sig(margin * free_max),
        free_max=free_max,
        free_until=float(log.t[np.nonzero(free)[0][-1]]),
        peak=float(lam[peak]),
        peak_time=float(log.t[peak]),
        late_median=float(np.nanmedian(lam[-max(1, log.steps // 4) :])),
    )


def run_all(
    progress: Progress | None = None, sweep: Sequence[float] = SWEEP_BOUNDS
) -> tuple[dict[str, SimulationLog], BoundChoice, dict[float, RunMetrics]]:
    """Run the seven simulations (and the bound sweep); no files are written."""
    say = progress or (lambda _: None)
    pull, edge = get_scenario("pull-in"), get_scenario("edge-singularity")
    say("pull-in, lp1")
    # the paper's runs state LP2 as the paper does: unbounded multipliers (None)
    logs = {"pull-in-lp1": pull.run("lp1", warm_start=False, **PAPER_COMMAND)}
    say("pull-in, lp1, warm-started")
    logs["pull-in-lp1-warm-start"] = pull.run("lp1", **PAPER_COMMAND)
    say("pull-in, lp2")
    logs["pull-in-lp2"] = pull.run("lp2", lambda_bound=None, **PAPER_COMMAND)
    say("pull-in, lp2s")
    logs["pull-in-lp2s"] = pull.run("lp2s", lambda_bound=None, **PAPER_COMMAND)
    say("edge-singularity, lp2, unbounded multipliers")
    logs["edge-singularity-lp2-unbounded"] = edge.run("lp2", lambda_bound=None, **PAPER_COMMAND)
    choice = choose_lambda_bound(logs["edge-singularity-lp2-unbounded"])
    say(f"edge-singularity, lp2, |lambda| <= {choice.bound:g}")
    logs["edge-singularity-lp2-bounded"] = edge.run(
        "lp2", lambda_bound=choice.bound, **PAPER_COMMAND
    )
    say("edge-singularity, lp2, the automatic bound (lpik's default)")
    logs["edge-singularity-lp2-auto"] = edge.run("lp2", **PAPER_COMMAND)
    metrics = {choice.bound: logs["edge-singularity-lp2-bounded"].metrics()}
    for bound in sweep:
        if bound not in metrics:
            say(f"edge-singularity, lp2, |lambda| <= {bound:g} (sweep)")
            metrics[bound] = edge.run("lp2", lambda_bound=bound, **PAPER_COMMAND).metrics()
    return logs, choice, dict(sorted(metrics.items()))
