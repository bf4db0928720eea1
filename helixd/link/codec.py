"""MAVLink 2 codec fast paths: decode a frame already framed and CRC-checked, encode the
RC override without building a pymavlink message object.

:func:`helixd.link.framing.scan_frames` has already checked the frame's CRC (with the
message's CRC_EXTRA) before anything here runs; pymavlink's ``decode`` would parse the header
and compute the CRC a second time and then build the message the same way this does. For an
*unsigned* frame of a message without arrays or strings (every stream the daemon flies on:
ATTITUDE, LOCAL_POSITION_NED, HEARTBEAT, SYS_STATUS, EKF_STATUS_REPORT, RC_CHANNELS,
SERVO_OUTPUT_RAW, COMMAND_ACK, ...), :class:`FrameDecoder` unpacks the payload into the very
pymavlink message class pymavlink would return, with the same fields and header. Anything
else (signed frames, arrays, strings, MAVLink 1) goes to pymavlink's own ``decode``; the
tests check both give the same message for arbitrary payloads.

:func:`pack_rc_channels_override` writes the same bytes as pymavlink's
``rc_channels_override_encode(...).pack(mav)`` for an unsigned link (MAVLink 2 trailing-zero
truncation included); a signing link uses pymavlink.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.framing import x25_crc

MavMsg = Any

MARKER_V2 = 0xFD
HEADER_V2_BYTES = 10
CRC_EXTRA: dict[int, int] = {
    int(msgid): int(cls.crc_extra) for msgid, cls in mavlink.mavlink_map.items()
}

_HEADER_V2 = struct.Struct("<BBBBBBBHB")
_CRC = struct.Struct("<H")


class _Plain:
    """How to build one message type from its payload (no arrays, no strings)."""

    __slots__ = ("cls", "order", "size", "unpack")

    def __init__(self, cls: Any) -> None:
        self.cls = cls
        self.unpack = cls.unpacker.unpack
        self.size = int(cls.unpacker.size)
        self.order = tuple(int(i) for i in cls.orders)


def _plain_entry(cls: Any) -> _Plain | None:
    lengths = list(cls.lengths)
    fmt = str(cls.unpacker.format)
    if sum(lengths) != len(lengths) or "s" in fmt or "c" in fmt:
        return None  # arrays or strings: pymavlink's decode handles them
    return _Plain(cls)


_PLAIN: dict[int, _Plain | None] = {
    int(msgid): _plain_entry(cls) for msgid, cls in mavlink.mavlink_map.items()
}


class FrameDecoder:
    """Decode one framed, CRC-checked frame: fast for plain unsigned MAVLink 2 messages,
    pymavlink's ``mav.decode`` for everything else (and always when signing is on)."""

    def __init__(self, mav: Any, signing: bool) -> None:
        self._mav = mav
        self._fast = not signing

    def decode(self, data: bytes) -> MavMsg:
        """The message; raises what ``mav.decode`` raises for frames it rejects."""
        if self._fast and data[0] == MARKER_V2 and data[2] == 0:
            msgid = data[7] | (data[8] << 8) | (data[9] << 16)
            entry = _PLAIN.get(msgid)
            plen = data[1]
            if entry is not None and len(data) == HEADER_V2_BYTES + plen + 2:
                return _decode_plain(entry, data, msgid, plen)
        return self._mav.decode(bytearray(data))


def _decode_plain(entry: _Plain, data: bytes, msgid: int, plen: int) -> MavMsg:
    payload = data[HEADER_V2_BYTES : HEADER_V2_BYTES + plen]
    size = entry.size
    if plen < size:
        payload += bytes(size - plen)  # MAVLink 2 trailing-zero truncation
    t = entry.unpack(payload[:size])
    m = entry.cls(*[t[i] for i in entry.order])
    msgbuf = bytearray(data)
    m._signed = False
    m._msgbuf = msgbuf
    m._payload = msgbuf[6:-2]  # as pymavlink (it slices from 6 for both versions)
    m._crc = data[-2] | (data[-1] << 8)
    m._header = mavlink.MAVLink_header(msgid, 0, data[3], plen, data[4], data[5], data[6])
    return m


_RC_OVERRIDE_ID = int(mavlink.MAVLINK_MSG_ID_RC_CHANNELS_OVERRIDE)
_RC_OVERRIDE_EXTRA = bytes((CRC_EXTRA[_RC_OVERRIDE_ID],))
_RC_OVERRIDE_PAYLOAD = struct.Struct("<8HBB10H")  # wire order: chan1..8, target, chan9..18


def pack_rc_channels_override(
    seq: int,
    src_system: int,
    src_component: int,
    target_system: int,
    target_component: int,
    channels_us: Sequence[int],
) -> bytes:
    """An unsigned MAVLink 2 RC_CHANNELS_OVERRIDE frame with 18 channel values (checked by the
    caller: 0..65535), byte for byte what pymavlink packs."""
    payload = _RC_OVERRIDE_PAYLOAD.pack(
        *channels_us[:8], target_system, target_component, *channels_us[8:18]
    )
    plen = len(payload)
    while plen > 1 and payload[plen - 1] == 0:
        plen -= 1
    body = (
        _HEADER_V2.pack(
            MARKER_V2,
            plen,
            0,
            0,
            seq,
            src_system,
            src_component,
            _RC_OVERRIDE_ID & 0xFFFF,
            _RC_OVERRIDE_ID >> 16,
        )
        + payload[:plen]
    )
    crc = x25_crc(_RC_OVERRIDE_EXTRA, x25_crc(body[1:]))
    return body + _CRC.pack(crc)
