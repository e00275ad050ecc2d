"""``lpik console --robot NAME | --urdf FILE --tip LINK | --planar``: the console in the browser.

Starts the robot's controller in a server thread and a web page to drive it
(:mod:`lpik.console`), prints the page's URL and runs until Ctrl-C (or
SIGTERM), which stops the page, the server and the controller and exits 0.
Listens on 127.0.0.1 unless ``--host`` says otherwise; any other interface
needs the access token the printed URL carries.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from typing import Any


def add_parser(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Register ``lpik console`` (light: viser is imported only when it runs)."""
    from lpik.cli.robots import add_robot_arguments
    from lpik.console.app import DEFAULT_HOST, DEFAULT_PORT
    from lpik.methods.registry import METHODS

    parser = sub.add_parser(
        "console",
        help="drive a robot from the browser: drag the target, watch p and the binding limit",
        description="Start the operator console: the controller runs in a server thread at "
        "its control period (1 kHz for the 3-D arms, 10 ms for the paper's planar arm); "
        "the page shows the robot, the scene, a target gizmo, p and the binding limit. "
        "Needs viser: pip install 'lpik[console]'.",
    )
    which = add_robot_arguments(parser)
    which.add_argument("--planar", action="store_true", help="the paper's planar 4-link arm")
    parser.add_argument(
        "--scene", metavar="SCENE.json", help="obstacles to avoid (2-D for --planar)"
    )
    parser.add_argument("--method", default="lp2s", help=f"one of {', '.join(METHODS)} (lp2s)")
    parser.add_argument(
        "--host",
        default=DEFAULT_HOST,
        help=f"interface to listen on (default {DEFAULT_HOST}); any other than loopback "
        "requires the access token that the printed URL carries",
    )
    parser.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help=f"port (default {DEFAULT_PORT}; the next free one when taken; 0: any free one)",
    )
    parser.add_argument(
        "--record-dir",
        metavar="DIR",
        help="the one folder the page may write recordings to and replay them from "
        "(default: no recording)",
    )
    parser.add_argument(
        "--map",
        metavar="DIR",
        help="show a capability map (lpik map) as voxels coloured by p, its weakest direction "
        "drawn",
    )
    parser.set_defaults(handler=run)


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    """Run the console until interrupted; 0 after a clean stop."""
    from lpik.cli.progress import compile_progress
    from lpik.cli.robots import check_scene_fits, robot_from_arguments
    from lpik.console.app import Console
    from lpik.console.gate import resolve_host
    from lpik.console.robot import console_robot
    from lpik.console.stepper import Settings

    resolve_host(args.host)  # a host that is not this machine's: one line, at once
    arm = robot_from_arguments(args)  # the planar arm's name with --planar
    check_scene_fits(arm, args.scene)
    robot = console_robot(arm, args.scene)
    settings = Settings(method=args.method, v_max=robot.v_max, w_max=robot.w_max)
    with compile_progress("lpik console"):  # a first run compiles the compiled step
        console = Console(
            robot,
            host=args.host,
            port=args.port,
            settings=settings,
            record_dir=args.record_dir,
            map_dir=args.map,
        )
    try:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, _interrupt)
            signal.signal(signal.SIGINT, signal.default_int_handler)  # even when started with &
        print(f"lpik console: {console.url}", flush=True)
        print("lpik console: Ctrl-C stops it", file=sys.stderr, flush=True)
        threading.Event().wait()
    except KeyboardInterrupt:
        pass
    finally:
        console.close()
    print("lpik console: stopped", file=sys.stderr, flush=True)
    return 0
