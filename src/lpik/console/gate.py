"""The console's one public port: a websocket gate in front of viser's private server.

Viser offers no public hook that sees a websocket's handshake or closes a
connection, and whatever a connection sends reaches the page's handlers (the
target gizmo, the widgets, recording and replay). So the console never puts
viser on the public interface: viser listens on a private loopback address
(:func:`private_address`, a random one of 127.0.0.0/8 where the system allows
it) and a port the system picks, and :class:`Gate` listens on the interface and
port the operator chose. For each websocket the gate checks the handshake
(:func:`lpik.console.access.check_handshake`: the token, or on loopback the
Host and Origin) before anything else: a refused connection is closed with
1008 at once and never reaches viser, so nothing it sent or sends acts; an
accepted one is joined to a fresh connection to viser, message for message.
Every message a browser sends is read with a size cap (:data:`MAX_MESSAGE`,
checked on the frame's header, before its payload is read). Plain HTTP
requests (the page itself, the same static client for every viser server) are
fetched from viser and passed back.

Processes of this machine can still reach viser's private port: the gate keeps
out the network and web pages (a page cannot find a random loopback address
and port), not local users.
"""

from __future__ import annotations

import asyncio
import errno
import http.client
import ipaddress
import logging
import re
import secrets
import socket
import threading
from typing import Any

from lpik.console.access import REFUSED, check_handshake

#: The largest message a browser may send [bytes]: a widget's value or the camera is far smaller.
MAX_MESSAGE = 1 << 20
#: Seconds a name may take to resolve (a host that does not answer is a bad ``--host``).
RESOLVE_TIMEOUT = 1.0
#: Seconds to wait for a closing handshake, and to open the connection to viser.
CLOSE_TIMEOUT, OPEN_TIMEOUT = 2.0, 10.0
#: Ports tried above a port that is taken (0 asks the system for any free one).
PORT_TRIES = 100
#: Close codes that are never sent (RFC 6455, 7.4.1), and what is sent instead.
_UNSENDABLE = {1005: 1000, 1006: 1011, 1015: 1011}
#: The headers of a static file passed back to the browser.
_FILE_HEADERS = ("Content-Type", "Content-Length", "Content-Encoding")

_log = logging.getLogger(__name__)
_log.addHandler(logging.NullHandler())  # a bad request is no traceback on the terminal


def resolve_host(host: str, timeout: float = RESOLVE_TIMEOUT) -> list[str]:
    """The numeric addresses of ``host`` (a name or an address) that this machine can listen on.

    ``""`` (every interface) is kept as it is. Each address is tried with a
    socket bound to a free port; those that cannot be bound are left out.

    Raises:
        ValueError: For an address that is not one, a name that does not
            resolve within ``timeout`` seconds, or one that is not this machine's.
    """
    name = host.strip()
    if name == "":
        return [""]
    bare = name[1:-1] if name.startswith("[") and name.endswith("]") else name
    try:
        addresses = [str(ipaddress.ip_address(bare))]
    except ValueError:
        if re.fullmatch(r"[0-9.]+", bare) or ":" in bare:
            raise ValueError(f"host: {host!r} is not an IP address") from None
        addresses = _lookup(host, bare, timeout)
    usable, why = [], ""
    for address in addresses:
        family = socket.AF_INET6 if ":" in address else socket.AF_INET
        try:
            with socket.socket(family, socket.SOCK_STREAM) as probe:
                probe.bind((address, 0))
        except OSError as exc:
            why = why or exc.strerror or str(exc)
            continue
        usable.append(address)
    if not usable:
        raise ValueError(f"host: cannot listen on {host!r}: {why}")
    return usable


def _lookup(host: str, name: str, timeout: float) -> list[str]:
    """The addresses of a host name, asked of the system's resolver for at most ``timeout`` s."""
    found: list[Any] = []

    def lookup() -> None:
        try:
            found.append(socket.getaddrinfo(name, None, type=socket.SOCK_STREAM))
        except (OSError, UnicodeError) as exc:
            found.append(exc)

    thread = threading.Thread(target=lookup, name="lpik-console-resolve", daemon=True)
    thread.start()
    thread.join(timeout)
    if not found:
        raise ValueError(f"host: {host!r} did not resolve within {timeout:g} s")
    if isinstance(found[0], BaseException):
        reason = getattr(found[0], "strerror", None) or str(found[0])
        raise ValueError(f"host: cannot resolve {host!r}: {reason}")
    addresses = list(dict.fromkeys(str(info[4][0]) for info in found[0]))
    if not addresses:
        raise ValueError(f"host: {host!r} has no address")
    return addresses


def private_address() -> str:
    """A loopback address for viser: a random one of 127.0.0.0/8, or 127.0.0.1 where none binds."""
    a, b, c = (1 + secrets.randbelow(254) for _ in range(3))
    candidate = f"127.{a}.{b}.{c}"
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
            probe.bind((candidate, 0))
    except OSError:
        return "127.0.0.1"
    return candidate


def _select_subprotocol(connection: Any, offered: Any) -> Any:
    """Viser's choice: the first ``viser-v...`` the browser offers (viser checks the version)."""
    return next((p for p in offered if p.startswith("viser-v")), None)


class Gate:
    """The public side of the console (:meth:`start`, :meth:`stop`).

    Args:
        upstream: Viser's private ``(address, port)``.
        token: The access token, or None on loopback (then Host and Origin are checked).
        host: The interface to listen on (a name or address).
        port: The port; taken, the next free one above it; 0: any free one.
    """

    def __init__(self, upstream: tuple[str, int], token: str | None, host: str, port: int) -> None:
        self.upstream, self.token, self.host = upstream, token, host
        self._addresses = resolve_host(host)
        self._port = port
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        #: Websocket connections the gate refused, and accepted, since it started.
        self.refused = self.accepted = 0

    @property
    def port(self) -> int:
        """The public port the gate listens on."""
        return self._port

    def start(self) -> None:
        """Listen; returns once the port is bound.

        Raises:
            ValueError: When the interface cannot be listened on.
        """
        self._thread = threading.Thread(target=self._run, name="lpik-console-gate", daemon=True)
        self._thread.start()
        self._ready.wait()
        if self._error is not None:
            self._thread.join()
            why = getattr(self._error, "strerror", None) or str(self._error)
            raise ValueError(f"host: cannot listen on {self.host!r}: {why}") from None

    def stop(self, timeout: float = 5.0) -> None:
        """Close the port and every connection through it, and wait for the thread."""
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None:
            try:
                loop.call_soon_threadsafe(stop.set)
            except RuntimeError:  # the loop is closed already
                pass
        if self._thread is not None:
            self._thread.join(timeout)

    # ---- the thread ---------------------------------------------------------------------------
    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._serve())
        except BaseException as exc:  # a failed bind: start() raises it
            self._error = exc
        finally:
            self._ready.set()
            loop.run_until_complete(loop.shutdown_default_executor())
            loop.close()

    async def _listen(self) -> Any:
        from websockets.asyncio.server import serve

        port = self._port
        # port 0 on several addresses would give each a port of its own: the first one only
        hosts = self._addresses if len(self._addresses) > 1 and port else self._addresses[0]
        for attempt in range(PORT_TRIES):
            try:
                return await serve(
                    self._handle,
                    host=hosts,
                    port=port,
                    process_request=self._process_request,
                    select_subprotocol=_select_subprotocol,
                    max_size=MAX_MESSAGE,
                    compression=None,
                    close_timeout=CLOSE_TIMEOUT,
                    logger=_log,
                    server_header=None,
                )
            except OSError as exc:
                if exc.errno != errno.EADDRINUSE or port == 0 or attempt == PORT_TRIES - 1:
                    raise OSError(exc.errno, exc.strerror or str(exc)) from None
                port += 1
        raise AssertionError("unreachable")

    async def _serve(self) -> None:
        server = await self._listen()
        self._port = int(server.sockets[0].getsockname()[1])
        self._stop = asyncio.Event()
        self._ready.set()
        try:
            await self._stop.wait()
        finally:
            server.close()
            await server.wait_closed()

    # ---- one request ----------------------------------------------------------------------------
    async def _process_request(self, connection: Any, request: Any) -> Any:
        """A plain HTTP request: the static page, fetched from viser; a websocket goes on."""
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return None
        return await asyncio.to_thread(self._fetch, request.path, request.headers)

    def _fetch(self, path: str, headers: Any) -> Any:
        from websockets.datastructures import Headers
        from websockets.http11 import Response

        link = http.client.HTTPConnection(*self.upstream, timeout=OPEN_TIMEOUT)
        try:
            link.request(
                "GET", path, headers={"Accept-Encoding": headers.get("Accept-Encoding", "")}
            )
            reply = link.getresponse()
            body = reply.read()
        except (OSError, http.client.HTTPException):
            return Response(502, "Bad Gateway", Headers(), b"")
        finally:
            link.close()
        kept = Headers([(k, v) for k in _FILE_HEADERS if (v := reply.getheader(k)) is not None])
        return Response(reply.status, reply.reason, kept, body)

    async def _handle(self, client: Any) -> None:
        """A websocket: refused and closed, or joined to a connection of its own to viser."""
        from websockets.asyncio.client import connect

        try:
            reason = check_handshake(client.request.path, client.request.headers, self.token)
        except Exception as exc:  # a request the rules cannot read is refused too
            reason = f"unreadable handshake: {type(exc).__name__}"
        if reason is not None:
            self.refused += 1
            await client.close(REFUSED, reason[:120])
            return
        self.accepted += 1
        address, port = self.upstream
        try:
            upstream = await connect(
                f"ws://{address}:{port}/",
                subprotocols=None if client.subprotocol is None else [client.subprotocol],
                max_size=None,  # viser's messages (meshes, the scene) are the server's own
                compression=None,
                open_timeout=OPEN_TIMEOUT,
                close_timeout=CLOSE_TIMEOUT,
                logger=_log,
            )
        except Exception:  # viser stopped or refused: say so, never a traceback
            await client.close(1011, "the console's server is not available")
            return
        try:
            await _join(client, upstream)
        finally:
            await upstream.close()


async def _forward(source: Any, sink: Any) -> None:
    from websockets.exceptions import ConnectionClosed

    try:
        async for message in source:
            await sink.send(message)
    except ConnectionClosed:
        pass


async def _join(client: Any, upstream: Any) -> None:
    """Pass messages both ways until one side closes; then close the other with its code."""
    up = asyncio.create_task(_forward(client, upstream))
    down = asyncio.create_task(_forward(upstream, client))
    try:
        done, _ = await asyncio.wait((up, down), return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in (up, down):
            task.cancel()
        await asyncio.gather(up, down, return_exceptions=True)
    closed, other = (client, upstream) if up in done else (upstream, client)
    code = closed.close_code or 1000
    reason = closed.close_reason or ""
    await other.close(_UNSENDABLE.get(code, code), reason)
    await closed.close()
