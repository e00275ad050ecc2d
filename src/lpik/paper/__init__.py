"""The paper's section 4: its scenarios, their reproduction, the report and the figures.

- :mod:`lpik.paper.scenarios`: the experiments as data, on the planar arm or a 3-D arm;
- :mod:`lpik.paper.runs`: the runs of section 4 and the multiplier bound derived from them;
- :mod:`lpik.paper.report`: their ``summary.md``;
- :mod:`lpik.paper.reproduce`: ``lpik reproduce`` (CSV logs, figures, the summary);
- :mod:`lpik.paper.figures`, :mod:`lpik.paper.run_figures`, :mod:`lpik.paper.style`:
  the figures (matplotlib, ``pip install "lpik[plot]"``).

This layer uses the core, the robots and the control loop; none of them uses it.
"""

from lpik.paper.scenarios import PLANAR, SCENARIOS, Scenario, Setup, get_scenario, scenario_names

__all__ = ["PLANAR", "SCENARIOS", "Scenario", "Setup", "get_scenario", "scenario_names"]
