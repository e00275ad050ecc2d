"""The console as one object: robot, control loop, viser server, page and access gate.

:class:`Console` starts the control loop thread, a viser server on a private
loopback address, the page (:class:`~lpik.console.view.ConsoleView`) and, on the
given interface and port, the gate (:class:`~lpik.console.gate.Gate`) that lets
through only the websockets the access rules (:mod:`lpik.console.access`)
accept; :meth:`Console.close` stops them in the reverse order. ``lpik console``
(:mod:`lpik.cli.console`) is a thin shell around it.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from typing import Any

from lpik.console.access import is_loopback, new_token, page_url
from lpik.console.gate import Gate, private_address, resolve_host
from lpik.console.loop import ControlLoop
from lpik.console.robot import ConsoleRobot
from lpik.console.stepper import Settings

#: The loopback address the console listens on by default.
DEFAULT_HOST = "127.0.0.1"
#: The default port (the next free one above it when taken).
DEFAULT_PORT = 8080


def viser_module() -> Any:
    """The ``viser`` module, or a ValueError saying how to install it."""
    try:
        import viser
    except ImportError:
        raise ValueError("console: the console needs viser: pip install 'lpik[console]'") from None
    return viser


def _read_map(map_dir: str | Path) -> Any:
    """The map's layer, read before anything starts (a bad ``--map`` fails at once)."""
    from lpik.console.map_layer import map_voxels

    return map_voxels(map_dir)


class Console:
    """A running console (use as a context manager, or call :meth:`close`).

    Args:
        robot: What to drive.
        host: The interface to listen on; anything but loopback needs a token.
        port: The port (0: any free one).
        settings: The first settings.
        record_dir: The one folder recordings go to and are replayed from.
        map_dir: A capability map (``lpik map``) to show as voxels
            (:mod:`lpik.console.map_layer`).
        token: The access token; default a fresh one when ``host`` is not loopback,
            none on loopback.
        quiet: Keep viser's own messages off the terminal.

    Raises:
        ValueError: For settings the robot cannot take, a host that cannot be
            listened on, or without viser.
    """

    def __init__(
        self,
        robot: ConsoleRobot,
        *,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        settings: Settings | None = None,
        record_dir: str | Path | None = None,
        token: str | None = None,
        quiet: bool = True,
        map_dir: str | Path | None = None,
    ) -> None:
        from lpik.console.view import ConsoleView

        viser = viser_module()
        if not (isinstance(port, int) and 0 <= port <= 65535):
            raise ValueError(f"port: must be a whole number in [0, 65535], got {port!r}")
        if record_dir is not None and not Path(record_dir).is_dir():
            raise ValueError(f"record-dir: {str(record_dir)!r} is not a directory")
        map_layer = None if map_dir is None else _read_map(map_dir)
        if not isinstance(host, str):
            raise ValueError(f"host: must be a name or an address, got {host!r}")
        resolve_host(host)  # a bad host fails here, before anything starts
        self.token = token if token is not None or is_loopback(host) else new_token()
        self.host = host
        self.loop = ControlLoop(robot, settings, record_dir)
        private = private_address()
        with contextlib.redirect_stdout(io.StringIO()) if quiet else contextlib.nullcontext():
            self.server = viser.ViserServer(host=private, port=0, verbose=not quiet)
        try:
            self.view = ConsoleView(self.server, self.loop)
            if map_layer is not None:
                from lpik.console.map_layer import add_map_layer

                add_map_layer(self.server.scene, map_layer)
            self.gate = Gate((private, int(self.server.get_port())), self.token, host, port)
            self.gate.start()
        except Exception:
            with contextlib.redirect_stdout(io.StringIO()):
                self.server.stop()
            raise
        self.loop.start()
        self.view.start()

    @property
    def port(self) -> int:
        """The public port (the gate's) the console listens on."""
        return self.gate.port

    @property
    def url(self) -> str:
        """The URL to open (it carries the token when there is one)."""
        import socket

        host = self.host
        if host in ("0.0.0.0", "::", ""):  # every interface: name this machine
            host = socket.gethostname()
        return page_url(host, self.port, self.token)

    def close(self) -> None:
        """Stop the gate, the page's refresh, the server and the control loop."""
        self.gate.stop()
        self.view.stop()
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()
        self.loop.stop()

    def __enter__(self) -> Console:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
