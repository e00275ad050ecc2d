"""``lpik robots``: the bundled arms, their joints, limits, tip link and URDF file.

``lpik robots --json`` prints a JSON list of objects with the keys ``name``,
``n_joints``, ``joint_names``, ``q_min``, ``q_max`` [rad], ``qd_max`` [rad/s],
``tip_link`` and ``urdf`` (path of the file used); an unbounded limit is
``null``.
"""

from __future__ import annotations

import argparse
import json
import math

JSON_KEYS = ("name", "n_joints", "joint_names", "q_min", "q_max", "qd_max", "tip_link", "urdf")


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
