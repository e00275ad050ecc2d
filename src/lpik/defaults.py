"""The defaults every way of taking a step shares, where a light module can read them.

The command line reads them without importing the methods; the methods'
registry (:mod:`lpik.methods.registry`), the stepper and the controller
read them from here.
"""

#: The method every way of taking a step uses unless told otherwise: LP2 with
#: saturation in the null space (``lp2s``). The paper's runs name ``lp2`` explicitly.
DEFAULT_METHOD = "lp2s"
