"""The console's gate holds: a refused websocket acts on nothing, and no frame is held in memory.

Every attack sends the messages an accepted page sends (as Chromium sends
them: first ``ViewerCameraMessage``, from which viser counts a client as
connected, then ``GuiUpdateMessage`` with each widget's uuid and
``TransformControlsUpdateMessage`` for the target) and the same messages sent
by an accepted client do act, so the refusals are not vacuous. Refused
clients try every control: pipelined behind the handshake in one write (so
the frames are in the server's buffer before it decides), then again and
again without ever answering the server's close (what acted before the gate:
viser read what was queued once its close timed out), and from a client that
goes on sending after the refusal. Traffic goes to 127.0.0.1 only; loops are bounded.
"""

from __future__ import annotations

import base64
import contextlib
import http.server
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cli_documents import LPIK

viser = pytest.importorskip("viser")
msgspec = pytest.importorskip("msgspec")
zstandard = pytest.importorskip("zstandard")

from websockets.exceptions import ConnectionClosed  # noqa: E402
from websockets.frames import Frame, Opcode  # noqa: E402
from websockets.sync.client import connect  # noqa: E402

from lpik.console import console_robot  # noqa: E402
from lpik.console.app import Console  # noqa: E402
from lpik.console.gate import CLOSE_TIMEOUT, MAX_MESSAGE  # noqa: E402

PROTOCOL = f"viser-v{viser.__version__}"
#: The widgets an attack drives, by their labels on the page.
LABELS = (
    "method",
    "v_max [m/s]",
    "w_max [rad/s]",
    "multiplier bound",
    "B",
    "acceleration limits",
    "qdd_max [rad/s²]",
    "Pause / resume",
    "Reset",
    "Record",
    "CSV",
    "Replay",
)
TOKEN = "s3cret-token"
#: Where an attack moves the target (the planar arm's home target is elsewhere).
MOVED = [0.2, 0.866, 0.0]


@pytest.fixture(scope="module")
def planar():
    return console_robot("planar")


def _client(port: int, tail: str = "/", **options):
    """A plain websocket client of the console (it keeps reading what the server sends)."""
    return connect(
        f"ws://127.0.0.1:{port}{tail}",
        subprotocols=[PROTOCOL],
        max_queue=None,
        close_timeout=1,
        **options,
    )


def _decode(frame: bytes) -> list[dict]:
    """The messages of one viser frame (zstd-compressed msgpack, then raw buffers)."""
    size, packed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16 : 16 + packed], max_output_size=size)
    return msgspec.msgpack.decode(inner)["messages"]


def _widgets(port: int, query: str = "") -> dict[str, str]:
    """Each widget's uuid by label, as an accepted page learns them (at most 10 s)."""
    found: dict[str, str] = {}
    with _client(port, f"/{query}") as ws:
        deadline = time.time() + 10
        while time.time() < deadline and not set(LABELS) <= set(found):
            try:
                messages = _decode(ws.recv(timeout=1))
            except TimeoutError:
                continue
            for m in messages:
                label = (
                    m.get("props", {}).get("label") if isinstance(m.get("props"), dict) else None
                )
                if label is not None and "uuid" in m:
                    found[label.removesuffix(" (no --record-dir)")] = m["uuid"]
    assert set(LABELS) <= set(found), found
    return found


def _messages(ids: dict[str, str], replay: str) -> list[bytes]:
    """Every control of the page, as Chromium sends it (msgpack, one message a frame)."""

    def gui(label: str, value: object) -> dict:
        return {"type": "GuiUpdateMessage", "uuid": ids[label], "updates": {"value": value}}

    gizmo = {"name": "/target", "owner": ""}
    sent = [
        {  # the first message of a page: viser counts a client as connected from it on
            "type": "ViewerCameraMessage",
            "wxyz": [-0.261, 0.965, 0.0, 0.0],
            "position": [1.5, -2.5, 6.0],
            "image_height": 800,
            "image_width": 1280,
            "fov": 1.309,
            "near": 0.01,
            "far": 1000,
            "look_at": [1.5, 1.0, 0.0],
            "up_direction": [0.0, 0.0, 1.0],
        },
        {"type": "TransformControlsDragStartMessage", **gizmo},
        {
            "type": "TransformControlsUpdateMessage",
            "wxyz": [1, 0, 0, 0],
            "position": MOVED,
            **gizmo,
        },
        {"type": "TransformControlsDragEndMessage", **gizmo},
        gui("method", "pinv"),
        gui("v_max [m/s]", 1.5),
        gui("w_max [rad/s]", 2.5),
        gui("multiplier bound", "none"),
        gui("B", 3.0),
        gui("acceleration limits", True),
        gui("qdd_max [rad/s²]", 5.0),
        gui("Record", True),  # starts a recording
        gui("Record", True),  # stops and saves it
        gui("CSV", replay),
        gui("Replay", True),
        gui("Reset", True),
        gui("Pause / resume", True),
    ]
    return [msgspec.msgpack.encode(m) for m in sent]


def _record(console: Console) -> str:
    """Record half a second (something to replay); the file's name."""
    console.loop.start_recording()
    time.sleep(0.5)
    return console.loop.stop_recording("saved.csv").name


def _state(console: Console, folder: Path) -> dict:
    snap = console.loop.snapshot()
    return {
        "target": console.loop.target().round(9).tolist(),
        "gizmo": np.round(console.view.gizmo.position, 9).tolist(),
        "settings": console.loop.settings(),
        "paused": snap.paused,
        "recording": snap.recording,
        "replaying": snap.replaying,
        "files": sorted(p.name for p in folder.iterdir()),
    }


def _changed(before: dict, after: dict) -> list[str]:
    return [k for k in before if before[k] != after[k]]


def _handshake(port: int, path: str, headers: dict[str, str]) -> bytes:
    key = base64.b64encode(os.urandom(16)).decode()
    lines = [
        f"GET {path} HTTP/1.1",
        f"Host: {headers.pop('Host', f'127.0.0.1:{port}')}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        f"Sec-WebSocket-Key: {key}",
        "Sec-WebSocket-Version: 13",
        f"Sec-WebSocket-Protocol: {PROTOCOL}",
        *(f"{k}: {v}" for k, v in headers.items()),
    ]
    return ("\r\n".join(lines) + "\r\n\r\n").encode()


def _frame(payload: bytes, opcode: Opcode = Opcode.BINARY) -> bytes:
    return Frame(opcode, payload).serialize(mask=True, extensions=[])


def _server_frames(data: bytes) -> list[tuple[int, bytes]]:
    """The (opcode, payload) of each whole frame the server sent (unmasked)."""
    frames = []
    while len(data) >= 2:
        length, at = data[1] & 0x7F, 2
        if length >= 126:
            width = 2 if length == 126 else 8
            length, at = int.from_bytes(data[2 : 2 + width], "big"), 2 + width
        if len(data) < at + length:
            break
        frames.append((data[0] & 0x0F, data[at : at + length]))
        data = data[at + length :]
    return frames


def _stubborn(port: int, path: str, headers: dict[str, str], frames: list[bytes]) -> tuple:
    """An attacker that never answers the server's close and never stops sending.

    The handshake and every frame go in one write (the frames are in the
    server's buffer before it decides), then every frame again each 0.25 s, for
    at most the gate's close timeout and a second. Returns the status line, the
    server's frames, and whether the server hung up.
    """
    burst = b"".join(frames)
    received, hung_up = b"", False
    with socket.create_connection(("127.0.0.1", port), timeout=0.25) as sock:
        sock.sendall(_handshake(port, path, dict(headers)) + burst)
        deadline = time.time() + CLOSE_TIMEOUT + 1.0
        while time.time() < deadline and not hung_up:
            try:
                chunk = sock.recv(65536)
                received += chunk
                hung_up = not chunk
                if chunk:
                    continue
            except TimeoutError:
                pass
            except OSError:
                hung_up = True
            try:
                sock.sendall(burst)
            except TimeoutError:
                pass
            except OSError:
                hung_up = True
    head, _, rest = received.partition(b"\r\n\r\n")
    return head.split(b"\r\n")[0], _server_frames(rest), hung_up


ATTACKS = {
    "foreign origin": (None, "/", {"Origin": "http://evil.example"}),
    "rebinding host": (None, "/", {"Host": "evil.example:80"}),
    "no token": (TOKEN, "/", {}),
    "wrong token": (TOKEN, "/?token=wrong", {}),
}


@pytest.mark.parametrize("attack", sorted(ATTACKS))
def test_a_refused_connection_acts_on_nothing(attack, planar, tmp_path) -> None:
    token, path, headers = ATTACKS[attack]
    with Console(planar, port=0, token=token, record_dir=tmp_path) as console:
        saved = _record(console)
        reached: list[int] = []
        console.server.on_client_connect(lambda client: reached.append(client.client_id))
        ids = _widgets(console.port, f"?token={token}" if token else "")
        frames = [_frame(m) for m in _messages(ids, saved)]
        time.sleep(0.2)  # the callbacks of the accepted page above
        reached.clear()
        before = _state(console, tmp_path)
        status, server_frames, hung_up = _stubborn(console.port, path, headers, frames)
        assert b" 101 " in status and hung_up  # the server dropped it, past its close timeout
        assert [(op, payload[:2]) for op, payload in server_frames] == [(Opcode.CLOSE, b"\x03\xf0")]
        with _client(console.port, path, additional_headers=headers) as ws:
            sent = 0
            for frame in _messages(ids, saved):  # and again, after the handshake
                try:
                    ws.send(frame)
                    sent += 1
                except ConnectionClosed:
                    break
            with pytest.raises(ConnectionClosed) as closed:
                ws.recv(timeout=5)
            assert closed.value.rcvd.code == 1008
        time.sleep(0.3)  # what would act has had the time to
        after = _state(console, tmp_path)
        assert _changed(before, after) == [], (before, after)
        assert reached == [] and console.gate.refused == 2


def test_an_accepted_client_sending_the_same_messages_drives_every_control(planar, tmp_path):
    with Console(planar, port=0, token=TOKEN, record_dir=tmp_path) as console:
        saved = _record(console)
        query = f"?token={TOKEN}"
        ids = _widgets(console.port, query)
        before = _state(console, tmp_path)
        messages = _messages(ids, saved)
        replay_at = 13  # CSV, Replay, Reset, Pause: checked apart, they undo the rest
        with _client(console.port, f"/{query}") as ws:
            for m in messages[:replay_at]:
                ws.send(m)
                time.sleep(0.05)
            deadline = time.time() + 10
            while time.time() < deadline and len(list(tmp_path.iterdir())) < 2:
                time.sleep(0.05)
            middle = _state(console, tmp_path)
            # the gizmo moved, and the loop's target with it (viser passes an event whose
            # target is the gizmo; reading .wxyz off the event raised in viser's pool)
            np.testing.assert_allclose(console.view.gizmo.position, MOVED, atol=1e-6)
            target = np.asarray(console.loop.target(), dtype=float)
            moved_to = target[:3, 3] if target.shape == (4, 4) else target[:3]
            np.testing.assert_allclose(moved_to[:2], MOVED[:2], atol=1e-6)
            s = middle["settings"]
            assert (s.method, s.v_max, s.w_max, s.qdd_max) == ("pinv", 1.5, 2.5, 5.0)
            assert len(middle["files"]) == 2  # the recording was started, stopped and saved
            for m in messages[replay_at : replay_at + 2]:
                ws.send(m)
            deadline = time.time() + 10
            while time.time() < deadline and "replaying" not in console.view.message.content:
                time.sleep(0.02)
            assert console.view.message.content.startswith(f"replaying {saved}")
            ws.send(messages[-2])  # Reset: running, not replaying (a replay ends paused)
            _wait(lambda: not (console.loop.snapshot().paused or console.loop.snapshot().replaying))
            ws.send(messages[-1])  # Pause
            _wait(lambda: console.loop.snapshot().paused)
        assert _changed(before, _state(console, tmp_path)) != []


def _wait(condition, seconds: float = 10.0) -> None:
    deadline = time.time() + seconds
    while not condition():
        assert time.time() < deadline, "timed out"
        time.sleep(0.02)


def _rss() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmRSS")


def _send_big_frame(port: int, path: str, headers: dict[str, str], size: int) -> None:
    """A handshake, then one binary frame of ``size`` bytes streamed in 1 MiB pieces."""
    header = bytes([0x82, 0x80 | 127]) + size.to_bytes(8, "big") + os.urandom(4)
    piece = bytes(1 << 20)
    with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
        try:
            sock.sendall(_handshake(port, path, dict(headers)) + header)
            for _ in range(size // len(piece)):
                sock.sendall(piece)
        except OSError:  # the server closed it: what the test wants
            pass


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="RSS read from /proc")
def test_big_frames_are_refused_before_they_are_read_and_memory_stays_flat(planar) -> None:
    big = 40 << 20
    assert big > MAX_MESSAGE
    with Console(planar, port=0, token=TOKEN) as console:
        time.sleep(0.5)
        start = _rss()
        for path in ("/", "/?token=wrong", f"/?token={TOKEN}") * 2:  # accepted ones too
            _send_big_frame(console.port, path, {}, big)
        time.sleep(0.5)
        grown = _rss() - start
        with _client(console.port, f"/?token={TOKEN}") as ws:
            assert ws.recv(timeout=5)  # the console still serves
            ws.send(bytes(MAX_MESSAGE + 1))
            with pytest.raises(ConnectionClosed) as closed:
                for _ in range(1000):  # what the server sent before it closed
                    ws.recv(timeout=5)
            assert closed.value.rcvd.code == 1009  # message too big
    assert grown < 16 << 20, f"RSS grew by {grown / 2**20:.1f} MiB after six 40 MiB frames"


def test_the_page_is_served_through_the_gate(planar) -> None:
    import urllib.request

    with Console(planar, port=0, token=TOKEN) as console:
        with urllib.request.urlopen(f"http://127.0.0.1:{console.port}/", timeout=10) as reply:
            assert reply.status == 200 and b"<html" in reply.read().lower()
        with pytest.raises(urllib.error.HTTPError) as missing:
            urllib.request.urlopen(f"http://127.0.0.1:{console.port}/../../etc/passwd", timeout=10)
        assert missing.value.code == 404


@pytest.mark.parametrize("host", ["999.1.1.1", "nosuch.invalid", "192.0.2.1"])
def test_a_bad_host_is_one_line_and_status_2_at_once(host) -> None:
    start = time.perf_counter()
    out = subprocess.run(
        [str(LPIK), "console", "--planar", "--host", host],
        capture_output=True,
        text=True,
        timeout=60,
    )
    elapsed = time.perf_counter() - start
    assert out.returncode == 2 and out.stdout == "", out
    assert len(out.stderr.strip().splitlines()) == 1 and "host" in out.stderr, out.stderr
    assert "Traceback" not in out.stderr
    assert elapsed < 10, elapsed  # interpreter start and imports; was 150 s, then a traceback


def test_a_taken_port_gives_the_next_free_one(planar) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        try:
            console = Console(planar, port=port)
        except ValueError:  # the one above is taken too: nothing to check here
            pytest.skip(f"port {port + 1} is taken")
        with console:
            assert console.port > port and console.url.endswith(f":{console.port}/")


def test_a_bad_host_in_python_is_a_value_error(planar) -> None:
    for host in ("999.1.1.1", "nosuch.invalid", "1:2:zz"):
        with pytest.raises(ValueError, match="host"):
            Console(planar, host=host, port=0)


def _browser_problem() -> str | None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
    from console_browser import browser_problem

    return browser_problem()


EVIL_PAGE = "<!doctype html><title>a page from elsewhere</title>"
#: What the page from elsewhere runs: every captured frame, sent as soon as the socket opens.
EVIL_SCRIPT = """async ({url, protocol, frames}) => await new Promise(resolve => {
    const ws = new WebSocket(url, [protocol]);
    let opened = false, sent = 0;
    ws.onopen = () => {
        opened = true;
        for (const f of frames) { ws.send(new Uint8Array(f)); sent++; }
    };
    ws.onclose = (e) => resolve({opened, sent, code: e.code});
    setTimeout(() => resolve({opened, sent, code: null}), 10000);
})"""


@contextlib.contextmanager
def _elsewhere():
    """Another web server on 127.0.0.1 serving :data:`EVIL_PAGE`; yields its URL."""

    class Page(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.end_headers()
            self.wfile.write(EVIL_PAGE.encode())

        def log_message(self, *args: object) -> None:
            pass

    with http.server.ThreadingHTTPServer(("127.0.0.1", 0), Page) as server:
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        try:
            yield f"http://127.0.0.1:{server.server_address[1]}/"
        finally:
            server.shutdown()
            thread.join(5)


@pytest.mark.skipif(_browser_problem() is not None, reason=f"no browser: {_browser_problem()}")
def test_in_chromium_a_page_from_elsewhere_replaying_a_real_session_acts_on_nothing(planar):
    from console_browser import chromium

    with Console(planar, port=0) as console, chromium() as browser:
        page = browser.new_page()
        sent: list[bytes] = []
        page.on("websocket", lambda ws: ws.on("framesent", lambda f: sent.append(f)))
        page.goto(console.url)
        page.wait_for_selector("#lpik-p", timeout=60_000)
        page.get_by_role("button", name="Pause / resume").click()
        page.get_by_label("method").first.click()
        page.get_by_role("option", name="pinv").click()
        _wait(lambda: console.loop.snapshot().paused and console.loop.settings().method == "pinv")
        page.close()  # the real session acted; now undo it, and replay it from elsewhere
        console.view.method.value = "lp2s"
        console.loop.change(method="lp2s")
        console.loop.pause(False)
        frames = [list(f if isinstance(f, bytes) else f.encode()) for f in sent]
        assert len(frames) >= 3  # the camera, the button, the dropdown
        evil = browser.new_page()
        # a page of another local server: Chromium lets no public page reach loopback at all
        with _elsewhere() as origin:
            evil.goto(origin)
        before = (console.loop.snapshot().paused, console.loop.settings())
        result = evil.evaluate(
            EVIL_SCRIPT,
            {"url": f"ws://127.0.0.1:{console.port}/", "protocol": PROTOCOL, "frames": frames},
        )
        time.sleep(0.3)
        assert result == {"opened": True, "sent": len(frames), "code": 1008}, result
        assert (console.loop.snapshot().paused, console.loop.settings()) == before
        assert not before[0] and before[1].method == "lp2s"
        assert console.gate.refused == 1 and console.gate.accepted == 1
