"""Who may connect to the console: the access token and the checks of a websocket handshake.

The console moves a robot, so by default it listens on the loopback interface
only. Then a connection's ``Host`` must be a loopback name and its ``Origin``
(when a browser sends one) the console's own page: a web page from elsewhere
cannot drive the robot through the operator's browser (cross-site websocket
hijacking, DNS rebinding). Listening on any other interface (``--host``)
needs an access token: the printed URL carries it, and every websocket
connection, which is where the robot's state and every command travel, must
present it (:func:`check_handshake`); a connection without it is closed before
it receives or sends anything. The page itself (viser's static client, the
same for every viser server) is served without the token: it holds no state.
"""

from __future__ import annotations

import hmac
import ipaddress
import secrets
from collections.abc import Mapping
from urllib.parse import parse_qs, quote, urlsplit

#: Host names that mean this machine only.
LOCAL_NAMES = ("localhost",)
#: The websocket close code of a refused connection (policy violation, RFC 6455).
REFUSED = 1008


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or address, IPv6 with or without brackets) is this machine only."""
    name = host.strip("[]").lower()
    if name in LOCAL_NAMES:
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def new_token() -> str:
    """A fresh access token: 32 random URL-safe characters (192 bits)."""
    return secrets.token_urlsafe(24)


def _hostname(host_header: str) -> str:
    return urlsplit(f"//{host_header}").hostname or ""


def check_handshake(path: str, headers: Mapping[str, str], token: str | None) -> str | None:
    """Why a websocket handshake is refused, or None when it may connect.

    Args:
        path: The request's path with its query (``/?token=...``).
        headers: The request's headers (``Host``, ``Origin``); one with ``get_all``
            (websockets' ``Headers``) is refused when it repeats either.
        token: The access token, or None when the console listens on loopback only.
    """
    get_all = getattr(headers, "get_all", None)
    for name in ("Host", "Origin"):
        if get_all is not None and len(get_all(name)) > 1:
            return f"more than one {name} header"
    host = headers.get("Host") or ""
    if token is not None:
        given = parse_qs(urlsplit(path).query).get("token", [""])[0]
        if not hmac.compare_digest(given.encode(), token.encode()):
            return "missing or wrong access token"
        return None
    if not is_loopback(_hostname(host)):
        return f"host {host!r} is not this machine's loopback name"
    origin = headers.get("Origin")
    if origin is not None and urlsplit(origin).netloc.lower() != host.lower():
        return f"origin {origin!r} is not the console's page"
    return None


def page_url(host: str, port: int, token: str | None) -> str:
    """The URL the operator opens (with the token, when there is one).

    Viser's page connects its websocket to the address in its ``websocket``
    parameter; the token rides in that address's query.
    """
    name = f"[{host}]" if ":" in host and not host.startswith("[") else host
    base = f"http://{name}:{port}/"
    if token is None:
        return base
    return f"{base}?websocket=ws://{name}:{port}/?token%3D{quote(token, safe='')}"
