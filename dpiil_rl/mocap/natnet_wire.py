"""The NatNet wire format (OptiTrack Motive's UDP streaming protocol), NatNet 3.0 to 4.x.

Only what the teleoperation client needs: the packet header, the server-info reply to a connect
request, the requests a client sends, and the rigid bodies, frame number and timestamp of a frame of
data. Layout as documented in the NatNet SDK (``PacketClient``), all little-endian:

* packet: ``uint16 message id, uint16 payload bytes, payload``
* server info (reply to ``NAT_CONNECT``): ``char[256] application name, uint8[4] application version,
  uint8[4] NatNet version``, then clock and multicast details this client does not need
* frame of data (``NAT_FRAMEOFDATA``): ``int32 frame number``, then the sections below, each an
  ``int32 count`` followed, from NatNet 4.1 on, by an ``int32 section bytes``:

  1. marker sets: ``cstring name, int32 n, n * float32[3]`` each
  2. unlabeled ("other") markers: ``float32[3]`` each
  3. rigid bodies: ``int32 id, float32[3] position, float32[4] qx qy qz qw, float32 mean marker
     error, int16 params`` (params bit 0: tracking valid), 38 bytes each
  4. skeletons: ``int32 id, int32 n, n * rigid body`` each
  5. assets (4.1 and later only)
  6. labeled markers: ``int32 id, float32[3], float32 size, int16 params, float32 residual`` each
  7. force plates, 8. devices: ``int32 id, int32 channels``, per channel ``int32 n, n * float32``
  9. suffix: ``uint32 timecode, uint32 subframe, float64 timestamp`` (s since Motive started), then
     camera timestamps, the 4.1 precision timestamp and the frame flags.

From 4.1 on, sections are skipped by their byte size; before, by walking their contents. Parsing stops
after the suffix's timestamp: the fields after it are not needed here (and their layout is the part
that changed most between versions). Versions before 3.0 (Motive 1.x) carry per-rigid-body marker lists
and are not supported. Every read is bounds-checked: a short or inconsistent packet raises
:class:`NatNetFormatError`, never reads past the data.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

NAT_CONNECT = 0
NAT_SERVERINFO = 1
NAT_REQUEST = 2
NAT_RESPONSE = 3
NAT_REQUEST_MODELDEF = 4
NAT_MODELDEF = 5
NAT_REQUEST_FRAMEOFDATA = 6
NAT_FRAMEOFDATA = 7
NAT_MESSAGESTRING = 8
NAT_DISCONNECT = 9
NAT_KEEPALIVE = 10
NAT_UNRECOGNIZED_REQUEST = 100

HEADER = struct.Struct("<HH")
RIGID_BODY = struct.Struct("<i3f4ffh")  # id, x y z, qx qy qz qw, mean marker error, params
_INT32 = struct.Struct("<i")
_SUFFIX = struct.Struct("<IId")  # timecode, subframe, timestamp
_LABELED_MARKER_BYTES = 4 + 12 + 4 + 2 + 4
_MAX_COUNT = 1_000_000  # no section of a UDP packet holds more elements

Version = tuple[int, int]
OLDEST_SUPPORTED: Version = (3, 0)


class NatNetFormatError(ValueError):
    """A packet does not follow the NatNet layout for the version in use (short, truncated, inconsistent)."""


@dataclass(frozen=True)
class RigidBodySample:
    """One rigid body as streamed: Motive's frame and units (m), quaternion in NatNet's x, y, z, w order."""

    id: int
    position: tuple[float, float, float]
    quaternion_xyzw: tuple[float, float, float, float]
    mean_error: float
    tracking_valid: bool


@dataclass(frozen=True)
class FrameOfData:
    frame_number: int
    rigid_bodies: tuple[RigidBodySample, ...]
    timestamp: float  # s, Motive's clock


@dataclass(frozen=True)
class ServerInfo:
    application: str  # "Motive"
    application_version: tuple[int, int, int, int]
    natnet_version: tuple[int, int, int, int]


def parse_version(value: str | Version) -> Version:
    """``"4.1"`` (or ``"4.1.0.0"``, or ``(4, 1)``) to ``(4, 1)``; rejects versions this module cannot read."""
    try:
        parts = [int(p) for p in value.split(".")] if isinstance(value, str) else [int(p) for p in value]
    except (TypeError, ValueError):
        parts = []
    if not 1 <= len(parts) <= 4 or any(p < 0 for p in parts):
        raise ValueError(
            f"natnet_version = {value!r}: expected 'major.minor' such as '4.1' (Motive shows it in "
            "the Streaming pane), or null to ask Motive"
        )
    version = (parts[0], parts[1] if len(parts) > 1 else 0)
    if version < OLDEST_SUPPORTED:
        raise ValueError(
            f"natnet_version = {value!r}: this client reads NatNet 3.0 to 4.x (Motive 2.0 and later); "
            "update Motive or stream with a newer bitstream version"
        )
    return version


def split_packet(packet: bytes) -> tuple[int, memoryview]:
    """``(message id, payload)``; the payload is cut to the size the header declares."""
    if len(packet) < HEADER.size:
        raise NatNetFormatError(f"packet of {len(packet)} bytes is shorter than the 4-byte header")
    message_id, size = HEADER.unpack_from(packet, 0)
    if len(packet) - HEADER.size < size:
        raise NatNetFormatError(
            f"message {message_id} declares {size} payload bytes, the packet holds {len(packet) - HEADER.size}"
        )
    return message_id, memoryview(packet)[HEADER.size : HEADER.size + size]


def build_request(message_id: int, text: str = "") -> bytes:
    """A client request (connect, keep-alive, disconnect: no text; a command: null-terminated text)."""
    payload = (text.encode("utf-8") + b"\0") if text else b""
    return HEADER.pack(message_id, len(payload)) + payload


def parse_server_info(payload: bytes | memoryview) -> ServerInfo:
    if len(payload) < 264:
        raise NatNetFormatError(f"server info of {len(payload)} bytes, expected at least 264")
    raw_name = bytes(payload[:256])
    name = raw_name.split(b"\0", 1)[0].decode("utf-8", errors="replace")
    app = tuple(payload[256:260])
    natnet = tuple(payload[260:264])
    return ServerInfo(name, app, natnet)  # type: ignore[arg-type]


def parse_frame(payload: bytes | memoryview, version: Version) -> FrameOfData:
    """The frame number, top-level rigid bodies and timestamp of a ``NAT_FRAMEOFDATA`` payload."""
    if version < OLDEST_SUPPORTED:
        raise ValueError(f"NatNet {version[0]}.{version[1]} frames are not supported (3.0 and later are)")
    reader = _Reader(payload)
    sized = version >= (4, 1)
    frame_number = reader.int32()

    # 1. marker sets
    count, size = reader.section(sized)
    if sized:
        reader.skip(size)
    else:
        for _ in range(count):
            reader.cstring()
            reader.skip(12 * reader.count())
    # 2. unlabeled markers
    count, size = reader.section(sized)
    reader.skip(size if sized else 12 * count)
    # 3. rigid bodies
    count, size = reader.section(sized)
    if sized and size != count * RIGID_BODY.size:
        raise NatNetFormatError(
            f"{count} rigid bodies in {size} bytes; NatNet {version[0]}.{version[1]} has "
            f"{RIGID_BODY.size} bytes per body (is natnet_version right?)"
        )
    bodies = tuple(_rigid_body(reader) for _ in range(count))
    # 4. skeletons
    count, size = reader.section(sized)
    if sized:
        reader.skip(size)
    else:
        for _ in range(count):
            reader.int32()
            reader.skip(RIGID_BODY.size * reader.count())
    # 5. assets (4.1 and later only, always sized)
    if sized:
        reader.skip(reader.section(True)[1])
    # 6. labeled markers
    count, size = reader.section(sized)
    reader.skip(size if sized else _LABELED_MARKER_BYTES * count)
    # 7. force plates, 8. devices
    for _ in range(2):
        count, size = reader.section(sized)
        if sized:
            reader.skip(size)
        else:
            for _ in range(count):
                reader.int32()
                for _ in range(reader.count()):
                    reader.skip(4 * reader.count())
    # 9. suffix: timecode, subframe, timestamp (the rest is not read)
    _, _, timestamp = reader.unpack(_SUFFIX)
    return FrameOfData(frame_number, bodies, float(timestamp))


def _rigid_body(reader: _Reader) -> RigidBodySample:
    body_id, x, y, z, qx, qy, qz, qw, error, params = reader.unpack(RIGID_BODY)
    return RigidBodySample(body_id, (x, y, z), (qx, qy, qz, qw), error, bool(params & 0x01))


class _Reader:
    """Bounds-checked little-endian reads from a payload."""

    def __init__(self, data: bytes | memoryview) -> None:
        self.data = data
        self.offset = 0

    def unpack(self, layout: struct.Struct) -> tuple:
        self._need(layout.size, layout.format)
        values = layout.unpack_from(self.data, self.offset)
        self.offset += layout.size
        return values

    def int32(self) -> int:
        return self.unpack(_INT32)[0]

    def count(self) -> int:
        value = self.int32()
        if not 0 <= value <= _MAX_COUNT:
            raise NatNetFormatError(f"element count {value} at byte {self.offset - 4} is out of range")
        return value

    def section(self, sized: bool) -> tuple[int, int]:
        """``(count, bytes)`` of a section header; bytes is 0 before NatNet 4.1, where it is not sent."""
        count = self.count()
        size = self.count() if sized else 0
        return count, size

    def skip(self, n: int) -> None:
        self._need(n, f"{n} bytes")
        self.offset += n

    def cstring(self) -> str:
        end = bytes(self.data[self.offset :]).find(b"\0")
        if end < 0:
            raise NatNetFormatError(f"unterminated string at byte {self.offset}")
        text = bytes(self.data[self.offset : self.offset + end]).decode("utf-8", errors="replace")
        self.offset += end + 1
        return text

    def _need(self, n: int, what: str) -> None:
        if self.offset + n > len(self.data):
            raise NatNetFormatError(f"packet ends at byte {len(self.data)}, reading {what} at byte {self.offset}")
