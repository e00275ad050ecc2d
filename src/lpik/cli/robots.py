"""``lpik robots``: the bundled arms, their joints, limits, tip link and URDF file.

``lpik robots --json`` prints a JSON list of objects with the keys ``name``,
``n_joints``, ``joint_names``, ``q_min``, ``q_max`` [rad], ``qd_max`` [rad/s],
``tip_link`` and ``urdf`` (path of the file used); an unbounded limit is
``null``.

Every command that drives an arm takes it the same way, through
:func:`add_robot_arguments` and :func:`robot_from_arguments`: ``--robot NAME``
(a bundled arm) or ``--urdf FILE --tip LINK [--base LINK]`` (any URDF's chain).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lpik.robots.arm import Arm

JSON_KEYS = ("name", "n_joints", "joint_names", "q_min", "q_max", "qd_max", "tip_link", "urdf")


def add_robot_arguments(
    parser: argparse.ArgumentParser,
    *,
    default: str | None = None,
    robot_help: str = "a bundled 3-D arm (lpik robots)",
    urdf_help: str = "any arm from a URDF file (with --tip), started mid-way between its end-stops",
) -> argparse._MutuallyExclusiveGroup:
    """Add ``--robot NAME`` or ``--urdf FILE``, with ``--tip LINK`` and ``--base LINK``.

    ``--robot`` and ``--urdf`` exclude each other; read the choice with
    :func:`robot_from_arguments`.

    Args:
        parser: The command's parser.
        default: ``--robot``'s default; None makes one of the group required.
        robot_help: ``--robot``'s help.
        urdf_help: ``--urdf``'s help.

    Returns:
        The group of ``--robot`` and ``--urdf``, for a command to add another
        choice to (``lpik console --planar``).
    """
    which = parser.add_mutually_exclusive_group(required=default is None)
    which.add_argument("--robot", metavar="NAME", default=default, help=robot_help)
    which.add_argument("--urdf", metavar="FILE.urdf", help=urdf_help)
    parser.add_argument(
        "--tip", metavar="LINK", help="with --urdf: the link that carries the task point"
    )
    parser.add_argument(
        "--base",
        metavar="LINK",
        help="with --urdf: the link whose frame is the world frame (default: the URDF's root)",
    )
    return which


def robot_from_arguments(args: argparse.Namespace) -> str | Arm:
    """The arm that :func:`add_robot_arguments`' options name: ``--robot``'s name, or a URDF's.

    ``--robot NAME`` is returned as the name (checked where it is used); neither
    ``--robot`` nor ``--urdf`` (``lpik console --planar``) as the planar arm's
    name; ``--urdf FILE --tip LINK [--base LINK]`` as an
    :class:`lpik.robots.arm.Arm`, which ``Scenario.setup``, ``reach_setup`` and
    ``console_robot`` take in place of a name.

    Raises:
        ValueError: One line naming the option: ``--tip`` or ``--base`` without
            ``--urdf``, ``--urdf`` without ``--tip``, a file that is missing or
            not a valid URDF, a link the URDF does not have, a chain that is no
            chain or has no moving joint.
    """
    from lpik.paper.scenarios import PLANAR

    if args.urdf is None:
        for option in ("tip", "base"):
            if getattr(args, option) is not None:
                raise ValueError(f"--{option}: only with --urdf FILE")
        return PLANAR if args.robot is None else str(args.robot)
    if args.tip is None:
        raise ValueError("--tip: --urdf needs the link of the task point: --tip LINK")
    return _urdf_arm(args.urdf, args.tip, args.base)


def _urdf_arm(file: str, tip: str, base: str | None) -> Arm:
    """``--urdf FILE --tip LINK [--base LINK]`` read, or a one-line error naming the option."""
    from lpik.robots.arm import urdf_arm
    from lpik.robots.urdf import parse_urdf

    path = Path(file)
    if not path.is_file():
        reason = "it is a directory" if path.is_dir() else "no such file"
        raise ValueError(f"--urdf: cannot read {file!r}: {reason}")
    try:
        robot = parse_urdf(path)
    except ValueError as exc:
        raise ValueError(f"--urdf: {exc}") from None
    links = [link.name for link in robot.links]
    for option, link in (("--tip", tip), ("--base", base)):
        if link is not None and link not in robot.link_map:
            raise ValueError(
                f"{option}: {file!r} has no link {link!r}; its links: "
                + ", ".join(repr(name) for name in links)
            )
    try:
        return urdf_arm(path, tip_link=tip, base_link=base)
    except ValueError as exc:
        raise ValueError(f"--urdf: {exc}") from None


def check_scene_fits(robot: str | Arm, scene: object) -> None:
    """Refuse ``--scene`` for a ``--urdf`` arm whose links' collision radii lpik does not know.

    Collision avoidance needs every link's capsule; lpik knows them for the
    bundled arms (and a URDF's chain only when it is one of them, by name).

    Raises:
        ValueError: One line naming ``--scene``.
    """
    from lpik.robots.arm import Arm

    if scene is None or not isinstance(robot, Arm):
        return
    from lpik.collision import default_capsules
    from lpik.robots.registry import robot_names

    try:
        default_capsules(robot.chain)
    except (ValueError, KeyError):
        raise ValueError(
            f"--scene: collision avoidance needs the links' radii, which lpik knows for the "
            f"bundled arms only ({', '.join(robot_names())}), not for {robot.name!r} of --urdf; "
            "in Python, pass radii= to lpik.collision.collision_avoidance"
        ) from None


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik robots``."""
    parser = sub.add_parser(
        "robots",
        help="list the bundled robot arms (joints, limits, tip link, URDF file)",
        description="List the bundled robot arms that --robot NAME and "
        "lpik.robots.registry.load_robot(NAME) accept.",
    )
    parser.add_argument("names", nargs="*", metavar="NAME", help="only these robots")
    parser.add_argument("--json", action="store_true", help="print a JSON list instead")
    parser.set_defaults(handler=run)


def _finite_or_none(values: tuple[float, ...]) -> list[float | None]:
    return [v if math.isfinite(v) else None for v in values]


def robots_json(names: list[str] | None = None) -> list[dict[str, object]]:
    """The JSON objects of ``lpik robots --json``.

    Args:
        names: Only these robots, in this order; all when None or empty.

    Raises:
        ValueError: For an unknown robot name.
    """
    from lpik.robots.registry import get_spec, list_robots

    for name in names or ():
        get_spec(name)
    infos = {info.name: info for info in list_robots()}
    out = []
    for name in names or list(infos):
        info = infos[name]
        out.append(
            {
                "name": info.name,
                "n_joints": info.n_joints,
                "joint_names": list(info.joint_names),
                "q_min": _finite_or_none(info.q_min),
                "q_max": _finite_or_none(info.q_max),
                "qd_max": _finite_or_none(info.qd_max),
                "tip_link": info.tip_link,
                "urdf": info.urdf,
            }
        )
    return out


def _number(value: float | None) -> str:
    return "unbounded" if value is None else f"{value:.4f}"


def run(args: argparse.Namespace) -> int:
    """Print the listing; an unknown name raises ``ValueError`` (exit 2 in main)."""
    from lpik.robots.registry import get_spec

    entries = robots_json(list(args.names))
    if args.json:
        print(json.dumps(entries, indent=2))
        return 0
    for k, entry in enumerate(entries):
        if k:
            print()
        print(f"{entry['name']}: {get_spec(str(entry['name'])).description}")
        print(f"  {entry['n_joints']} joints, tip link {entry['tip_link']}")
        print(f"  URDF: {entry['urdf']}")
        names = list(entry["joint_names"])  # type: ignore[call-overload]
        width = max(len("joint"), *(len(n) for n in names))
        print(f"  {'joint':<{width}}  {'q_min [rad]':>11}  {'q_max [rad]':>11}  qd_max [rad/s]")
        rows = zip(names, entry["q_min"], entry["q_max"], entry["qd_max"])  # type: ignore[call-overload]
        for name, lo, hi, vel in rows:
            print(f"  {name:<{width}}  {_number(lo):>11}  {_number(hi):>11}  {_number(vel):>14}")
    return 0
