"""The defaults every way of taking a step shares, where a light module can read them.

The command line reads them without importing the methods; the methods'
registry (:mod:`lpik.methods.registry`), the stepper and the controller
read them from here.
"""

#: The method every way of taking a step uses unless told otherwise: LP2 with
#: saturation in the null space (``lp2s``). The paper's runs name ``lp2`` explicitly.
DEFAULT_METHOD = "lp2s"

#: Steps that stall (:func:`lpik.methods.progress.is_stall`: no step along the command,
#: or one with ``p <= STALL_P`` that gains far less than the progress step, a start from
#: rest excepted) in a row before the progress step (:mod:`lpik.methods.progress`) is
#: taken; ``None``: never (the paper's strict step: the direction or no motion). On by
#: default, so that an arm with a target it could still come nearer to does not freeze.
#: The paper's runs name ``None`` (:data:`lpik.paper.setup.PAPER_COMMAND`).
DEFAULT_ON_STALL: int | None = 1

#: The ways a controller spends the limits: ``"exact"`` keeps the commanded direction
#: (the paper's steps, the default); ``"progress"`` adds, after the exact step, the step
#: that most reduces the task error left (:func:`lpik.methods.progress.further_step`).
MODES = ("exact", "progress")
DEFAULT_MODE = "exact"
