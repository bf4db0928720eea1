"""The codec fast paths give exactly what pymavlink gives (decode and the RC override)."""

from __future__ import annotations

import math
import os
import struct

os.environ.setdefault("MAVLINK20", "1")

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.wire.codec import CRC_EXTRA, FrameDecoder, pack_rc_channels_override
from helixd.link.wire.framing import FrameKind, scan_frames, x25_crc

MSG_IDS = sorted(CRC_EXTRA)
HOT = [
    mavlink.MAVLINK_MSG_ID_ATTITUDE,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    mavlink.MAVLINK_MSG_ID_HEARTBEAT,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS,
    mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT,
    mavlink.MAVLINK_MSG_ID_RC_CHANNELS,
    mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,
    mavlink.MAVLINK_MSG_ID_COMMAND_ACK,
    mavlink.MAVLINK_MSG_ID_STATUSTEXT,  # a string: pymavlink's path
    mavlink.MAVLINK_MSG_ID_PARAM_VALUE,
]


def frame(msgid: int, payload: bytes, seq: int, sysid: int, compid: int, compat: int) -> bytes:
    header = struct.pack(
        "<BBBBBBBHB", 0xFD, len(payload), 0, compat, seq, sysid, compid, msgid & 0xFFFF, msgid >> 16
    )
    body = header + payload
    crc = x25_crc(bytes((CRC_EXTRA[msgid],)), x25_crc(body[1:]))
    return body + struct.pack("<H", crc)


def same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


@settings(max_examples=400, deadline=None)
@given(
    msgid=st.one_of(st.sampled_from(HOT), st.sampled_from(MSG_IDS)),
    data=st.data(),
    seq=st.integers(0, 255),
    sysid=st.integers(0, 255),
    compid=st.integers(0, 255),
    compat=st.integers(0, 255),
)
def test_fast_decode_equals_pymavlink(
    msgid: int, data: st.DataObject, seq: int, sysid: int, compid: int, compat: int
) -> None:
    size = mavlink.mavlink_map[msgid].unpacker.size
    payload = data.draw(st.binary(min_size=1, max_size=min(255, size)))
    buf = frame(msgid, payload, seq, sysid, compid, compat)
    ref = mavlink.MAVLink(None, 255, 190).decode(bytearray(buf))
    fast = FrameDecoder(mavlink.MAVLink(None, 255, 190), signing=False).decode(buf)
    assert type(fast) is type(ref)
    assert fast.get_type() == ref.get_type()
    for name in ref.fieldnames:
        assert same(getattr(fast, name), getattr(ref, name)), name
    for attr in ("mlen", "seq", "srcSystem", "srcComponent", "msgId", "incompat_flags"):
        assert getattr(fast._header, attr) == getattr(ref._header, attr), attr
    assert fast._header.compat_flags == ref._header.compat_flags
    assert (fast._crc, bytes(fast._msgbuf), bytes(fast._payload)) == (
        ref._crc,
        bytes(ref._msgbuf),
        bytes(ref._payload),
    )
    assert fast._signed is False


def test_signing_link_always_uses_pymavlink() -> None:
    calls: list[bytearray] = []

    class Spy:
        def decode(self, buf: bytearray) -> str:
            calls.append(buf)
            return "pymavlink"

    buf = frame(mavlink.MAVLINK_MSG_ID_ATTITUDE, bytes(28), 0, 1, 1, 0)
    assert FrameDecoder(Spy(), signing=True).decode(buf) == "pymavlink"
    assert FrameDecoder(Spy(), signing=False).decode(buf) != "pymavlink"
    assert len(calls) == 1


@settings(max_examples=300, deadline=None)
@given(
    values=st.lists(st.integers(0, 65535), min_size=18, max_size=18),
    seq=st.integers(0, 255),
    src=st.tuples(st.integers(0, 255), st.integers(0, 255)),
    target=st.tuples(st.integers(0, 255), st.integers(0, 255)),
)
def test_rc_override_bytes_equal_pymavlink(
    values: list[int], seq: int, src: tuple[int, int], target: tuple[int, int]
) -> None:
    mav = mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    mav.seq = seq
    ref = bytes(mav.rc_channels_override_encode(*target, *values).pack(mav))
    assert pack_rc_channels_override(seq, *src, *target, values) == ref


@settings(max_examples=300, deadline=None)
@given(msgid=st.sampled_from(HOT), data=st.data(), tail=st.binary(max_size=3))
def test_whole_datagram_fast_path_equals_the_full_scan(
    msgid: int, data: st.DataObject, tail: bytes
) -> None:
    size = mavlink.mavlink_map[msgid].unpacker.size
    payload = data.draw(st.binary(min_size=1, max_size=min(255, size)))
    buf = frame(msgid, payload, 1, 1, 1, 0) + tail
    fast = scan_frames(buf, final=True, crc_extra=CRC_EXTRA)
    # the same bytes through the full scan (a stream read that happens to end there)
    full = scan_frames(buf, final=False, crc_extra=CRC_EXTRA)
    assert [f.data for f in fast.frames][:1] == [f.data for f in full.frames][:1]
    assert fast.frames[0].kind is FrameKind.KNOWN and fast.frames[0].msgid == msgid
    if not tail:
        assert (fast.consumed, fast.bad_runs, fast.bad_bytes) == (len(buf), 0, 0)
    # a corrupted CRC is never taken as that frame (the full scan resynchronises inside it)
    bad = bytearray(frame(msgid, payload, 1, 1, 1, 0))
    bad[-1] ^= 0xFF
    frames = scan_frames(bytes(bad), final=True, crc_extra=CRC_EXTRA).frames
    assert all(f.data != bytes(bad) for f in frames)
