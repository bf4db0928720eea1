"""The frame scanner (pure): valid frames survive any garbage around them."""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.wire.codec import CRC_EXTRA
from helixd.link.wire.framing import (
    MAX_FRAME_BYTES,
    FrameKind,
    _x25_crc_table,
    scan_frames,
    whole_frame_msgid,
    x25_crc,
)


def codec(sysid: int = 1) -> Any:
    return mavlink.MAVLink(None, srcSystem=sysid, srcComponent=1)


def attitude(i: int, sysid: int = 1) -> bytes:
    return bytes(codec(sysid).attitude_encode(i, 0.1, 0.2, 0.3, 0.0, 0.0, 0.0).pack(codec(sysid)))


def known(data: bytes, final: bool = True) -> list[bytes]:
    scan = scan_frames(data, final=final, crc_extra=CRC_EXTRA)
    return [f.data for f in scan.frames if f.kind is FrameKind.KNOWN]


def unknown_frame(msgid: int = 0xABCDE, payload: bytes = b"\x01\x02\x03") -> bytes:
    header = bytes((0xFD, len(payload), 0, 0, 7, 1, 1, msgid & 0xFF, (msgid >> 8) & 0xFF))
    header += bytes(((msgid >> 16) & 0xFF,))
    body = header + payload
    crc = x25_crc(body[1:])
    return body + bytes((crc & 0xFF, crc >> 8))


def test_crc_matches_pymavlink() -> None:
    frame = attitude(5)
    assert known(frame) == [frame]
    assert x25_crc(b"123456789") == mavlink.x25crc(b"123456789").crc


def test_bogus_length_does_not_swallow_the_frames_behind_it() -> None:
    frames = [attitude(i) for i in range(10)]
    data = b"\xfd\xff" + b"".join(frames)
    assert known(data) == frames
    # pymavlink's own parser loses them (the reason this module exists)
    parser = codec()
    parser.robust_parsing = True
    got = [m for m in parser.parse_buffer(data) or [] if m.get_type() == "ATTITUDE"]
    assert len(got) < len(frames)


def test_bad_crc_costs_only_its_marker() -> None:
    good = [attitude(i) for i in range(3)]
    broken = bytearray(attitude(99))
    broken[-1] ^= 0xFF
    data = bytes(broken[:-3]) + good[0] + bytes(broken) + good[1] + good[2]
    scan = scan_frames(data, final=True, crc_extra=CRC_EXTRA)
    assert [f.data for f in scan.frames] == good
    assert scan.bad_runs == 2 and scan.consumed == len(data)


def test_stream_waits_for_an_incomplete_frame_then_resyncs() -> None:
    frames = [attitude(i) for i in range(20)]
    data = b"\xfd\xff\x00" + b"".join(frames)
    first = scan_frames(data[:100], final=False, crc_extra=CRC_EXTRA)
    assert first.frames == [] and first.consumed == 0  # could still be a 255-byte frame
    rest = scan_frames(data, final=False, crc_extra=CRC_EXTRA)
    assert [f.data for f in rest.frames] == frames[: len(rest.frames)]
    assert len(rest.frames) >= 19  # the last may still be waiting behind nothing
    assert len(data) - rest.consumed <= MAX_FRAME_BYTES


def test_unknown_ids_are_counted_as_unknown_not_as_a_system() -> None:
    frame = unknown_frame()
    scan = scan_frames(frame + attitude(1), final=True, crc_extra=CRC_EXTRA)
    assert [f.kind for f in scan.frames] == [FrameKind.UNKNOWN_ID, FrameKind.KNOWN]
    assert scan.frames[0].msgid == 0xABCDE and scan.frames[0].src_system == 1


def test_an_unknown_id_cannot_hide_a_valid_frame() -> None:
    hidden = attitude(3)
    fake = bytes((0xFD, 60, 0, 0, 7, 1, 1, 0xDE, 0xBC, 0x0A))  # unknown id, claims 60 bytes
    data = fake + hidden + b"\x00" * 10
    assert known(data) == [hidden]


garbage = st.one_of(
    st.binary(max_size=64),
    st.just(b"\xfd\xff"),
    st.binary(max_size=40).map(lambda b: b"\xfd" + b),
    st.binary(max_size=40).map(lambda b: b"\xfe" + b),
    st.integers(0, 2**24 - 1).map(lambda i: unknown_frame(i)),
    st.integers(1, 40).map(lambda n: attitude(7)[:n]),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(garbage, st.integers(0, 2**31)), max_size=20), st.booleans())
def test_every_valid_frame_survives_garbage(items: list[tuple[bytes, int]], final: bool) -> None:
    frames = [attitude(i) for _, i in items]
    data = b"".join(g + f for (g, _), f in zip(items, frames, strict=True))
    if not final:  # a stream holds back at most one maximal frame until more bytes arrive
        held = scan_frames(data, final=False, crc_extra=CRC_EXTRA)
        assert len(data) - held.consumed <= MAX_FRAME_BYTES
        data += b"\x00" * MAX_FRAME_BYTES
    got = iter(known(data, final=final))
    # garbage may itself be a CRC-valid frame (hypothesis finds 16-bit collisions), so the
    # real frames must form a subsequence of what was found
    found = sum(1 for f in frames if any(g == f for g in got))
    assert found == len(frames)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600), st.booleans())
def test_scanner_is_total(data: bytes, final: bool) -> None:
    scan = scan_frames(data, final=final, crc_extra=CRC_EXTRA)
    assert 0 <= scan.consumed <= len(data)
    if final:
        assert scan.consumed == len(data)
    assert scan.bad_bytes <= len(data)


@given(st.binary(max_size=300), st.integers(0, 0xFFFF))
def test_fast_crc_equals_the_table(data: bytes, init: int) -> None:
    assert x25_crc(data, init) == _x25_crc_table(data, init)


@settings(max_examples=300)
@given(
    st.integers(0, 2**32 - 1),
    st.lists(st.integers(0, 255), max_size=4),
    st.lists(st.tuples(st.integers(0, 80), st.integers(0, 255)), max_size=3),
    st.integers(1, 255),
)
def test_one_frame_fast_path_agrees_with_the_scan(
    t: int, tail: list[int], flips: list[tuple[int, int]], sysid: int
) -> None:
    """The common datagram's fast path (no ScanResult, no Frame) says what the full scan says:
    its message id (and the source system at byte 5) exactly when the scan finds one whole
    known frame and nothing else; otherwise it declines and the scan decides."""
    data = bytearray(attitude(t % 1000, sysid) + bytes(tail))
    for i, v in flips:
        if i < len(data):
            data[i] = v
    buf = bytes(data)
    msgid = whole_frame_msgid(buf, CRC_EXTRA)
    scan = scan_frames(buf, final=True, crc_extra=CRC_EXTRA)
    whole = (
        len(scan.frames) == 1
        and scan.frames[0].kind is FrameKind.KNOWN
        and scan.frames[0].data == buf
        and scan.bad_runs == 0
    )
    if msgid is not None:
        assert whole
        assert (scan.frames[0].msgid, scan.frames[0].src_system) == (msgid, buf[5])
    elif not tail and not flips:
        raise AssertionError("an untouched single frame must take the fast path")
