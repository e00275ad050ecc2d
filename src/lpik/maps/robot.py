"""The arm a map is made for: its task model, chain arrays, rows, limits and home.

A map takes ``"planar"`` (the paper's planar 4-link arm as in its pull-in
runs: links 1 m, end-stops -180..95 deg for joint 1 and -180..180 deg for the
others, 1 rad/s; the position task x, y), the name of a bundled arm (its pose
task, from its home configuration), an arm read from a URDF
(:class:`lpik.robots.arm.Arm`: its pose task, from the middle of its
end-stops), or a task model over a :class:`~lpik.robots.chain.SerialChain`.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from lpik.paper.scenarios import PLANAR, SCENARIOS
from lpik.problem import reference_configuration
from lpik.robots.chain import SerialChain
from lpik.robots.planar import planar_arm
from lpik.robots.registry import home_configuration, load_robot
from lpik.types import FloatArray

#: The paper's scenario whose planar arm a ``"planar"`` map is of.
PLANAR_SCENARIO = "pull-in"
#: Task row names, in the order of a chain's six Jacobian rows.
SIX_ROWS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True, eq=False)
class MapRobot:
    """An arm as a map needs it.

    Attributes:
        name: The name the map's ``robot`` attribute carries.
        model: Its task model (the rows the map commands).
        rows: Indices of the task's rows among x, y, z, rx, ry, rz.
        home: The first seed of every pose's solve, and the tool orientation
            of a map with one orientation.
        fingerprint: A digest of the chain and its limits: a map is only ever
            continued for the same arm.
    """

    name: str
    model: Any
    rows: tuple[int, ...]
    home: FloatArray
    fingerprint: str

    @property
    def chain(self) -> SerialChain:
        """The serial chain under the task."""
        return self.model.kinematics  # type: ignore[no-any-return]

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.model.n_joints)

    def chain_arrays(self) -> tuple[Any, ...]:
        """``SerialChain.arrays()`` as the compiled kernels take them."""
        origins, axes, revolute, tip = self.chain.arrays()
        return (np.ascontiguousarray(origins, dtype=np.float64),
                np.ascontiguousarray(axes, dtype=np.float64),
                np.ascontiguousarray(revolute, dtype=np.float64),  # 1.0: revolute
                np.ascontiguousarray(tip, dtype=np.float64))  # fmt: skip

    def home_rotation(self) -> FloatArray:
        """The tool's rotation (3, 3) at :attr:`home`."""
        return np.asarray(self.chain.fk(self.home), dtype=np.float64)[:3, :3]


def map_robot(robot: Any) -> MapRobot:
    """``robot`` (a name, an :class:`lpik.robots.arm.Arm` or a task model) as a :class:`MapRobot`.

    Raises:
        ValueError: For an unknown name, or a model that is not over a serial chain.
    """
    if isinstance(robot, MapRobot):
        return robot
    if robot == PLANAR:
        arm = SCENARIOS[PLANAR_SCENARIO].paper
        model = planar_arm(arm.link_lengths, arm.q_min, arm.q_max, arm.qd_max, name=PLANAR)
        return _described(PLANAR, model, np.array(arm.q0))
    if isinstance(robot, str):
        return _described(robot, load_robot(robot, "pose"), home_configuration(robot))
    if hasattr(robot, "chain") and hasattr(robot, "home"):  # an Arm (a URDF's)
        return _described(str(robot.name), robot.task("pose"), np.asarray(robot.home, float))
    chain = getattr(robot, "kinematics", None)
    if not isinstance(chain, SerialChain):
        raise ValueError(
            f"robot: a map needs '{PLANAR}', a bundled arm's name, an Arm or a task model over "
            f"a SerialChain (load_robot, load_urdf + make_task), got {type(robot).__name__}"
        )
    home = reference_configuration(chain.q_min, chain.q_max, np.zeros(chain.n_joints))
    return _described(str(robot.name), robot, home)


def _described(name: str, model: Any, home: FloatArray) -> MapRobot:
    """The :class:`MapRobot` of a task model: its rows and its fingerprint."""
    rows = tuple(SIX_ROWS.index(r) for r in model.row_names)
    digest = hashlib.sha256()
    for array in (*model.kinematics.arrays(), model.q_min, model.q_max, model.qd_max, rows):
        digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    return MapRobot(name, model, rows, np.asarray(home, dtype=np.float64), digest.hexdigest()[:16])
