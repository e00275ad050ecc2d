"""lpik: inverse kinematics of redundant manipulators as small linear programs."""

__version__ = "0.1.0"
