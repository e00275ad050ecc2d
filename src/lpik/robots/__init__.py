"""Kinematic models behind one protocol (:class:`~lpik.robots.base.TaskModel`).

The paper's planar arm (:class:`PlanarArm`), 3-D serial chains read from URDF
(:mod:`lpik.robots.urdf`, :mod:`lpik.robots.chain`) with their tasks
(:mod:`lpik.robots.tasks`), and the bundled arms (:func:`load_robot`).
"""

from lpik.robots.base import TaskModel
from lpik.robots.chain import SerialChain
from lpik.robots.planar import PlanarArm
from lpik.robots.registry import home_configuration, list_robots, load_robot, robot_names
from lpik.robots.tasks import OrientationTask, PoseTask, PositionTask, make_task
from lpik.robots.urdf import load_urdf

__all__ = [
    "OrientationTask",
    "PlanarArm",
    "PoseTask",
    "PositionTask",
    "SerialChain",
    "TaskModel",
    "home_configuration",
    "list_robots",
    "load_robot",
    "load_urdf",
    "make_task",
    "robot_names",
]
