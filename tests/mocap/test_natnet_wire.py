"""The NatNet frame parser against frames packed from the documented layout (no sockets)."""

from __future__ import annotations

import struct

import pytest

from dpiil_rl.mocap import natnet_wire as wire
from tests.mocks.natnet_sender import Body, Clutter, pack_frame, pack_server_info

VERSIONS = [(3, 0), (3, 1), (4, 0), (4, 1), (4, 2)]
BODIES = [
    Body(1, (0.1, -0.2, 1.5), (0.0, 0.0, 0.38268343, 0.92387953)),
    Body(2, (2.0, 0.0, -3.0), (1.0, 0.0, 0.0, 0.0), tracked=False),
]


@pytest.mark.parametrize("version", VERSIONS, ids=lambda v: f"natnet{v[0]}.{v[1]}")
def test_frame_with_every_section_filled(version: tuple[int, int]) -> None:
    message_id, payload = wire.split_packet(pack_frame(4242, BODIES, version=version, timestamp=98.765))
    assert message_id == wire.NAT_FRAMEOFDATA
    frame = wire.parse_frame(payload, version)
    assert frame.frame_number == 4242
    assert frame.timestamp == pytest.approx(98.765)
    assert [b.id for b in frame.rigid_bodies] == [1, 2]  # skeleton and asset bodies (101, 102, 201) stay out
    first, second = frame.rigid_bodies
    assert first.position == pytest.approx((0.1, -0.2, 1.5))
    assert first.quaternion_xyzw == pytest.approx((0.0, 0.0, 0.38268343, 0.92387953))
    assert first.tracking_valid and not second.tracking_valid
    assert first.mean_error == pytest.approx(0.0005)


@pytest.mark.parametrize("version", [(3, 1), (4, 1)], ids=lambda v: f"natnet{v[0]}.{v[1]}")
def test_empty_frame(version: tuple[int, int]) -> None:
    empty = Clutter(
        marker_sets=[],
        unlabeled=[],
        skeletons=[],
        labeled_markers=0,
        force_plate_channels=[],
        device_channels=[],
        asset_bodies=[],
    )
    frame = wire.parse_frame(wire.split_packet(pack_frame(1, [], version=version, clutter=empty))[1], version)
    assert frame.rigid_bodies == () and frame.frame_number == 1


def test_every_truncation_raises_format_error() -> None:
    packet = pack_frame(7, BODIES, version=(3, 1))
    _, payload = wire.split_packet(packet)
    cut_points = range(len(payload) - 30)  # the last 30 bytes are after the timestamp (not read)
    for cut in cut_points:
        with pytest.raises(wire.NatNetFormatError):
            wire.parse_frame(payload[:cut], (3, 1))


def test_wrong_version_is_caught_by_the_section_sizes() -> None:
    _, payload = wire.split_packet(pack_frame(7, BODIES, version=(3, 1)))
    with pytest.raises(wire.NatNetFormatError):
        wire.parse_frame(payload, (4, 1))


def test_rigid_body_section_size_must_match_the_layout() -> None:
    payload = bytearray(wire.split_packet(pack_frame(7, BODIES, version=(4, 1)))[1])
    # marker sets and unlabeled markers are [count, size, data]: find the rigid-body size field and corrupt it
    offset = 4
    for _ in range(2):
        size = struct.unpack_from("<i", payload, offset + 4)[0]
        offset += 8 + size
    assert struct.unpack_from("<ii", payload, offset) == (2, 2 * 38)
    struct.pack_into("<i", payload, offset + 4, 2 * 42)
    with pytest.raises(wire.NatNetFormatError, match="38 bytes per body"):
        wire.parse_frame(bytes(payload), (4, 1))


def test_negative_count_is_rejected() -> None:
    payload = struct.pack("<ii", 1, -5) + bytes(100)
    with pytest.raises(wire.NatNetFormatError, match="count -5"):
        wire.parse_frame(payload, (3, 0))


def test_header_checks() -> None:
    with pytest.raises(wire.NatNetFormatError, match="shorter than the 4-byte header"):
        wire.split_packet(b"\x07")
    with pytest.raises(wire.NatNetFormatError, match="declares 100 payload bytes"):
        wire.split_packet(struct.pack("<HH", 7, 100) + bytes(10))
    message_id, payload = wire.split_packet(struct.pack("<HH", 3, 2) + b"okEXTRA")
    assert (message_id, bytes(payload)) == (3, b"ok")


def test_server_info_and_requests() -> None:
    message_id, payload = wire.split_packet(pack_server_info((4, 1, 0, 0)))
    assert message_id == wire.NAT_SERVERINFO
    info = wire.parse_server_info(payload)
    assert (
        info.application == "Motive"
        and info.natnet_version == (4, 1, 0, 0)
        and info.application_version == (3, 1, 0, 0)
    )
    assert wire.build_request(wire.NAT_KEEPALIVE) == b"\x0a\x00\x00\x00"
    assert wire.build_request(wire.NAT_REQUEST, "FrameRate") == b"\x02\x00\x0a\x00FrameRate\x00"


@pytest.mark.parametrize("text, expected", [("4.1", (4, 1)), ("3.0.0.0", (3, 0)), ("4", (4, 0)), ((3, 1), (3, 1))])
def test_parse_version(text: str, expected: tuple[int, int]) -> None:
    assert wire.parse_version(text) == expected


@pytest.mark.parametrize(
    "text, message", [("2.10", "3.0 to 4.x"), ("four", "major.minor"), ("", "major.minor"), ("4.-1", "major.minor")]
)
def test_parse_version_rejects(text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        wire.parse_version(text)
