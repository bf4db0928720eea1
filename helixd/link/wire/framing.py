"""Find MAVLink frames in received bytes, losing nothing that need not be lost (pure).

pymavlink's parser (even with ``robust_parsing``) trusts the length byte that follows a start
marker: a stray ``0xFD 0xFF`` makes it swallow the next 267+ bytes whole, valid frames
included, and a frame with a bad CRC is dropped together with everything its claimed length
covers. Its state also carries over from one UDP datagram into the next, so a 2-byte garbage
datagram eats the autopilot's following datagram.

:func:`scan_frames` resynchronises byte by byte instead: a candidate frame whose CRC (with the
message's CRC_EXTRA) fails, whose incompatibility flags are unknown, or which is truncated
costs only its start marker; scanning resumes at the next byte, so a valid frame hidden under a
bogus length is still found. A frame with a message id we do not know cannot be CRC-checked;
it is accepted as an *unknown message* only when no CRC-valid known frame starts inside its
span (otherwise it was garbage hiding that frame).

``final=True`` (one UDP datagram: nothing more will follow) treats an incomplete candidate as
garbage; ``final=False`` (TCP / serial) stops at an incomplete candidate and reports how many
bytes were consumed, so the caller keeps the rest for the next read. A stream parse therefore
holds back at most one maximal frame (280 bytes) behind a bogus length, and never drops the
valid frames behind it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

_fast_mcrf4xx: Any
try:  # a dependency of pymavlink; the pure-Python table below is the fallback
    from fastcrc import crc16 as _fastcrc16

    _fast_mcrf4xx = _fastcrc16.mcrf4xx
except ImportError:  # pragma: no cover - fastcrc ships wheels for our platforms
    _fast_mcrf4xx = None

__all__ = [
    "MAX_FRAME_BYTES",
    "Frame",
    "FrameKind",
    "ScanResult",
    "scan_frames",
    "x25_crc",
]

MARKER_V1 = 0xFE
MARKER_V2 = 0xFD
HEADER_V1_BYTES = 6
HEADER_V2_BYTES = 10
CRC_BYTES = 2
SIGNATURE_BYTES = 13
IFLAG_SIGNED = 0x01
MAX_FRAME_BYTES = HEADER_V2_BYTES + 255 + CRC_BYTES + SIGNATURE_BYTES
_MARKER_RE = re.compile(bytes((ord("["), MARKER_V2, MARKER_V1, ord("]"))))


class FrameKind(Enum):
    KNOWN = "known"  # CRC verified against the message's CRC_EXTRA
    UNKNOWN_ID = "unknown_id"  # message id not in the dialect: framing only, no CRC check


@dataclass(frozen=True, slots=True)
class Frame:
    kind: FrameKind
    msgid: int
    src_system: int
    data: bytes  # the whole frame, start marker to CRC (and signature)


@dataclass(slots=True)
class ScanResult:
    frames: list[Frame] = field(default_factory=list)
    consumed: int = 0  # bytes of the input accounted for (frames + garbage)
    bad_runs: int = 0  # contiguous runs of bytes that were not part of any frame
    bad_bytes: int = 0


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
        table.append(crc)
    return tuple(table)


_CRC_TABLE = _crc_table()


def _x25_crc_table(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """MAVLink's CRC-16/MCRF4XX (X.25 polynomial 0x1021 reflected, init 0xFFFF, no xorout),
    table-driven: one lookup per byte (the fallback without fastcrc)."""
    table = _CRC_TABLE
    for byte in data:
        crc = (crc >> 8) ^ table[(crc ^ byte) & 0xFF]
    return crc


def x25_crc(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """MAVLink's CRC-16/MCRF4XX. pymavlink depends on ``fastcrc`` (Rust) and so do we when it is
    there: ~100× faster than the Python table, which keeps a flood of plausible-looking
    garbage (every candidate start marker costs a CRC) from eating the control loop's CPU."""
    if _fast_mcrf4xx is not None:
        return int(_fast_mcrf4xx(bytes(data), crc))
    return _x25_crc_table(data, crc)


@dataclass(frozen=True, slots=True)
class _Header:
    msgid: int
    src_system: int
    header_bytes: int
    payload_bytes: int
    total_bytes: int


def _header(buf: bytes, i: int) -> _Header | None:
    """The header at ``buf[i]`` (a start marker with enough bytes); None if impossible."""
    if buf[i] == MARKER_V2:
        incompat = buf[i + 2]
        if incompat & ~IFLAG_SIGNED:
            return None  # unknown incompatibility flag: MAVLink says drop the frame
        plen = buf[i + 1]
        msgid = buf[i + 7] | (buf[i + 8] << 8) | (buf[i + 9] << 16)
        sig = SIGNATURE_BYTES if incompat & IFLAG_SIGNED else 0
        total = HEADER_V2_BYTES + plen + CRC_BYTES + sig
        return _Header(msgid, buf[i + 5], HEADER_V2_BYTES, plen, total)
    plen = buf[i + 1]
    total = HEADER_V1_BYTES + plen + CRC_BYTES
    return _Header(buf[i + 5], buf[i + 3], HEADER_V1_BYTES, plen, total)


def _crc_ok(buf: bytes, i: int, h: _Header, crc_extra: int) -> bool:
    end = i + h.header_bytes + h.payload_bytes
    crc = x25_crc(memoryview(buf)[i + 1 : end])
    crc = x25_crc(bytes((crc_extra,)), crc)
    return crc == buf[end] | (buf[end + 1] << 8)


def _header_len(marker: int) -> int:
    return HEADER_V2_BYTES if marker == MARKER_V2 else HEADER_V1_BYTES


def _valid_known_at(buf: bytes, i: int, crc_extra: Mapping[int, int]) -> bool:
    """A complete, CRC-valid frame of a known message starts at ``buf[i]``."""
    n = len(buf)
    if buf[i] not in (MARKER_V1, MARKER_V2) or n - i < _header_len(buf[i]):
        return False
    h = _header(buf, i)
    if h is None or n - i < h.total_bytes:
        return False
    extra = crc_extra.get(h.msgid)
    return extra is not None and _crc_ok(buf, i, h, extra)


def whole_frame_msgid(buf: bytes, crc_extra: Mapping[int, int]) -> int | None:
    """The common datagram: exactly one CRC-valid MAVLink 2 frame of a known message, start
    marker at 0 and nothing after it — its message id (the source system is ``buf[5]``), found
    in one step with no object built; None sends the datagram through :func:`scan_frames`,
    which returns the same frame for it."""
    n = len(buf)
    if n < HEADER_V2_BYTES + CRC_BYTES or buf[0] != MARKER_V2:
        return None
    incompat = buf[2]
    if incompat & ~IFLAG_SIGNED:
        return None
    end = HEADER_V2_BYTES + buf[1]
    if n != end + CRC_BYTES + (SIGNATURE_BYTES if incompat & IFLAG_SIGNED else 0):
        return None
    msgid = buf[7] | (buf[8] << 8) | (buf[9] << 16)
    extra = crc_extra.get(msgid)
    if extra is None:
        return None
    crc = x25_crc(bytes((extra,)), x25_crc(buf[1:end]))
    if crc != buf[end] | (buf[end + 1] << 8):
        return None
    return msgid


def scan_frames(
    data: bytes | bytearray, *, final: bool, crc_extra: Mapping[int, int]
) -> ScanResult:
    """Split ``data`` into frames and garbage; see the module docstring.

    ``crc_extra`` maps each known message id to its CRC_EXTRA byte (the dialect's table).
    Total: any byte string in, a :class:`ScanResult` out, never an exception.
    """
    buf = bytes(data)
    n = len(buf)
    if final:
        msgid = whole_frame_msgid(buf, crc_extra)
        if msgid is not None:
            return ScanResult([Frame(FrameKind.KNOWN, msgid, buf[5], buf)], n)
    out = ScanResult()
    i = 0
    bad_from: int | None = None

    def bad_until(j: int) -> None:
        nonlocal bad_from
        if bad_from is not None:
            out.bad_runs += 1
            out.bad_bytes += j - bad_from
            bad_from = None

    while i < n:
        marker = buf[i]
        if marker not in (MARKER_V1, MARKER_V2):
            if bad_from is None:
                bad_from = i
            found = _MARKER_RE.search(buf, i + 1)  # skip to the next start marker (in C)
            i = n if found is None else found.start()
            continue
        if n - i < _header_len(marker):
            if not final:
                break
            bad_from = i if bad_from is None else bad_from
            i += 1
            continue
        h = _header(buf, i)
        if h is None:
            bad_from = i if bad_from is None else bad_from
            i += 1
            continue
        if n - i < h.total_bytes:
            if not final:
                break  # wait for the rest (a bogus length costs a delay, not the frames)
            bad_from = i if bad_from is None else bad_from
            i += 1  # truncated: a real frame may start inside it
            continue
        extra = crc_extra.get(h.msgid)
        if extra is None:
            hidden = next(
                (
                    j
                    for j in range(i + 1, i + h.total_bytes)
                    if buf[j] in (MARKER_V1, MARKER_V2) and _valid_known_at(buf, j, crc_extra)
                ),
                None,
            )
            if hidden is not None:
                bad_from = i if bad_from is None else bad_from
                i = hidden
                continue
            bad_until(i)
            out.frames.append(
                Frame(FrameKind.UNKNOWN_ID, h.msgid, h.src_system, buf[i : i + h.total_bytes])
            )
            i += h.total_bytes
            continue
        if not _crc_ok(buf, i, h, extra):
            bad_from = i if bad_from is None else bad_from
            i += 1
            continue
        bad_until(i)
        out.frames.append(Frame(FrameKind.KNOWN, h.msgid, h.src_system, buf[i : i + h.total_bytes]))
        i += h.total_bytes
    bad_until(i)
    out.consumed = i
    return out
