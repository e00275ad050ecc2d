"""The defaults every way of taking a step shares, where a light module can read them.

The command line reads them without importing the methods; the methods'
registry (:mod:`lpik.methods.registry`), the stepper and the controller
read them from here.
"""

#: The method every way of taking a step uses unless told otherwise: LP2 with
#: saturation in the null space (``lp2s``). The paper's runs name ``lp2`` explicitly.
DEFAULT_METHOD = "lp2s"

#: Steps that stall (``p`` near 0 and no motion along the command,
#: :data:`lpik.tolerances.STALL_P`) in a row before the progress step
#: (:mod:`lpik.methods.progress`) is taken; ``None``: never (the paper's strict step,
#: the default). Opt-in (``on_stall=1``) because, measured: with targets beyond reach
#: the least-L1 step jumps between vertices (lp2s's joint-velocity jitter 26,440 rad/s
#: against 447 strict), and under acceleration limits a start from rest reads as a stall.
DEFAULT_ON_STALL: int | None = None

#: The ways a controller spends the limits: ``"exact"`` keeps the commanded direction
#: (the paper's steps, the default); ``"progress"`` adds, after the exact step, the step
#: that most reduces the task error left (:func:`lpik.methods.progress.further_step`).
MODES = ("exact", "progress")
DEFAULT_MODE = "exact"
