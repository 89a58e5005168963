"""The NatNet client against a mock Motive on 127.0.0.1 (unicast UDP), frames in the documented wire format."""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from dpiil_rl.mocap import natnet
from dpiil_rl.mocap.base import MocapUnavailable
from dpiil_rl.mocap.natnet import NatNetMocap
from tests.mocks.natnet_sender import Body, MockMotive, pack_frame, pack_packet

Y_UP_TO_Z_UP = {"rotation": [[1, 0, 0], [0, 0, -1], [0, 1, 0]], "translation": [0.5, 0.0, 0.1]}


def wait_until(condition: Callable[[], bool], timeout: float = 2.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("timed out waiting for the client")
        time.sleep(0.002)


def client_for(motive: MockMotive, **overrides: object) -> NatNetMocap:
    kwargs: dict = {
        "server_address": "127.0.0.1",
        "local_interface": "127.0.0.1",
        "multicast": False,
        "command_port": motive.command_port,
        "connect_timeout_s": 2.0,
    }
    kwargs.update(overrides)
    return NatNetMocap(**kwargs)


@pytest.fixture
def motive() -> Iterator[MockMotive]:
    with MockMotive(natnet_version=(4, 1)) as server:
        yield server


@pytest.mark.parametrize("version", [(3, 0), (3, 1), (4, 0), (4, 1)], ids=lambda v: f"natnet{v[0]}.{v[1]}")
def test_handshake_learns_the_version_and_frames_parse(version: tuple[int, int]) -> None:
    with MockMotive(natnet_version=version) as motive, client_for(motive) as client:
        assert client.version == version and client.server is not None and client.server.application == "Motive"
        assert client.latest() is None  # nothing streamed yet
        sent = time.monotonic()
        motive.send(
            pack_frame(
                100,
                [Body(1, (0.1, 1.2, -0.3), (0.0, 0.7071068, 0.0, 0.7071068)), Body(3, (2.0, 0.0, 0.0), tracked=False)],
                version=version,
                timestamp=33.25,
            )
        )
        wait_until(lambda: client.latest(3) is not None)
        pose = client.latest()  # the configured body (1)
        assert pose is not None
        np.testing.assert_allclose(pose.position, [0.1, 1.2, -0.3], atol=1e-6)
        np.testing.assert_allclose(pose.quaternion, [0.7071068, 0.0, 0.7071068, 0.0], atol=1e-6)  # w, x, y, z
        assert pose.tracking_valid and pose.frame_number == 100 and pose.timestamp == pytest.approx(33.25)
        assert sent <= pose.received <= time.monotonic()
        other = client.latest(3)
        assert other is not None and not other.tracking_valid
        assert client.fresh(1.0, 3) is None and client.fresh(1.0) is pose  # lost by the tracker: not to be followed
        np.testing.assert_allclose(other.position, [2.0, 0.0, 0.0], atol=1e-6)
        assert client.latest(101) is None  # a skeleton's bone is not a rigid body
        assert client.rigid_body_ids() == [1, 3]
        assert client.stats.frames == 1 and client.stats.malformed == 0 and client.receiving
    assert not client.receiving


def test_newest_frame_wins_and_bodies_update_independently(motive: MockMotive) -> None:
    with client_for(motive) as client:
        motive.send(pack_frame(1, [Body(1, (0.0, 0.0, 0.0)), Body(2, (5.0, 5.0, 5.0))]))
        wait_until(lambda: client.stats.frames == 1)
        motive.send(pack_frame(2, [Body(1, (1.0, 0.0, 0.0))]))  # body 2 out of view: absent from the frame
        wait_until(lambda: client.stats.frames == 2)
        one, two = client.latest(1), client.latest(2)
        assert one is not None and two is not None
        assert one.frame_number == 2 and one.position[0] == pytest.approx(1.0)
        assert two.frame_number == 1 and two.received < one.received  # kept, but older: a watchdog sees its age


def test_mocap_to_robot_maps_y_up_to_z_up(motive: MockMotive) -> None:
    with client_for(motive, mocap_to_robot=Y_UP_TO_Z_UP) as client:
        # hand 1 m up (Motive's +y), 0.2 m towards Motive's +z, turned 90 degrees about Motive's up axis (y)
        motive.send(pack_frame(5, [Body(1, (0.0, 1.0, 0.2), (0.0, 0.7071068, 0.0, 0.7071068))]))
        wait_until(lambda: client.latest() is not None)
        pose = client.latest()
        assert pose is not None
        np.testing.assert_allclose(pose.position, [0.5, -0.2, 1.1], atol=1e-6)  # up is the robot's +z
        # the turn about the world's up axis is now a turn about the robot's z axis, applied after the axis change
        robot_axis_angle = np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)])
        change = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0])  # +90 degrees about x: y -> z
        expected = _mul(robot_axis_angle, change)
        assert abs(float(np.dot(pose.quaternion, expected))) == pytest.approx(1.0, abs=1e-6)


def test_explicit_version_streams_without_a_handshake() -> None:
    with (
        MockMotive(answer_connect=False) as motive,
        client_for(motive, natnet_version="3.1", connect_timeout_s=0.2) as client,
    ):
        assert client.version == (3, 1) and client.server is None
        motive.send(pack_frame(9, [Body(1, (0.0, 0.0, 1.0))], version=(3, 1)), to=client.local_address)
        wait_until(lambda: client.latest() is not None)
        assert client.latest().frame_number == 9  # type: ignore[union-attr]


def test_connect_request_is_repeated_until_the_stream_starts() -> None:
    with (
        MockMotive(answer_connect=False) as motive,
        client_for(motive, natnet_version="4.1", keepalive_s=0.03) as client,
    ):
        wait_until(lambda: motive.connects >= 3)
        assert motive.keepalives == 0
        motive.send(pack_frame(1, [Body(1, (0.0, 0.0, 0.0))]), to=client.local_address)
        wait_until(lambda: motive.keepalives >= 2)  # streaming: keep-alives replace the connect requests
        connects = motive.connects
        time.sleep(0.1)
        assert motive.connects == connects


def test_a_too_old_motive_is_a_clear_error() -> None:
    with (
        MockMotive(natnet_version=(2, 10)) as motive,
        pytest.raises(MocapUnavailable, match="streams NatNet 2.10; this client reads 3.0 to 4.x"),
    ):
        client_for(motive).connect()


def test_no_answer_is_a_clear_error() -> None:
    with MockMotive(answer_connect=False) as motive:
        client = client_for(motive, connect_timeout_s=0.2)
        with pytest.raises(MocapUnavailable, match="no answer to the connect request within 0.2 s.*natnet_version"):
            client.connect()
        assert not client.is_connected
        with pytest.raises(MocapUnavailable, match="not connected"):
            client.latest()


def test_stale_when_frames_stop_and_keepalives_go_out(motive: MockMotive) -> None:
    with client_for(motive, keepalive_s=0.05) as client:
        motive.send(pack_frame(1, [Body(1, (0.0, 0.0, 0.0))]))
        wait_until(lambda: client.latest() is not None)
        assert client.fresh(0.5) is not None
        wait_until(lambda: motive.keepalives >= 2)  # unicast: Motive keeps streaming to clients that keep alive
        time.sleep(0.15)  # the sender stops: no frame refreshes the pose
        pose = client.latest()
        assert pose is not None and pose.age() >= 0.15
        assert client.fresh(0.1) is None  # what the teleoperation watchdog checks
        motive.send(pack_frame(2, [Body(1, (0.0, 0.0, 0.0))]))  # the stream resumes
        wait_until(lambda: client.fresh(0.1) is not None)
    assert motive.disconnects == 1


def test_malformed_packets_are_counted_and_the_receiver_keeps_going(motive: MockMotive) -> None:
    with client_for(motive) as client:
        good = pack_frame(1, [Body(1, (0.0, 0.0, 0.0))])
        bad = [
            b"",  # empty datagram
            b"\x07",  # shorter than the header
            struct.pack("<HH", 7, 500) + bytes(20),  # header promises more than the packet holds
            good[:40],  # frame cut inside the rigid bodies (header size wrong too)
            pack_packet(7, good[4:60]),  # consistent header, truncated frame
            pack_packet(7, struct.pack("<ii", 3, -1)),  # negative count
            pack_packet(1, b"short server info"),  # server info too short
            bytes(range(256)) * 3,  # noise
        ]
        for packet in bad:
            motive.send(packet)
        motive.send(pack_packet(3, b"ok\0"))  # a command response: fine, not a frame
        motive.send(pack_frame(2, [Body(1, (0.3, 0.2, 0.1))]))
        wait_until(lambda: client.latest() is not None)
        assert client.stats.malformed == len(bad)
        assert client.stats.other_messages == 1 and client.stats.frames == 1
        np.testing.assert_allclose(client.latest().position, [0.3, 0.2, 0.1], atol=1e-6)  # type: ignore[union-attr]
        assert client.stats.last_error


class FlakySocket(socket.socket):
    """A socket whose receives fail while ``failing`` is set (as Windows reports an ICMP port-unreachable)."""

    failing = False

    def recv(self, *args: object, **kwargs: object) -> bytes:  # type: ignore[override]
        if FlakySocket.failing:
            raise ConnectionResetError(10054, "connection reset by peer")
        return super().recv(*args, **kwargs)  # type: ignore[arg-type]


def test_socket_errors_are_counted_and_leave_the_pose_stale(
    motive: MockMotive, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(natnet.socket, "socket", FlakySocket)
    with client_for(motive) as client:
        motive.send(pack_frame(1, [Body(1, (0.0, 0.0, 0.0))]))
        wait_until(lambda: client.latest() is not None)
        FlakySocket.failing = True
        try:
            motive.send(pack_frame(2, [Body(1, (1.0, 0.0, 0.0))]))
            wait_until(lambda: client.stats.socket_errors >= 2)
            time.sleep(0.1)
            pose = client.latest()
            assert pose is not None and pose.frame_number == 1 and client.fresh(0.1) is None
            assert "connection reset" in (client.stats.last_error or "")
        finally:
            FlakySocket.failing = False
        wait_until(lambda: client.latest().frame_number == 2)  # type: ignore[union-attr]  # the queued frame arrives
        assert client.fresh(0.1) is not None


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"command_port": 0}, "command_port = 0"),
        ({"data_port": 70000}, "data_port = 70000"),
        ({"server_address": "motive.local"}, "server_address = 'motive.local'"),
        ({"multicast_group": "10.0.0.1"}, "not a multicast address"),
        ({"natnet_version": "2.9"}, "3.0 to 4.x"),
        ({"mocap_to_robot": {"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}}, "not a proper rotation"),
        ({"mocap_to_robot": {"rotation": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}}, "not a proper rotation"),
        ({"mocap_to_robot": {"translation": [0, 0]}}, "3-vector"),
        ({"mocap_to_robot": {"offset": [0, 0, 0]}}, "unknown key"),
        ({"connect_timeout_s": 0}, "positive seconds"),
    ],
)
def test_bad_config_names_the_value(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        NatNetMocap(**kwargs)


def test_bad_local_interface_is_unavailable_with_a_fix() -> None:
    client = NatNetMocap(local_interface="203.0.113.7", multicast=False)  # not an address of this machine
    with pytest.raises(MocapUnavailable, match="local_interface = '203.0.113.7'"):
        client.connect()


def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )
