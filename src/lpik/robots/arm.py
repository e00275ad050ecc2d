"""A 3-D arm to drive: its kinematic chain, its start configuration and its name.

What a scenario (:meth:`lpik.paper.scenarios.Scenario.setup`), a reach run
(:func:`lpik.paper.reach.reach_setup`) and the console
(:func:`lpik.console.robot.console_robot`) need of an arm besides its name:
a bundled arm (:func:`bundled_arm`) starts at its home configuration; an arm
read from any URDF (:func:`urdf_arm`) starts in the middle of its end-stops
(0 for a joint without end-stops), the default ``q_ref`` of sec. 3.1
(:func:`lpik.problem.reference_configuration`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from lpik.problem import reference_configuration
from lpik.robots.base import TaskModel
from lpik.robots.chain import SerialChain
from lpik.robots.registry import home_configuration, load_chain
from lpik.robots.tasks import make_task
from lpik.robots.urdf import load_urdf
from lpik.types import FloatArray


@dataclass(frozen=True, eq=False)
class Arm:
    """A serial arm with the configuration it starts from.

    Attributes:
        name: The arm's name (a bundled arm's, or the URDF's robot name).
        chain: Its kinematics from the base link to the tip link.
        home: The start configuration, shape (n,) [rad or m].
    """

    name: str
    chain: SerialChain
    home: FloatArray

    def task(self, task: str = "pose") -> TaskModel:
        """The arm's task model: ``"position"`` (3 rows), ``"orientation"`` or ``"pose"`` (6)."""
        return make_task(self.chain, task=task, name=self.name)


def bundled_arm(name: str) -> Arm:
    """A bundled arm (:func:`lpik.robots.registry.robot_names`) at its home configuration.

    Raises:
        ValueError: For an unknown name (the message lists the bundled arms).
    """
    return Arm(name, load_chain(name), home_configuration(name))


def urdf_arm(source: str | os.PathLike[str], tip_link: str, base_link: str | None = None) -> Arm:
    """A URDF's chain from ``base_link`` to ``tip_link``, started mid-way between end-stops.

    Args:
        source: A path to a ``.urdf`` file or the XML text.
        tip_link: The link the task point is attached to.
        base_link: The link whose frame is the world frame; the URDF's root link when None.

    Raises:
        ValueError: As :func:`lpik.robots.urdf.load_urdf` (unreadable or malformed
            file, unknown link, no chain, no moving joint, ...).
    """
    chain = load_urdf(source, tip_link=tip_link, base_link=base_link)
    home = reference_configuration(chain.q_min, chain.q_max, np.zeros(chain.n_joints))
    return Arm(chain.name, chain, np.asarray(home, dtype=float))


def as_arm(robot: str | Arm) -> Arm:
    """``robot`` as an :class:`Arm`: itself, or the bundled arm of that name."""
    return robot if isinstance(robot, Arm) else bundled_arm(robot)
