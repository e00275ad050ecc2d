"""A live operator console in the browser: drag the target, watch ``p`` and the binding limit.

``lpik console --robot NAME`` (or ``--planar``) runs the robot's controller in
a server thread at its control period and shows it on a web page made with
viser (``pip install 'lpik[console]'``): the robot and the scene, a target
gizmo, the commanded path and the tool's trail, ``p`` as a gauge and over
time, the binding limit in words and lit on the robot, a bar per joint, and
controls for the method, speeds, bounds, recording and replay.

The logic lives in plain modules that need no browser: :mod:`~lpik.console.robot`
(what is driven), :mod:`~lpik.console.stepper` (the settings and the step
they select), :mod:`~lpik.console.loop` (the control loop thread),
:mod:`~lpik.console.record` (CSV recording and replay),
:mod:`~lpik.console.access` (who may connect) and :mod:`~lpik.console.geometry`
(what is drawn). :mod:`~lpik.console.view` and :mod:`~lpik.console.app` are the
viser layer.
"""

from lpik.console.loop import ControlLoop, Snapshot
from lpik.console.robot import ConsoleRobot, console_robot
from lpik.console.stepper import Settings

__all__ = ["ConsoleRobot", "ControlLoop", "Settings", "Snapshot", "console_robot"]
