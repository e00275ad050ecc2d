"""The console as one object: robot, control loop, viser server, page and access gate.

:class:`Console` starts the control loop thread, a viser server on the given
interface and port, the page (:class:`~lpik.console.view.ConsoleView`) and the
access gate (:mod:`lpik.console.access`); :meth:`Console.close` stops them in
the reverse order. ``lpik console`` (:mod:`lpik.cli.console`) is a thin shell
around it.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from typing import Any

from lpik.console.access import REFUSED, check_handshake, is_loopback, new_token, page_url
from lpik.console.loop import ControlLoop
from lpik.console.robot import ConsoleRobot
from lpik.console.stepper import Settings

#: The loopback address the console listens on by default.
DEFAULT_HOST = "127.0.0.1"
#: The default port (viser's: the next free one above it when taken).
DEFAULT_PORT = 8080


def viser_module() -> Any:
    """The ``viser`` module, or a ValueError saying how to install it."""
    try:
        import viser
    except ImportError:
        raise ValueError("console: the console needs viser: pip install 'lpik[console]'") from None
    return viser


def install_gate(server: Any, token: str | None) -> None:
    """Refuse every websocket connection whose handshake :func:`check_handshake` refuses.

    The check runs when viser accepts a connection, before it sends or reads any
    message. Viser offers no public hook that sees the handshake, so this reads
    its websocket server's table of live connections; when that table is not
    where it is expected (another viser version), the console refuses to start
    rather than run without the gate. The gate is in place before the URL (and
    its token) is printed.

    Raises:
        RuntimeError: When this viser version cannot be gated.
    """
    ws = getattr(server, "_websock_server", None)
    live = getattr(ws, "_live_connections", None)
    if ws is None or not isinstance(live, dict) or not hasattr(ws, "on_client_connect"):
        raise RuntimeError("console: this viser version offers no way to check connections")

    async def gate(client: Any) -> None:
        connection = live.get(client.client_id)
        request = getattr(connection, "request", None)
        reason = (
            "no handshake"
            if request is None
            else check_handshake(request.path, request.headers, token)
        )
        if reason is not None and connection is not None:
            await connection.close(REFUSED, reason[:120])

    ws.on_client_connect(gate)


class Console:
    """A running console (use as a context manager, or call :meth:`close`).

    Args:
        robot: What to drive.
        host: The interface to listen on; anything but loopback needs a token.
        port: The port (0: any free one).
        settings: The first settings.
        record_dir: The one folder recordings go to and are replayed from.
        token: The access token; default a fresh one when ``host`` is not loopback,
            none on loopback.
        quiet: Keep viser's own messages off the terminal.

    Raises:
        ValueError: For settings the robot cannot take, or without viser.
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
    ) -> None:
        from lpik.console.view import ConsoleView

        viser = viser_module()
        if not (isinstance(port, int) and 0 <= port <= 65535):
            raise ValueError(f"port: must be a whole number in [0, 65535], got {port!r}")
        if record_dir is not None and not Path(record_dir).is_dir():
            raise ValueError(f"record-dir: {str(record_dir)!r} is not a directory")
        self.token = token if token is not None or is_loopback(host) else new_token()
        self.host = host
        self.loop = ControlLoop(robot, settings, record_dir)
        sink = io.StringIO()
        with contextlib.redirect_stdout(sink) if quiet else contextlib.nullcontext():
            self.server = viser.ViserServer(host=host, port=port, verbose=not quiet)
        try:
            install_gate(self.server, self.token)
            self.view = ConsoleView(self.server, self.loop)
        except Exception:
            self.server.stop()
            raise
        self.loop.start()
        self.view.start()

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """The URL to open (it carries the token when there is one)."""
        import socket

        host = self.host
        if host in ("0.0.0.0", "::", ""):  # every interface: name this machine
            host = socket.gethostname()
        return page_url(host, self.port, self.token)

    def close(self) -> None:
        """Stop the page's refresh, the server and the control loop."""
        self.view.stop()
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()
        self.loop.stop()

    def __enter__(self) -> Console:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
