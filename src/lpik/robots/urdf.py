"""Serial chains from URDF files.

The XML is read by ``urdf_parser_py`` (``pip install urdf-parser-py``, the
parser of the ROS ``urdf_parser_py`` project, github.com/ros/urdf_parser_py).
It was chosen over the alternatives because it is the smallest maintained
one: it needs only PyYAML and lxml, while ``yourdfpy`` pulls ``trimesh[easy]``
(about thirty packages: shapely, embreex, manifold3d, httpx, ...) and
``urchin`` pulls trimesh, networkx, pyribbit and pyglet, all for meshes and
rendering that lpik does not use. lpik keeps on top of the parser only what
the kinematics needs: the path of joints from a base link to a tip link, and
checks that name the element at fault.

Joint types: ``revolute`` (needs ``<limit lower upper velocity>``),
``continuous`` (unbounded; the velocity limit is used when given), ``prismatic``
(needs ``<limit>``) and ``fixed`` (folded into the next joint's origin).
``floating`` and ``planar`` joints, and joints that mimic another joint, are
refused when they lie on the chain; joints off the chain (grippers, sensors)
are ignored whatever their type.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from lpik.robots.chain import ChainJoint, SerialChain
from lpik.robots.rotations import transform

SUPPORTED_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed")


def _parser():
    from urdf_parser_py import urdf as urdf_module
    from urdf_parser_py.xml_reflection import core

    return urdf_module, core


def read_urdf_text(source: str | os.PathLike[str]) -> tuple[str, str]:
    """Return the XML text of a URDF and a label for error messages.

    Args:
        source: A path to a ``.urdf`` file, or the XML text itself (a string
            whose first non-blank character is ``<``).

    Raises:
        ValueError: If the file cannot be read (missing, a directory, not
            UTF-8 text such as a binary file), or ``source`` is neither a path
            nor text; the message names the file.
    """
    if isinstance(source, str) and source.lstrip().startswith("<"):
        return source, "<URDF string>"
    if not isinstance(source, str | os.PathLike):
        raise ValueError(f"URDF: expected a path or XML text, got {type(source).__name__}")
    path = Path(source)
    try:
        return path.read_text(encoding="utf-8"), str(path)
    except OSError as exc:
        raise ValueError(f"URDF file '{path}' cannot be read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        byte = exc.object[exc.start]
        raise ValueError(
            f"URDF file '{path}' cannot be read: not UTF-8 text (byte 0x{byte:02x} at offset "
            f"{exc.start}); a URDF is an XML text file"
        ) from None


def parse_urdf(source: str | os.PathLike[str]):
    """Parse a URDF into ``urdf_parser_py``'s ``Robot`` and check its tree.

    Args:
        source: A path to a ``.urdf`` file or the XML text.

    Returns:
        The parsed robot (``links``, ``joints``, ``joint_map``, ``parent_map``).

    Raises:
        ValueError: As :func:`_parse`.
    """
    return _parse(source)[0]


def _parse(source: str | os.PathLike[str]):
    """Parse a URDF and check its tree; return the robot and a label for messages.

    Unknown elements (``<gazebo>``, ``<mujoco>``, ...) are extensions and are
    ignored without a message.

    Args:
        source: A path to a ``.urdf`` file or the XML text.

    Returns:
        The parsed robot and the file name (or ``<URDF string>``).

    Raises:
        ValueError: Malformed XML, a root element other than ``<robot>``, a
            missing or ill-typed attribute (the message gives the element's
            path), duplicate link or joint names, a joint naming an undeclared
            link, or a link with two parent joints.
    """
    text, label = read_urdf_text(source)
    urdf_module, core = _parser()
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ValueError(f"URDF {label}: malformed XML: {exc}") from None
    if root.tag != "robot":
        raise ValueError(f"URDF {label}: the root element is <{root.tag}>, expected <robot>")
    quiet, core.on_error = core.on_error, lambda message: None  # unknown tags are extensions
    try:
        robot = urdf_module.URDF.from_xml_string(text)
    except core.ParseError as exc:
        raise ValueError(f"URDF {label}: {exc.path}: {exc.e}") from None
    except (ValueError, AssertionError, TypeError) as exc:
        raise ValueError(f"URDF {label}: {exc}") from None
    finally:
        core.on_error = quiet
    _check_tree(robot, label)
    return robot, label


def _check_tree(robot, label: str) -> None:
    links = [link.name for link in robot.links]
    for kind, names in (("link", links), ("joint", [j.name for j in robot.joints])):
        seen: set[str] = set()
        for name in names:
            if name in seen:
                raise ValueError(f"URDF {label}: duplicate {kind} name '{name}'")
            seen.add(name)
    declared = set(links)
    parent_of: dict[str, str] = {}
    for joint in robot.joints:
        for role in ("parent", "child"):
            link = getattr(joint, role)
            if link not in declared:
                raise ValueError(
                    f"URDF {label}: joint '{joint.name}' names {role} link '{link}', "
                    "which is not declared"
                )
        if joint.child in parent_of:
            raise ValueError(
                f"URDF {label}: link '{joint.child}' is the child of two joints, "
                f"'{parent_of[joint.child]}' and '{joint.name}'"
            )
        parent_of[joint.child] = joint.name


def _limits(joint, label: str) -> tuple[float, float, float]:
    """End-stops and velocity limit of a moving joint."""
    limit = joint.limit
    if joint.type == "continuous":
        velocity = np.inf if limit is None or limit.velocity is None else float(limit.velocity)
        return -np.inf, np.inf, velocity
    if limit is None:
        raise ValueError(
            f"URDF {label}: {joint.type} joint '{joint.name}' has no <limit> "
            "(lower, upper and velocity are needed)"
        )
    lower, upper, velocity = float(limit.lower), float(limit.upper), float(limit.velocity)
    if not (np.isfinite(lower) and np.isfinite(upper)) or lower > upper:
        raise ValueError(
            f"URDF {label}: joint '{joint.name}' <limit>: need finite lower <= upper, "
            f"got lower={lower}, upper={upper}"
        )
    if not velocity > 0:
        raise ValueError(
            f"URDF {label}: joint '{joint.name}' <limit>: velocity must be > 0, got {velocity}"
        )
    return lower, upper, velocity


def _origin(joint) -> np.ndarray:
    if joint.origin is None:
        return np.eye(4)
    return transform(joint.origin.xyz or (0.0, 0.0, 0.0), joint.origin.rpy or (0.0, 0.0, 0.0))


def chain_path(robot, base_link: str, tip_link: str, label: str) -> list:
    """Joints from ``base_link`` to ``tip_link`` in order (URDF joint objects).

    Raises:
        ValueError: If a link is unknown, or ``tip_link`` does not descend
            from ``base_link``.
    """
    names = [link.name for link in robot.links]
    for role, link in (("base", base_link), ("tip", tip_link)):
        if link not in robot.link_map:
            raise ValueError(
                f"URDF {label}: unknown {role} link '{link}'; available: " + ", ".join(names)
            )
    path = []
    link = tip_link
    while link != base_link:
        if link not in robot.parent_map:
            raise ValueError(
                f"URDF {label}: links '{base_link}' and '{tip_link}' do not form a chain: "
                f"'{tip_link}' does not descend from '{base_link}'"
            )
        joint_name, link = robot.parent_map[link]
        path.append(robot.joint_map[joint_name])
    path.reverse()
    return path


def load_urdf(
    source: str | os.PathLike[str],
    tip_link: str,
    base_link: str | None = None,
    tool: ArrayLike | None = None,
    name: str | None = None,
) -> SerialChain:
    """Read the serial chain from ``base_link`` to ``tip_link`` of a URDF.

    Args:
        source: A path to a ``.urdf`` file or the XML text.
        tip_link: The link the task point is attached to.
        base_link: The link whose frame is the world frame; the URDF's root
            link when None.
        tool: Offset of the task point from ``tip_link``: a 4 x 4 transform,
            xyz (3,) [m] or xyz + rpy (6,) [m, rad]; identity when None.
        name: Model name; the URDF's robot name when None.

    Returns:
        The chain; every link on the path is a frame that
        :meth:`SerialChain.fk` accepts.

    Raises:
        ValueError: On malformed files, unknown links, a base/tip pair that is
            not a chain, unsupported joint types or mimic joints on the chain,
            and missing or invalid limits; the message names the element.
    """
    robot, label = _parse(source)
    if base_link is None:
        roots = [link.name for link in robot.links if link.name not in robot.parent_map]
        if len(roots) != 1:
            raise ValueError(
                f"URDF {label}: expected one root link, found {len(roots)}: {roots}; pass base_link"
            )
        base_link = roots[0]
    path = chain_path(robot, base_link, tip_link, label)
    joints: list[ChainJoint] = []
    links: dict[str, tuple[int, np.ndarray]] = {}
    pending = np.eye(4)  # fixed transforms since the last moving joint
    for joint in path:
        if joint.type not in SUPPORTED_JOINT_TYPES:
            raise ValueError(
                f"URDF {label}: joint '{joint.name}' on the chain from '{base_link}' to "
                f"'{tip_link}' has unsupported type '{joint.type}'; supported: "
                + ", ".join(SUPPORTED_JOINT_TYPES)
            )
        if joint.mimic is not None:
            raise ValueError(
                f"URDF {label}: joint '{joint.name}' on the chain mimics '{joint.mimic.joint}'; "
                "mimic joints are not supported on the chain"
            )
        if joint.type == "fixed":
            pending = pending @ _origin(joint)
            links[joint.child] = (len(joints) - 1, pending.copy())
            continue
        lower, upper, velocity = _limits(joint, label)
        axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), dtype=float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-12:
            raise ValueError(f"URDF {label}: joint '{joint.name}' <axis>: need a non-zero xyz")
        kind = "prismatic" if joint.type == "prismatic" else "revolute"
        joints.append(
            ChainJoint(joint.name, kind, pending @ _origin(joint), axis, lower, upper, velocity)
        )
        links[joint.child] = (len(joints) - 1, np.eye(4))
        pending = np.eye(4)
    if not joints:
        raise ValueError(
            f"URDF {label}: the chain from '{base_link}' to '{tip_link}' has no moving joint"
        )
    links.pop(tip_link, None)
    return SerialChain(
        joints,
        tip_offset=pending,
        tool=tool,
        name=name or robot.name,
        base_link=base_link,
        tip_link=tip_link,
        links=links,
    )
