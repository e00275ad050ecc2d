"""Kinematic models behind one protocol (:class:`~lpik.robots.base.TaskModel`).

Serial chains (:mod:`lpik.robots.chain`), read from URDF (:mod:`lpik.robots.urdf`)
or built for the paper's planar arm (:func:`planar_arm`)
with their tasks
(:mod:`lpik.robots.tasks`), and the bundled arms (:func:`load_robot`).
"""

from lpik.robots.base import TaskModel
from lpik.robots.chain import SerialChain
from lpik.robots.planar import planar_arm, planar_chain
from lpik.robots.registry import home_configuration, list_robots, load_robot, robot_names
from lpik.robots.tasks import OrientationTask, PoseTask, PositionTask, make_task
from lpik.robots.urdf import load_urdf

__all__ = [
    "OrientationTask",
    "PoseTask",
    "PositionTask",
    "SerialChain",
    "TaskModel",
    "home_configuration",
    "list_robots",
    "load_robot",
    "load_urdf",
    "make_task",
    "planar_arm",
    "planar_chain",
    "robot_names",
]
