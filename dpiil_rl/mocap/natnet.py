"""``mocap=natnet``: rigid-body poses streamed live by OptiTrack Motive over NatNet (UDP).

The person holds a tracked ring; this client keeps the newest pose of every rigid body in the stream
and hands out the configured one through :meth:`NatNetMocap.latest`. A background thread receives and
parses frames (:mod:`dpiil_rl.mocap.natnet_wire`), so reading never waits for the network.

Connecting sends ``NAT_CONNECT`` to Motive's command port; Motive answers with its NatNet version,
which decides the frame layout (set ``natnet_version`` to skip waiting for that answer). Then:

* **unicast**: Motive sends frames to the socket that connected; the client sends a keep-alive every
  ``keepalive_s`` so Motive keeps streaming to it.

The connect request is repeated every ``keepalive_s`` until Motive answers or frames arrive (UDP may
drop either).
* **multicast**: frames go to the group (239.255.42.99:1511 by default), joined on ``local_interface``.

A body missing from a frame (out of view, deactivated in Motive) keeps its last pose, which ages.
Packets that do not parse are counted in :attr:`NatNetMocap.stats` and logged, never fatal; socket
errors are counted too. Neither refreshes a pose, so when frames stop for any reason the poses age and
the teleoperation watchdog (which compares :attr:`MocapPose.received` with the clock) stops the robot.
"""

from __future__ import annotations

import logging
import select
import socket
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from dpiil_rl.mocap import natnet_wire as wire
from dpiil_rl.mocap.base import MocapPose, MocapSource, MocapUnavailable
from dpiil_rl.mocap.transform import RigidTransform

log = logging.getLogger(__name__)

_RECV_BYTES = 65_536
_POLL_S = 0.05  # how often the receiver thread checks for shutdown and keep-alives
_MAX_BURST = 256  # packets read from one socket before checking for shutdown and keep-alives again


@dataclass
class NatNetStats:
    """What the receiver thread has seen since :meth:`NatNetMocap.connect`."""

    frames: int = 0  # frames of data parsed
    malformed: int = 0  # packets that did not parse (short, truncated, wrong version)
    socket_errors: int = 0  # receive errors (e.g. an ICMP "port unreachable" reported by Windows)
    other_messages: int = 0  # other well-formed packets: command replies, model definitions, frames that
    # arrived before Motive said which NatNet version they are in
    last_error: str | None = None


class NatNetMocap(MocapSource):
    def __init__(
        self,
        server_address: str = "127.0.0.1",
        local_interface: str = "0.0.0.0",
        multicast: bool = True,
        multicast_group: str = "239.255.42.99",
        command_port: int = 1510,
        data_port: int = 1511,
        natnet_version: str | None = None,
        rigid_body_id: int = 1,
        mocap_to_robot: RigidTransform | Mapping[str, Any] | None = None,
        connect_timeout_s: float = 2.0,
        keepalive_s: float = 1.0,
    ) -> None:
        """Arguments as in ``configs/mocap/natnet.yaml``; ``mocap_to_robot`` None = poses in Motive's frame."""
        super().__init__(rigid_body_id)
        for key, port in (("command_port", command_port), ("data_port", data_port)):
            if not 0 < int(port) < 65536:
                raise ValueError(
                    f"mocap.{key} = {port}: expected a UDP port in 1..65535 (Motive's default is "
                    f"{1510 if key == 'command_port' else 1511})"
                )
        if connect_timeout_s <= 0 or keepalive_s <= 0:
            raise ValueError(
                f"mocap.connect_timeout_s = {connect_timeout_s}, keepalive_s = {keepalive_s}: expected positive seconds"
            )
        for key, address in (
            ("server_address", server_address),
            ("local_interface", local_interface),
            ("multicast_group", multicast_group),
        ):
            try:
                socket.inet_aton(str(address))
            except OSError:
                raise ValueError(f"mocap.{key} = {address!r}: expected an IPv4 address such as 192.168.1.10") from None
        if multicast and not 224 <= int(str(multicast_group).split(".")[0]) <= 239:
            raise ValueError(
                f"mocap.multicast_group = {multicast_group!r} is not a multicast address (224.0.0.0 to "
                "239.255.255.255); Motive's default is 239.255.42.99"
            )
        self.server_address = str(server_address)
        self.local_interface = str(local_interface)
        self.multicast = bool(multicast)
        self.multicast_group = str(multicast_group)
        self.command_port = int(command_port)
        self.data_port = int(data_port)
        self.configured_version = None if natnet_version is None else wire.parse_version(str(natnet_version))
        self.mocap_to_robot = RigidTransform.from_config(mocap_to_robot)
        self.connect_timeout_s = float(connect_timeout_s)
        self.keepalive_s = float(keepalive_s)
        self.name = (
            f"NatNet ({'multicast ' + self.multicast_group if self.multicast else 'unicast'} from Motive at "
            f"{self.server_address}:{self.command_port})"
        )

        self.version: wire.Version | None = None
        self.server: wire.ServerInfo | None = None
        self.stats = NatNetStats()
        self._poses: dict[int, MocapPose] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._server_info_arrived = threading.Event()
        self._thread: threading.Thread | None = None
        self._command: socket.socket | None = None  # unicast: also receives the frames
        self._data: socket.socket | None = None  # multicast only

    # ---------------------------------------------------------------------------- lifecycle
    def connect(self) -> None:
        if self.is_connected:
            return
        self.stats = NatNetStats()
        self._poses = {}
        self.version, self.server = self.configured_version, None
        self._server_info_arrived.clear()
        self._stop.clear()
        self._open_sockets()
        self._send(wire.NAT_CONNECT)
        self._thread = threading.Thread(target=self._receive_loop, name="natnet-receiver", daemon=True)
        self._thread.start()
        if self.configured_version is None and not self._server_info_arrived.wait(self.connect_timeout_s):
            self._close()
            raise MocapUnavailable(
                f"{self.name}: no answer to the connect request within {self.connect_timeout_s:g} s. Check that Motive "
                "runs with streaming on (Streaming pane: Enable, Local Interface = the mocap network), that its "
                f"transmission type is {'multicast' if self.multicast else 'unicast'} like mocap.multicast, that "
                "server_address is the Motive PC and the firewall lets UDP "
                f"{self.command_port}/{self.data_port} through; "
                "or set mocap.natnet_version to stream without the handshake"
            )
        if self.version is None:  # Motive answered with a version this client cannot read
            self._close()
            raise MocapUnavailable(f"{self.name}: {self.stats.last_error}")
        super().connect()
        log.info("%s: connected (NatNet %s)", self.name, _version_text(self.version))

    def disconnect(self) -> None:
        if not self.is_connected:
            return
        if not self.multicast:
            self._send(wire.NAT_DISCONNECT)
        self._close()
        super().disconnect()

    @property
    def receiving(self) -> bool:
        """The receiver thread runs (False after disconnect, or if it stopped on an error: see ``stats.last_error``)."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def local_address(self) -> tuple[str, int]:
        """``(address, port)`` the frames are received on (unicast: where Motive sends them)."""
        sock = self._data if self.multicast else self._command
        if sock is None:
            raise MocapUnavailable(f"{self.name} is not connected: call connect() first")
        return sock.getsockname()

    # ---------------------------------------------------------------------------- reading
    def latest(self, rigid_body_id: int | None = None) -> MocapPose | None:
        self._require_connected()
        with self._lock:
            return self._poses.get(self.rigid_body_id if rigid_body_id is None else int(rigid_body_id))

    def rigid_body_ids(self) -> list[int]:
        """Ids of every rigid body seen in the stream so far (to find the ring's id)."""
        with self._lock:
            return sorted(self._poses)

    # ---------------------------------------------------------------------------- internals
    def _open_sockets(self) -> None:
        try:
            self._command = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
            self._command.bind((self.local_interface, 0))
            self._command.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
            if self.multicast:
                self._data = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
                self._data.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # other clients may listen too
                self._data.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
                self._data.bind(("", self.data_port))
                membership = socket.inet_aton(self.multicast_group) + socket.inet_aton(self.local_interface)
                self._data.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
        except OSError as err:
            self._close()
            raise MocapUnavailable(
                f"{self.name}: cannot open the UDP sockets ({err}). "
                f"Check that local_interface = {self.local_interface!r} "
                "is an address of this machine (`ip addr`; 0.0.0.0 = any)"
                + (
                    ", and that the multicast group can be joined there "
                    f"(a route for 224.0.0.0/4; data port {self.data_port})"
                    if self.multicast
                    else ""
                )
            ) from err

    def _close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        for sock in (self._command, self._data):
            if sock is not None:
                sock.close()
        self._command = self._data = None

    def _send(self, message_id: int) -> None:
        if self._command is None:
            return
        try:
            self._command.sendto(wire.build_request(message_id), (self.server_address, self.command_port))
        except OSError as err:
            self._record_error(f"sending message {message_id} to {self.server_address}:{self.command_port}: {err}")

    def _receive_loop(self) -> None:
        try:
            self._receive()
        except Exception as err:  # a bug must not die silently: the poses go stale and the log says why
            self.stats.last_error = f"receiver thread crashed: {err!r}"
            log.exception("%s: receiver thread crashed; no more poses arrive", self.name)

    def _receive(self) -> None:
        sockets = [s for s in (self._command, self._data) if s is not None]
        for sock in sockets:
            sock.setblocking(False)
        next_keepalive = time.monotonic() + self.keepalive_s
        while not self._stop.is_set():
            try:
                readable, _, _ = select.select(sockets, [], [], _POLL_S)
            except (OSError, ValueError) as err:  # a socket closed under us: nothing more will arrive
                self._record_error(f"receiver stopped: {err}")
                return
            for sock in readable:
                self._drain(sock)
            if time.monotonic() >= next_keepalive:
                if self.server is None and self.stats.frames == 0:
                    self._send(wire.NAT_CONNECT)  # UDP: the first request (or Motive's answer) may have been lost
                elif not self.multicast:
                    self._send(wire.NAT_KEEPALIVE)
                next_keepalive = time.monotonic() + self.keepalive_s

    def _drain(self, sock: socket.socket) -> None:
        for _ in range(_MAX_BURST):
            try:
                packet = sock.recv(_RECV_BYTES)
            except BlockingIOError:
                return
            except OSError as err:
                self._record_error(f"receive error: {err}")
                time.sleep(0.01)  # an error repeating on every call must not spin the CPU
                return
            self._handle(packet, time.monotonic())

    def _handle(self, packet: bytes, received: float) -> None:
        try:
            message_id, payload = wire.split_packet(packet)
            if message_id == wire.NAT_FRAMEOFDATA:
                if self.version is None:
                    self.stats.other_messages += 1  # a frame before Motive said how to read it
                    return
                self._store(wire.parse_frame(payload, self.version), received)
            elif message_id == wire.NAT_SERVERINFO:
                self._adopt(wire.parse_server_info(payload))
            else:
                self.stats.other_messages += 1
        except wire.NatNetFormatError as err:
            self.stats.malformed += 1
            self.stats.last_error = str(err)
            (log.warning if self.stats.malformed == 1 else log.debug)(
                "%s: dropped a malformed packet (%s); further ones are counted in stats.malformed", self.name, err
            )

    def _store(self, frame: wire.FrameOfData, received: float) -> None:
        poses = {}
        for body in frame.rigid_bodies:
            qx, qy, qz, qw = body.quaternion_xyzw
            position, quaternion = self.mocap_to_robot.apply(np.array(body.position), np.array([qw, qx, qy, qz]))
            poses[body.id] = MocapPose(
                position, quaternion, frame.timestamp, received, body.tracking_valid, frame.frame_number
            )
        with self._lock:
            self._poses.update(poses)
        self.stats.frames += 1

    def _adopt(self, info: wire.ServerInfo) -> None:
        streamed = (info.natnet_version[0], info.natnet_version[1])
        if streamed < wire.OLDEST_SUPPORTED:
            self.stats.last_error = (
                f"{info.application} streams NatNet {_version_text(streamed)}; this client reads "
                "3.0 to 4.x (Motive 2.0 and later): update Motive"
            )
            log.error("%s: %s", self.name, self.stats.last_error)
            self._server_info_arrived.set()
            return
        if self.configured_version is not None and streamed != self.configured_version:
            log.warning(
                "%s: natnet_version is %s but %s streams %s; reading frames as %s",
                self.name,
                _version_text(self.configured_version),
                info.application,
                _version_text(streamed),
                _version_text(streamed),
            )
        if streamed[0] > 4:
            log.warning(
                "%s: NatNet %s is newer than this client knows (4.x); frames are read with the 4.1 layout",
                self.name,
                _version_text(streamed),
            )
        self.server, self.version = info, streamed
        self._server_info_arrived.set()

    def _record_error(self, message: str) -> None:
        self.stats.socket_errors += 1
        self.stats.last_error = message
        (log.warning if self.stats.socket_errors == 1 else log.debug)("%s: %s", self.name, message)


def _version_text(version: wire.Version | None) -> str:
    return "unknown" if version is None else f"{version[0]}.{version[1]}"
