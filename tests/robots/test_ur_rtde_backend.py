"""URRTDEBackend: an unreachable robot fails fast with a useful message (real ur_rtde); what the backend sends
to the controller, and when, checked against stand-ins that follow ur_rtde's real signatures."""

from __future__ import annotations

import inspect
import math
import re
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dpiil_rl.robots import ur_rtde_backend
from dpiil_rl.robots.interface import RobotUnavailable
from dpiil_rl.robots.ur_rtde_backend import (
    URRTDEBackend,
    probe_rtde,
    rotvec_to_quaternion,
)
from tests.mocks.fake_ur_rtde import (
    FakeController,
    FakeRTDEControlInterface,
    FakeRTDEReceiveInterface,
    fake_modules,
)


def assert_helpful(message: str, host: str) -> None:
    for part in (host, "powered on", "remote control", "network", "robot.host="):
        assert part in message, f"{part!r} missing from: {message}"


# ------------------------------------------------------------------------------------------ unreachable robot
def test_unreachable_robot_fails_fast_with_what_to_check() -> None:
    robot = URRTDEBackend("127.0.0.1", connect_timeout=1.0)
    start = time.monotonic()
    with pytest.raises(RobotUnavailable) as info:
        robot.connect()
    assert time.monotonic() - start < 3.0
    assert_helpful(str(info.value), "127.0.0.1")
    assert not robot.is_connected


def test_real_ur_rtde_errors_become_robot_unavailable(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the probe, the real ur_rtde refuses 127.0.0.1 at once; the backend explains it."""
    monkeypatch.setattr(ur_rtde_backend, "probe_rtde", lambda *args, **kwargs: None)
    robot = URRTDEBackend("127.0.0.1")
    start = time.monotonic()
    with pytest.raises(RobotUnavailable) as info:
        robot.connect()
    assert time.monotonic() - start < 3.0
    message = str(info.value)
    assert "RTDE receive interface failed" in message and "30004" in message  # ur_rtde's own words kept
    assert_helpful(message, "127.0.0.1")
    assert isinstance(info.value.__cause__, RuntimeError)


def test_real_control_interface_error_releases_the_receive_side(monkeypatch: pytest.MonkeyPatch) -> None:
    controller = FakeController()
    _, fake_receive = fake_modules(controller)
    monkeypatch.setitem(sys.modules, "rtde_receive", fake_receive)  # rtde_control stays the real package
    monkeypatch.setattr(ur_rtde_backend, "probe_rtde", lambda *args, **kwargs: None)
    with pytest.raises(RobotUnavailable, match="control interface failed"):
        URRTDEBackend("127.0.0.1").connect()
    assert controller.names() == ["RTDEReceiveInterface", "receive.disconnect"]


# ------------------------------------------------------------------------------------------ the probe
def serve(handler: Callable[[socket.socket], None]) -> tuple[int, threading.Thread]:
    """A one-connection TCP server on a free local port; ``handler`` gets the accepted socket."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def run() -> None:
        with server:
            server.settimeout(5.0)
            connection, _ = server.accept()
            with connection:
                handler(connection)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return server.getsockname()[1], thread


def test_probe_accepts_an_rtde_answer_after_a_text_message() -> None:
    received: list[bytes] = []

    def controller(connection: socket.socket) -> None:
        received.append(connection.recv(5))
        text = b"hello"
        connection.sendall(struct.pack(">HBB", 3 + 1 + len(text), 77, 1) + text)  # a text message first
        connection.sendall(struct.pack(">HBB", 4, 86, 1))  # protocol version accepted

    port, thread = serve(controller)
    probe_rtde("127.0.0.1", port, timeout=2.0)
    thread.join(2.0)
    assert received == [struct.pack(">HBH", 5, 86, 2)]


@pytest.mark.parametrize(
    "behaviour, expected",
    [
        ("silent", "sent no RTDE answer within 0.3 s"),
        ("http", "answered, but not with RTDE"),
        ("close", "closed the connection"),
    ],
)
def test_probe_fails_fast_on_anything_but_rtde(behaviour: str, expected: str) -> None:
    release = threading.Event()

    def other(connection: socket.socket) -> None:
        connection.recv(5)
        if behaviour == "http":
            connection.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")
        if behaviour == "silent":
            release.wait(5.0)

    port, thread = serve(other)
    start = time.monotonic()
    with pytest.raises(RobotUnavailable) as info:
        probe_rtde("127.0.0.1", port, timeout=0.3)
    assert time.monotonic() - start < 1.5
    release.set()
    thread.join(2.0)
    assert expected in str(info.value)
    assert_helpful(str(info.value), "127.0.0.1")


def test_probe_on_a_closed_port() -> None:
    with socket.socket() as s:  # a port that was free a moment ago: nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(RobotUnavailable, match=f"cannot open the RTDE port {port}"):
        probe_rtde("127.0.0.1", port, timeout=0.5)


# ------------------------------------------------------------------------------------------ construction
def test_ur_rtde_is_imported_only_on_connect() -> None:
    code = (
        "import sys, dpiil_rl.robots.ur_rtde_backend; "
        "print('rtde_control' in sys.modules, 'rtde_receive' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"host": ""}, "host"),
        ({"host": "10.0.0.2", "frequency": 0.0}, "frequency"),
        ({"host": "10.0.0.2", "frequency": 600.0}, "at most the RTDE rate"),
        ({"host": "10.0.0.2", "tcp_offset": [0.0, 0.0, 0.1]}, "tcp_offset"),
        ({"host": "10.0.0.2", "connect_timeout": math.nan}, "connect_timeout"),
    ],
)
def test_bad_arguments_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        URRTDEBackend(**kwargs)


def test_rotvec_to_quaternion_matches_scipy() -> None:
    np.testing.assert_allclose(rotvec_to_quaternion([0.0, 0.0, 0.0]), [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(rotvec_to_quaternion([0.0, 0.0, math.pi]), [0.0, 0.0, 0.0, 1.0], atol=1e-12)
    for rotvec in np.random.default_rng(0).normal(size=(20, 3)):
        x, y, z, w = Rotation.from_rotvec(rotvec).as_quat()
        expected = np.array([w, x, y, z]) * (1.0 if w >= 0 else -1.0)
        got = rotvec_to_quaternion(rotvec)
        got = got * (1.0 if got[0] >= 0 else -1.0)
        np.testing.assert_allclose(got, expected, atol=1e-12)


# ------------------------------------------------------------------------------------------ with stand-ins
def _signatures(doc: str, name: str) -> list[list[str]]:
    """Parameter names of every overload in a pybind11 docstring."""
    result = []
    for line in doc.splitlines():
        match = re.match(rf"^\s*(?:\d+\. )?{name}\((.*)\) -> ", line)
        if match:
            result.append(re.findall(r"(?:^|, )(\w+):", match.group(1)))
    return result


@pytest.mark.parametrize(
    "fake, module, cls",
    [
        (FakeRTDEControlInterface, "rtde_control", "RTDEControlInterface"),
        (FakeRTDEReceiveInterface, "rtde_receive", "RTDEReceiveInterface"),
    ],
)
def test_stand_ins_follow_the_installed_ur_rtde(fake: type, module: str, cls: str) -> None:
    real = getattr(__import__(module), cls)
    for name, method in vars(fake).items():
        if not callable(method) or (name.startswith("_") and name != "__init__"):
            continue
        real_method = getattr(real, name, None)
        assert real_method is not None, f"{cls}.{name} does not exist in ur_rtde"
        ours = list(inspect.signature(method).parameters)
        theirs = _signatures(real_method.__doc__ or "", name)
        assert ours in theirs, f"{cls}.{name}{ours} differs from ur_rtde's {theirs}"


@pytest.fixture
def controller(monkeypatch: pytest.MonkeyPatch) -> FakeController:
    controller = FakeController()
    control, receive = fake_modules(controller)
    monkeypatch.setitem(sys.modules, "rtde_control", control)
    monkeypatch.setitem(sys.modules, "rtde_receive", receive)

    def probe(host: str, port: int, timeout: float) -> None:
        controller.calls.append(("probe", host, port, timeout))

    monkeypatch.setattr(ur_rtde_backend, "probe_rtde", probe)
    return controller


def test_connect_and_read_state(controller: FakeController) -> None:
    offset = [0.0, 0.0, 0.15, 0.0, 0.0, 0.0]
    with URRTDEBackend("10.0.0.2", frequency=50.0, tcp_offset=offset, connect_timeout=0.5) as robot:
        assert robot.is_connected and robot.control_period == pytest.approx(0.02)
        assert controller.calls[:4] == [
            ("probe", "10.0.0.2", 30004, 0.5),
            ("RTDEReceiveInterface", "10.0.0.2", 500.0),
            ("RTDEControlInterface", "10.0.0.2", 500.0),
            ("setTcp", offset),
        ]
        robot.connect()  # idempotent
        assert controller.names().count("probe") == 1
        state = robot.read_state()
    np.testing.assert_allclose(state.tcp_position, [0.1, -0.4, 0.3])
    np.testing.assert_allclose(state.tcp_quaternion, rotvec_to_quaternion([0.0, 3.14159, 0.0]))
    assert abs(state.tcp_quaternion[2]) == pytest.approx(1.0, abs=1e-5)  # half a turn about y
    np.testing.assert_allclose(state.joint_positions, controller.q)
    assert state.time == 12.5 and not state.protective_stop and not state.collision


def test_velocity_commands_keep_the_control_period(controller: FakeController) -> None:
    with URRTDEBackend("10.0.0.2", frequency=50.0) as robot:
        start = time.monotonic()
        for _ in range(10):
            robot.command_tcp_velocity(np.array([0.01, -0.02, 0.03]), acceleration=0.8)
        assert 0.195 <= time.monotonic() - start < 0.4  # 10 periods of 20 ms
        sends = [call for call in controller.calls if call[0] == "speedL"]
        assert [call[1:4] for call in sends] == [([0.01, -0.02, 0.03, 0.0, 0.0, 0.0], 0.8, 1 / 500)] * 10
        # sent on a fixed grid (deadlines chained, so sleep jitter does not add up): the mean gap is the period
        assert (sends[-1][4] - sends[1][4]) / 8 == pytest.approx(0.02, abs=0.0015)
        time.sleep(0.1)  # the caller paused (training, a reset)
        start = time.monotonic()
        for _ in range(3):
            robot.command_tcp_velocity(np.zeros(3), acceleration=0.8)
        assert time.monotonic() - start >= 0.055  # a new chain: no burst to catch up
        with pytest.raises(ValueError, match="finite"):
            robot.command_tcp_velocity(np.array([np.nan, 0.0, 0.0]), 0.8)


def test_move_to_keeps_the_orientation_and_stop_uses_speed_stop(controller: FakeController) -> None:
    with URRTDEBackend("10.0.0.2", move_acceleration=0.4) as robot:
        robot.move_to(np.array([0.2, -0.5, 0.25]), speed=0.1)
        robot.stop(2.0)
    moves = [call for call in controller.calls if call[0] == "moveL"]
    assert moves == [("moveL", [0.2, -0.5, 0.25, 0.0, 3.14159, 0.0], 0.1, 0.4)]
    assert ("speedStop", 2.0) in controller.calls


def test_protective_stop_then_unlock_reuploads_the_script(controller: FakeController) -> None:
    with URRTDEBackend("10.0.0.2", frequency=100.0) as robot:
        controller.protective_stop = True
        controller.program_running = False  # a protective stop ends the script
        assert robot.read_state().protective_stop
        robot.command_tcp_velocity(np.array([0.01, 0.0, 0.0]), 0.5)
        assert "speedL" not in controller.names()
        with pytest.raises(RuntimeError, match="protective stop"):
            robot.move_to(np.array([0.2, -0.5, 0.25]), 0.1)
        controller.protective_stop = False  # unlocked on the pendant
        robot.command_tcp_velocity(np.array([0.01, 0.0, 0.0]), 0.5)
        assert controller.names()[-2:] == ["reuploadScript", "speedL"]


def test_a_program_stopped_on_the_pendant_is_not_restarted(controller: FakeController) -> None:
    with URRTDEBackend("10.0.0.2") as robot:
        controller.program_running = False
        with pytest.raises(RobotUnavailable, match="control script is not running"):
            robot.command_tcp_velocity(np.array([0.01, 0.0, 0.0]), 0.5)
        assert "reuploadScript" not in controller.names()


def test_disconnect_stops_and_releases_once(controller: FakeController) -> None:
    robot = URRTDEBackend("10.0.0.2", move_acceleration=0.4)
    robot.connect()
    controller.calls.clear()
    robot.disconnect()
    robot.disconnect()
    assert controller.calls == [("speedStop", 0.4), ("stopScript",), ("control.disconnect",), ("receive.disconnect",)]
    assert not robot.is_connected
    with pytest.raises(RuntimeError, match="not connected"):
        robot.read_state()


def test_lost_connection_is_reported(controller: FakeController) -> None:
    with URRTDEBackend("10.0.0.2") as robot:
        controller.connected = False
        with pytest.raises(RobotUnavailable, match="connection was lost"):
            robot.read_state()
