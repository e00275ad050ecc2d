"""Kinematic models behind one protocol (:class:`~lpik.robots.base.TaskModel`)."""

from lpik.robots.base import TaskModel
from lpik.robots.planar import PlanarArm

__all__ = ["PlanarArm", "TaskModel"]
