"""Test-only stand-in for Motive: packs NatNet packets as the SDK documents them and sends them over UDP.

The packer is written from the documented layout (``PacketClient``), independently of the client's
parser, and fills every section of a frame (marker sets, unlabeled markers, skeletons whose rigid
bodies must not be mistaken for top-level ones, assets, labeled markers, force plates, devices) so a
parser that skips a section wrongly reads garbage. :class:`MockMotive` answers ``NAT_CONNECT`` with
server info on its command port and streams frames to the client that connected (unicast), on
127.0.0.1 only.
"""

from __future__ import annotations

import socket
import struct
import threading
from dataclasses import dataclass, field
from typing import Self

NAT_CONNECT, NAT_SERVERINFO, NAT_FRAMEOFDATA, NAT_DISCONNECT, NAT_KEEPALIVE = 0, 1, 7, 9, 10


@dataclass
class Body:
    id: int
    position: tuple[float, float, float]
    quaternion_xyzw: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    tracked: bool = True
    error: float = 0.0005


@dataclass
class Clutter:
    """Everything in a frame that is not a top-level rigid body."""

    marker_sets: list[tuple[str, list[tuple[float, float, float]]]] = field(
        default_factory=lambda: [
            ("ring", [(0.1, 0.2, 0.3), (0.4, 0.5, 0.6), (0.7, 0.8, 0.9)]),
            ("all", [(9.0, 9.0, 9.0)]),
        ]
    )
    unlabeled: list[tuple[float, float, float]] = field(default_factory=lambda: [(1.0, 2.0, 3.0), (4.0, 5.0, 6.0)])
    skeletons: list[tuple[int, list[Body]]] = field(
        default_factory=lambda: [(7, [Body(101, (5.0, 5.0, 5.0)), Body(102, (6.0, 6.0, 6.0))])]
    )
    labeled_markers: int = 3
    force_plate_channels: list[list[float]] = field(default_factory=lambda: [[1.0, 2.0], [3.0]])
    device_channels: list[list[float]] = field(default_factory=lambda: [[0.5], [0.25, 0.125, 1.0]])
    asset_bodies: list[Body] = field(default_factory=lambda: [Body(201, (7.0, 7.0, 7.0))])


def pack_packet(message_id: int, payload: bytes) -> bytes:
    return struct.pack("<HH", message_id, len(payload)) + payload


def pack_frame(
    frame_number: int,
    bodies: list[Body],
    version: tuple[int, int] = (4, 1),
    timestamp: float = 12.5,
    clutter: Clutter | None = None,
) -> bytes:
    """A complete ``NAT_FRAMEOFDATA`` packet (header included) for NatNet ``version`` (3.0 and later)."""
    c = Clutter() if clutter is None else clutter
    sized = version >= (4, 1)

    def section(count: int, body: bytes) -> bytes:
        return struct.pack("<i", count) + (struct.pack("<i", len(body)) if sized else b"") + body

    def rigid_body(b: Body) -> bytes:
        return struct.pack("<i3f4ffh", b.id, *b.position, *b.quaternion_xyzw, b.error, 1 if b.tracked else 0)

    def channels(device_id: int, data: list[list[float]]) -> bytes:
        out = struct.pack("<ii", device_id, len(data))
        for values in data:
            out += struct.pack(f"<i{len(values)}f", len(values), *values)
        return out

    payload = struct.pack("<i", frame_number)
    payload += section(
        len(c.marker_sets),
        b"".join(
            name.encode() + b"\0" + struct.pack("<i", len(ms)) + b"".join(struct.pack("<3f", *m) for m in ms)
            for name, ms in c.marker_sets
        ),
    )
    payload += section(len(c.unlabeled), b"".join(struct.pack("<3f", *m) for m in c.unlabeled))
    payload += section(len(bodies), b"".join(rigid_body(b) for b in bodies))
    payload += section(
        len(c.skeletons),
        b"".join(
            struct.pack("<ii", skeleton_id, len(parts)) + b"".join(rigid_body(b) for b in parts)
            for skeleton_id, parts in c.skeletons
        ),
    )
    if sized:  # assets: id, rigid bodies (id, pos, quat, error, params), markers (id, pos, size, params, residual)
        asset = struct.pack("<ii", 1, len(c.asset_bodies)) + b"".join(
            struct.pack("<i3f4ffh", b.id, *b.position, *b.quaternion_xyzw, b.error, 1) for b in c.asset_bodies
        )
        asset += struct.pack("<i", 1) + struct.pack("<i3ffhf", 5, 1.0, 2.0, 3.0, 0.01, 0, 0.0)
        payload += section(1, asset)
    payload += section(
        c.labeled_markers,
        b"".join(
            struct.pack("<i3ffhf", (1 << 16) | i, 0.1 * i, 0.2, 0.3, 0.014, 0x04, 0.0002)
            for i in range(c.labeled_markers)
        ),
    )
    payload += section(1, channels(11, c.force_plate_channels))
    payload += section(1, channels(12, c.device_channels))
    # suffix: timecode, subframe, timestamp, three camera timestamps, [4.1+] precision timestamp, params, end tag
    payload += struct.pack("<IId3Q", 0, 0, timestamp, 1000, 2000, 3000)
    if sized:
        payload += struct.pack("<II", 0, 0)
    payload += struct.pack("<hi", 0, 0)
    return pack_packet(NAT_FRAMEOFDATA, payload)


def pack_server_info(natnet_version: tuple[int, ...], application: str = "Motive") -> bytes:
    version = tuple(natnet_version) + (0,) * (4 - len(natnet_version))
    payload = application.encode().ljust(256, b"\0") + bytes((3, 1, 0, 0)) + bytes(version)
    payload += struct.pack("<QH?4B", 1_000_000, 1511, False, 239, 255, 42, 99)
    return pack_packet(NAT_SERVERINFO, payload)


class MockMotive:
    """A NatNet server on 127.0.0.1: answers connect requests, counts keep-alives, sends frames to the client."""

    def __init__(self, natnet_version: tuple[int, ...] = (4, 1), answer_connect: bool = True) -> None:
        self.natnet_version = natnet_version
        self.answer_connect = answer_connect
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.command_port: int = self.sock.getsockname()[1]
        self.client: tuple[str, int] | None = None
        self.connects = self.keepalives = self.disconnects = 0
        self._connected = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        while not self._stop.is_set():
            try:
                packet, address = self.sock.recvfrom(4096)
            except (TimeoutError, OSError):
                continue
            message_id = struct.unpack_from("<H", packet)[0] if len(packet) >= 2 else -1
            if message_id == NAT_CONNECT:
                self.connects += 1
                self.client = address
                if self.answer_connect:
                    self.sock.sendto(pack_server_info(self.natnet_version), address)
                self._connected.set()
            elif message_id == NAT_KEEPALIVE:
                self.keepalives += 1
            elif message_id == NAT_DISCONNECT:
                self.disconnects += 1

    def wait_for_client(self, timeout: float = 2.0) -> tuple[str, int]:
        if not self._connected.wait(timeout) or self.client is None:
            raise AssertionError("the client never sent NAT_CONNECT to the mock Motive")
        return self.client

    def send(self, packet: bytes, to: tuple[str, int] | None = None) -> None:
        self.sock.sendto(packet, to or self.wait_for_client())

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
        self.sock.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
