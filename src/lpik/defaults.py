"""The defaults every way of taking a step shares, where a light module can read them.

The command line reads them without importing the methods; the methods'
registry (:mod:`lpik.methods.registry`), the stepper and the controller
read them from here.
"""

#: The method every way of taking a step uses unless told otherwise: LP2 with
#: saturation in the null space (``lp2s``). The paper's runs name ``lp2`` explicitly.
DEFAULT_METHOD = "lp2s"

#: Steps that stall (:func:`lpik.methods.progress.is_stall`: no step along the command,
#: or one with ``p <= STALL_P`` (``STALL_BLEND_P`` right after a progress step) that
#: gains far less than the progress step, a start from rest excepted) in a row before the
#: progress step (:mod:`lpik.methods.progress`) is taken; ``None``: never (the paper's
#: strict step: the direction or no motion). On by default, so that an arm with a target
#: it could still come nearer to does not freeze.
#: The paper's runs name ``None`` (:data:`lpik.paper.setup.PAPER_COMMAND`).
DEFAULT_ON_STALL: int | None = 1

#: The ways a controller spends the limits: ``"exact"`` keeps the commanded direction
#: (the paper's steps, the default); ``"progress"`` adds, after the exact step, the step
#: that most reduces the task error left (:func:`lpik.methods.progress.further_step`).
MODES = ("exact", "progress")
DEFAULT_MODE = "exact"

#: When a controller compiles its kernels (:mod:`lpik.control.warmup`): ``"background"``
#: loads them from numba's disk cache when it has them, and otherwise takes its steps on
#: the numpy engine (the same answers) while a child process compiles them, moving to
#: the compiled step when they are ready; ``"now"`` compiles them when the controller is
#: built (about a minute on an empty cache), so that every step is compiled.
COMPILE_MODES = ("background", "now")
DEFAULT_COMPILE = "background"
#: The environment variable that sets the default of ``compile`` for a whole process
#: (the test suite sets ``now``, so that every controller's steps are the compiled ones).
COMPILE_ENV = "LPIK_COMPILE"
