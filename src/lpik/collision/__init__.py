"""Collision avoidance: obstacles and scenes, the robot's capsules, distances, rows and field.

``coal`` computes the distances (``pip install "lpik[collision]"``).
"""

from lpik.collision.avoidance import (
    CollisionAvoidance,
    DistanceRows,
    field_force,
    repulsion,
)
from lpik.collision.bodies import LinkCapsule, RobotBodies, frame_capsules, urdf_capsules
from lpik.collision.distance import Proximities, Proximity, robot_bodies, signed_distance
from lpik.collision.model import BUNDLED_RADII, as_avoidance, collision_avoidance, default_capsules
from lpik.collision.scene_json import load_scene, scene_from_dict
from lpik.collision.shapes import Obstacle, Scene

__all__ = [
    "BUNDLED_RADII",
    "CollisionAvoidance",
    "DistanceRows",
    "LinkCapsule",
    "Obstacle",
    "Proximities",
    "Proximity",
    "RobotBodies",
    "Scene",
    "as_avoidance",
    "collision_avoidance",
    "default_capsules",
    "field_force",
    "frame_capsules",
    "load_scene",
    "repulsion",
    "robot_bodies",
    "scene_from_dict",
    "signed_distance",
    "urdf_capsules",
]
