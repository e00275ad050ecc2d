"""The operator console's logic, without a browser: loop, settings, recording, access, drawing."""

from __future__ import annotations

import csv
import signal
import subprocess
import threading
import time

import numpy as np
import pytest

from cli_documents import LPIK
from lpik.console import ControlLoop, Settings, console_robot
from lpik.console import geometry as geo
from lpik.console.access import check_handshake, is_loopback, page_url
from lpik.console.record import read_replay, recording_path
from lpik.control.controller import Lp2Controller
from lpik.labels import Binding
from lpik.paper.scenarios import get_scenario


@pytest.fixture(scope="module")
def planar():
    return console_robot("planar")


@pytest.fixture(scope="module")
def panda():
    return console_robot("panda")


def test_each_step_is_the_controllers_step(planar) -> None:
    loop = ControlLoop(planar)
    loop.set_target([0.2, 0.866, 0.0])
    reference = Lp2Controller(planar.model, dt=planar.dt, v_max=planar.v_max, w_max=planar.w_max)
    q, q_prev = planar.q0.copy(), None
    saturated = 0  # steps with joint 1 on its end-stop
    for _ in range(400):
        snap = loop.tick()
        expected = reference.step(q, np.array([0.2, 0.866, 0.0]), q_prev)
        q_prev, q = q, expected.q
        assert snap.p == pytest.approx(expected.p, abs=1e-12)
        assert snap.binding == expected.binding
        np.testing.assert_allclose(snap.q, expected.q, atol=1e-12)
        saturated += snap.q[0] == planar.model.q_max[0]
    # joint 1 meets its end-stop on the way; saturated there, the others carry the tool on
    assert saturated > 100 and snap.p == 1.0 and snap.binding is None


@pytest.mark.parametrize("name", ["planar", "panda"])
def test_a_target_far_outside_the_workspace_gives_p_to_0_and_a_label(name, planar, panda) -> None:
    robot = planar if name == "planar" else panda
    loop = ControlLoop(robot)
    loop.set_target([3e3, 1e3, 0.0] if name == "planar" else [1e3, -2e3, 5e2])
    for _ in range(1000 if name == "planar" else 3000):
        snap = loop.tick()
    assert snap.error is None and snap.status != "error"
    assert snap.p < 0.05 and isinstance(snap.binding, Binding)


def test_bad_targets_and_settings_are_refused_and_nothing_changes(planar) -> None:
    loop = ControlLoop(planar)
    before = loop.snapshot().target.copy()
    for bad in ([np.nan, 0, 0], [1, 2], np.eye(3), np.diag([2.0, 1, 1, 1])):
        with pytest.raises(ValueError, match="target"):
            loop.set_target(bad)
    np.testing.assert_array_equal(loop.snapshot().target, before)
    for values, word in (
        ({"method": "nope"}, "method"),
        ({"v_max": 0.0}, "v_max"),
        ({"method": "pinv", "lambda_bound": 1.0}, "lambda_bound"),
        ({"qdd_max": float("inf")}, "qdd_max"),
        ({"lambda_bound": "x"}, "auto"),
    ):
        with pytest.raises(ValueError, match=word):
            loop.change(**values)
    assert loop.settings() == Settings(v_max=planar.v_max, w_max=planar.w_max)


def test_every_method_and_option_steps(planar) -> None:
    loop = ControlLoop(planar)
    loop.set_target([0.2, 0.866, 0.0])
    for method in ("lp2s", "lp1", "l1", "pinv", "weighted", "robust"):
        loop.change(method=method, lambda_bound="auto", qdd_max=5.0)  # "auto": LP2's only
        snap = loop.tick()
        assert snap.error is None and 0 <= snap.p <= 1, method
    loop.change(method="lp2", lambda_bound=2.0, qdd_max=None)
    assert loop.tick().settings.lambda_bound == 2.0


def test_a_step_that_raises_pauses_the_loop_and_says_why(planar, monkeypatch) -> None:
    loop = ControlLoop(planar)

    def broken(q, target, q_prev):
        raise RuntimeError("boom")

    monkeypatch.setattr(loop, "_stepper", broken)
    snap = loop.tick()
    assert snap.paused and snap.status == "error" and "boom" in snap.error
    assert "stopped" in geo.binding_words(snap.binding, snap.status)


def test_the_thread_keeps_its_period_pauses_and_resets(planar) -> None:
    loop = ControlLoop(planar)
    loop.start()
    loop.start()  # a second start does not start a second controller
    time.sleep(0.6)
    loop.pause()
    paused_at = loop.snapshot().step
    assert 15 <= paused_at <= 80  # 0.01 s period: about 60 steps (fewer on a loaded machine)
    time.sleep(0.1)
    assert loop.snapshot().step == paused_at and loop.snapshot().paused
    loop.reset()
    time.sleep(0.1)
    assert loop.snapshot().step < paused_at
    names = [t.name for t in threading.enumerate()].count("lpik-console-loop")
    loop.stop()
    assert names == 1 and not loop.running


def test_a_recording_is_an_lpik_simulate_csv_and_replays(planar, tmp_path) -> None:
    loop = ControlLoop(planar, record_dir=tmp_path)
    loop.set_target([0.2, 0.866, 0.0])
    loop.start_recording()
    for _ in range(40):
        loop.tick()
    assert loop.snapshot().recording == 40
    path = loop.stop_recording("run.csv")
    with path.open() as handle:
        rows = list(csv.reader(handle))
    head = ["t", "q1", "q2", "q3", "q4", "x", "y", "p", "lam1", "lam2", "status", "binding"]
    assert rows[0][:12] == head and len(rows) == 41
    setup = get_scenario("pull-in").setup()
    reference = setup.run("lp2", steps=40, second_order=True)  # as the console's controller
    replay = read_replay(path, 4)
    np.testing.assert_allclose(replay.q, reference.q, atol=1e-9)
    np.testing.assert_allclose(replay.p, reference.p, atol=1e-9)
    loop.replay("run.csv")
    for k in range(40):
        snap = loop.tick()
        np.testing.assert_allclose(snap.q, replay.q[k])
    assert snap.paused and not snap.replaying


def test_recordings_stay_in_the_record_folder(planar, tmp_path) -> None:
    for name in ("../x.csv", "/etc/x.csv", "a/b.csv", "x.txt", ".hidden.csv", "..csv"):
        with pytest.raises(ValueError, match="record"):
            recording_path(tmp_path, name)
    with pytest.raises(ValueError, match="--record-dir"):
        ControlLoop(planar).start_recording()
    (tmp_path / "other.csv").write_text("t,q1,q2,p\n0,1,2,1\n")
    loop = ControlLoop(planar, record_dir=tmp_path)
    with pytest.raises(ValueError, match="4 joints"):
        loop.replay("other.csv")
    with pytest.raises(ValueError, match="not recording"):
        loop.stop_recording()


def test_a_planar_scene_reports_distances_and_lights_the_pair(tmp_path) -> None:
    robot = console_robot("planar", get_scenario("obstacle").setup().scene)
    loop = ControlLoop(robot)
    assert loop.snapshot().closest is not None
    pair = Binding("collision link 2 - obstacle", "collision", 0, "link 2 - obstacle", "upper")
    links, obstacles = geo.highlighted(pair, robot.capsules)
    assert obstacles == {"obstacle"} and [robot.capsules[k].link for k in links] == ["link 2"]
    assert [s.kind for s in geo.obstacle_shapes(robot.scene)] == ["cylinder"]
    with pytest.raises(ValueError, match="3-D scene"):
        console_robot("panda", robot.scene)


def test_drawing_values() -> None:
    from lpik.robots.rotations import transform

    R = transform([0, 0, 0], [0.3, -1.1, 2.5])[:3, :3]
    np.testing.assert_allclose(geo.rotation(geo.wxyz(R)), R, atol=1e-12)
    seg = geo.segment([0, 0, 0], [0, 0, 2])
    assert seg.center == (0, 0, 1) and seg.length == 2
    np.testing.assert_allclose(
        geo.rotation(geo.segment([0, 0, 0], [1, 0, 0]).wxyz)[:, 2], [1, 0, 0], atol=1e-12
    )


def test_access_rules() -> None:
    assert is_loopback("127.0.0.1") and is_loopback("localhost") and is_loopback("[::1]")
    assert not is_loopback("0.0.0.0") and not is_loopback("192.168.1.5")
    local = {"Host": "127.0.0.1:8080", "Origin": "http://127.0.0.1:8080"}
    assert check_handshake("/", local, None) is None
    assert check_handshake("/", {"Host": "127.0.0.1:8080"}, None) is None
    assert "origin" in check_handshake("/", {**local, "Origin": "http://evil.example"}, None)
    assert "host" in check_handshake("/", {"Host": "evil.example:8080"}, None)  # rebinding
    assert "token" in check_handshake("/", local, "s3cret")
    assert "token" in check_handshake("/?token=wrong", local, "s3cret")
    assert check_handshake("/?token=s3cret", {"Host": "10.0.0.2:9"}, "s3cret") is None
    url = page_url("10.0.0.2", 9000, "s3cret")
    assert url == "http://10.0.0.2:9000/?websocket=ws://10.0.0.2:9000/?token%3Ds3cret"


def test_connections_without_the_token_are_refused_and_tabs_do_not_touch_the_loop(planar) -> None:
    import viser
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from lpik.console.app import Console

    protocol = [f"viser-v{viser.__version__}"]
    with Console(planar, port=0, token="s3cret") as console:
        base = f"ws://127.0.0.1:{console.port}/"
        with connect(base, subprotocols=protocol) as ws:
            with pytest.raises(ConnectionClosed) as refused:
                ws.recv(timeout=5)
        assert refused.value.rcvd.code == 1008
        for _ in range(3):  # tabs come and go: the one controller runs on
            with connect(base + "?token=s3cret", subprotocols=protocol) as ws:
                assert ws.recv(timeout=5)
        before = console.loop.snapshot().step
        time.sleep(0.3)
        assert console.loop.snapshot().step > before
        assert [t.name for t in threading.enumerate()].count("lpik-console-loop") == 1
    assert not console.loop.running


def test_the_command_line_refuses_bad_input_in_one_line() -> None:
    for args, word in (
        (["--robot", "nope"], "unknown robot"),
        (["--planar", "--port", "-3"], "port"),
        (["--planar", "--record-dir", "/no/such/dir"], "record-dir"),
    ):
        out = subprocess.run(
            [str(LPIK), "console", *args], capture_output=True, text=True, timeout=60
        )
        assert out.returncode == 2 and out.stdout == "", args
        assert len(out.stderr.strip().splitlines()) == 1 and word in out.stderr, out.stderr


def test_ctrl_c_stops_the_console_cleanly() -> None:
    proc = subprocess.Popen(
        [str(LPIK), "console", "--planar", "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = proc.stdout.readline()
        assert line.startswith("lpik console: http://127.0.0.1:")
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 0
    finally:
        proc.kill()
    err = proc.stderr.read()
    assert "Traceback" not in err and "stopped" in err


def test_pause_holds_a_replay_and_resume_goes_on(planar, tmp_path) -> None:
    loop = ControlLoop(planar, record_dir=tmp_path)
    loop.set_target([0.2, 0.866, 0.0])
    loop.start_recording()
    for _ in range(10):
        loop.tick()
    loop.stop_recording("r.csv")
    loop.replay("r.csv")
    loop.tick()
    loop.pause()
    held = loop.tick()
    assert held.replaying and held.paused and loop.tick().step == held.step
    loop.pause(False)
    assert loop.tick().step == held.step + 1


def test_a_3d_scene_is_avoided_and_recorded_with_its_distances(tmp_path) -> None:
    from importlib.resources import files

    scene = files("lpik") / "data" / "scenes" / "panda-shelf.json"
    loop = ControlLoop(console_robot("panda", str(scene)), record_dir=tmp_path)
    target = loop.target()
    target[:3, 3] = [0.62, 0.0, 0.52]
    loop.set_target(target)
    loop.start_recording()
    for _ in range(5):
        snap = loop.tick()
    assert snap.error is None and snap.closest is not None
    header = loop.stop_recording("shelf.csv").read_text().splitlines()[0].split(",")
    assert header[-2:] == ["min_distance", "closest"]
    assert "box" in [s.kind for s in geo.obstacle_shapes(loop.robot.scene)]


def test_a_3d_arm_runs_at_1_khz(panda) -> None:
    loop = ControlLoop(panda)
    assert panda.dt == 0.001
    loop.start()
    time.sleep(1.0)
    loop.stop()
    assert loop.snapshot().step > 300  # 1,000 on an idle machine; CI machines are shared
