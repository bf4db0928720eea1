"""helixd.mav.ftp_wire: the MAVLink FTP payload layout, its checks, NAK decoding and ArduPilot's
CRC."""

from __future__ import annotations

import struct
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as hs
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav import ftp_wire
from helixd.mav.ftp_wire import (
    MAX_DATA_LEN,
    PAYLOAD_LEN,
    FtpErr,
    FtpHeader,
    FtpOp,
    FtpPayload,
    FtpPayloadError,
    Nak,
    crc32_ardupilot,
    encode_path,
    from_message,
    parse_nak,
    to_message,
)


def _table() -> list[int]:
    table = []
    for n in range(256):
        c = n
        for _ in range(8):
            c = (c >> 1) ^ 0xEDB88320 if c & 1 else c >> 1
        table.append(c)
    return table


CRC32_TAB = _table()


def crc_crc32(crc: int, buf: bytes) -> int:
    """AP_Math/crc.cpp crc_crc32, transcribed: table lookup, no inversion on entry or exit."""
    for b in buf:
        crc = CRC32_TAB[(crc ^ b) & 0xFF] ^ (crc >> 8)
    return crc


u8 = hs.integers(0, 255)


@hs.composite
def payloads(draw: hs.DrawFn) -> FtpPayload:
    data = draw(hs.binary(max_size=MAX_DATA_LEN))
    return FtpPayload(
        seq_number=draw(hs.integers(0, 0xFFFF)),
        session=draw(u8),
        opcode=draw(u8),
        size=draw(hs.integers(len(data), MAX_DATA_LEN)),
        req_opcode=draw(u8),
        burst_complete=draw(u8),
        offset=draw(hs.integers(0, 0xFFFF_FFFF)),
        data=data,
    )


def test_enums_are_the_mavlink_ones_ardupilot_uses() -> None:
    # GCS_FTP.h: FTP_OP / FTP_ERROR are defined as MAV_FTP_OPCODE_* / MAV_FTP_ERR_*
    assert [int(o) for o in FtpOp] == [*range(16), 128, 129]
    assert FtpOp.CalcFileCRC32 == mavlink.MAV_FTP_OPCODE_CALCFILECRC == 14
    assert FtpOp.Nack == mavlink.MAV_FTP_OPCODE_NAK == 129
    assert [int(e) for e in FtpErr] == list(range(11))
    assert FtpErr.EndOfFile == mavlink.MAV_FTP_ERR_EOF == 6
    assert int(FtpErr.FileNotFound) == 10
    assert ftp_wire.MSG_ID_FILE_TRANSFER_PROTOCOL == 110


def test_pack_layout_is_little_endian_with_a_zero_padding_byte() -> None:
    p = FtpPayload(
        seq_number=0x1234,
        session=7,
        opcode=FtpOp.WriteFile,
        size=3,
        req_opcode=9,
        burst_complete=1,
        offset=0xA1B2C3D4,
        data=b"abc",
    )
    raw = p.pack()
    assert len(raw) == PAYLOAD_LEN == 251
    assert raw[:12] == bytes([0x34, 0x12, 7, 7, 3, 9, 1, 0, 0xD4, 0xC3, 0xB2, 0xA1])
    assert raw[12:15] == b"abc"
    assert raw[15:] == bytes(251 - 15)


@given(payloads())
def test_round_trip(p: FtpPayload) -> None:
    raw = p.pack()
    back = FtpPayload.unpack(raw)
    # the data field is zero-padded on the wire: what comes back is ``size`` bytes of it
    assert back == FtpPayload(
        p.seq_number,
        p.session,
        p.opcode,
        p.size,
        p.req_opcode,
        p.burst_complete,
        p.offset,
        p.data.ljust(p.size, b"\0"),
    )
    assert back.pack() == raw
    assert FtpHeader.unpack(raw) == p.header
    # MAVLink 2 drops trailing zero bytes of a message: the payload means the same
    assert FtpPayload.unpack(raw.rstrip(b"\0")) == back


def test_size_out_of_range_is_refused_at_the_edge() -> None:
    raw = bytearray(FtpPayload(1, 0, FtpOp.WriteFile).pack())
    raw[4] = 240
    with pytest.raises(FtpPayloadError, match="size 240"):
        FtpPayload.unpack(bytes(raw))
    assert FtpHeader.unpack(bytes(raw)).size == 240  # the header alone is still readable
    with pytest.raises(FtpPayloadError, match="252 bytes"):
        FtpPayload.unpack(bytes(252))
    with pytest.raises(FtpPayloadError):
        FtpPayload.unpack("not bytes")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "kwargs",
    [
        {"size": 240, "data": b""},
        {"size": 2, "data": b"abc"},
        {"seq_number": 0x10000},
        {"session": -1},
        {"opcode": 256},
        {"offset": 1 << 32},
        {"burst_complete": True},
        {"data": "text"},
    ],
)
def test_constructor_checks(kwargs: dict[str, Any]) -> None:
    fields: dict[str, Any] = {"seq_number": 0, "session": 0, "opcode": 0, "size": 3}
    fields["data"] = b"abc"
    fields.update(kwargs)
    with pytest.raises(FtpPayloadError):
        FtpPayload(**fields)


def test_request_sizes_from_its_data_or_as_given() -> None:
    w = FtpPayload.request(FtpOp.WriteFile, 5, 2, data=b"hello", offset=10)
    assert (w.size, w.opcode, w.offset, w.req_opcode) == (5, FtpOp.WriteFile, 10, 0)
    r = FtpPayload.request(FtpOp.ReadFile, 6, 2, size=239)
    assert (r.size, r.data) == (239, b"")
    assert "ReadFile" in str(r)


@given(hs.binary(max_size=300))
def test_hostile_bytes_raise_only_the_module_error(raw: bytes) -> None:
    try:
        p = FtpPayload.unpack(raw)
    except FtpPayloadError:
        assert len(raw) > PAYLOAD_LEN or raw.ljust(12, b"\0")[4] > MAX_DATA_LEN
        return
    assert len(p.data) == p.size <= MAX_DATA_LEN
    # packing gives the same bytes, but for the padding byte and the data past ``size``
    expected = bytearray(raw.ljust(PAYLOAD_LEN, b"\0"))
    expected[7] = 0
    expected[12 + p.size :] = bytes(PAYLOAD_LEN - 12 - p.size)
    assert p.pack() == bytes(expected)
    if p.opcode == FtpOp.Nack:
        str(parse_nak(p))  # never raises for a NAK


@given(hs.binary(max_size=300))
def test_hostile_header_never_raises_but_the_module_error(raw: bytes) -> None:
    try:
        h = FtpHeader.unpack(raw)
    except FtpPayloadError:
        assert len(raw) > PAYLOAD_LEN
        return
    assert 0 <= h.offset <= 0xFFFF_FFFF


def test_parse_nak() -> None:
    def nak(*data: int) -> FtpPayload:
        return FtpPayload(1, 0, FtpOp.Nack, size=len(data), data=bytes(data))

    assert parse_nak(nak(10)) == Nak(FtpErr.FileNotFound)
    assert parse_nak(nak(2, 13)) == Nak(FtpErr.FailErrno, 13)
    assert str(parse_nak(nak(2, 13))) == "FailErrno (errno 13 EACCES)"
    assert str(parse_nak(nak(2))) == "FailErrno"
    assert parse_nak(nak(8, 99)) == Nak(FtpErr.FileExists)  # errno only after FailErrno
    assert str(parse_nak(nak())) == "NAK without an error code"
    assert parse_nak(nak(77)).code is None
    assert str(parse_nak(nak(77))) == "unknown error 77"
    with pytest.raises(FtpPayloadError):
        parse_nak(FtpPayload(1, 0, FtpOp.Ack))


def test_encode_path() -> None:
    assert encode_path("/APM/scripts/helixd-guard.lua") == b"/APM/scripts/helixd-guard.lua"
    assert len(encode_path("a" * 238)) == 238
    for bad in ("", "a" * 239, "/APM/é.lua", "a\0b"):
        with pytest.raises(FtpPayloadError, match="FTP path"):
            encode_path(bad)


def test_crc32_is_ardupilots_crc_crc32_from_zero() -> None:
    assert crc32_ardupilot(b"") == 0
    assert crc32_ardupilot(b"123456789") == crc_crc32(0, b"123456789") == 0x2DFD2D88
    # not zlib's CRC-32 (0xCBF43926): crc_crc32 neither inverts on entry nor on exit
    assert crc32_ardupilot(b"123456789") != 0xCBF43926
    with pytest.raises(FtpPayloadError):
        crc32_ardupilot(b"x", -1)


@given(hs.binary(max_size=600), hs.binary(max_size=600), hs.integers(0, 0xFFFF_FFFF))
def test_crc32_matches_the_table_code_and_chains(a: bytes, b: bytes, start: int) -> None:
    assert crc32_ardupilot(a, start) == crc_crc32(start, a)
    # AP_Filesystem::crc32 feeds the file in 64-byte reads: chaining is the same CRC
    assert crc32_ardupilot(b, crc32_ardupilot(a)) == crc32_ardupilot(a + b)


def test_message_round_trip_through_mavlink() -> None:
    p = FtpPayload.request(FtpOp.CreateFile, 3, 1, data=b"/APM/x.lua")
    msg = to_message(p, 1, 1)
    wire = msg.pack(mavlink.MAVLink(None, srcSystem=255, srcComponent=190))
    got = mavlink.MAVLink(None).decode(bytearray(wire))
    assert (got.target_system, got.target_component, got.target_network) == (1, 1, 0)
    assert FtpPayload.unpack(from_message(got)) == p
    with pytest.raises(FtpPayloadError):
        to_message(p, 256, 1)


class _Fake:
    def __init__(self, kind: str, payload: object) -> None:
        self.kind, self.payload = kind, payload

    def get_type(self) -> str:
        return self.kind


@pytest.mark.parametrize(
    "msg",
    [
        object(),
        _Fake("HEARTBEAT", [0] * 251),
        _Fake("FILE_TRANSFER_PROTOCOL", [0] * 252),
        _Fake("FILE_TRANSFER_PROTOCOL", [256] + [0] * 250),
        _Fake("FILE_TRANSFER_PROTOCOL", "text"),
        _Fake("FILE_TRANSFER_PROTOCOL", [1.5]),
    ],
)
def test_from_message_refuses_what_is_no_payload(msg: object) -> None:
    with pytest.raises(FtpPayloadError):
        from_message(msg)


def test_from_message_accepts_bytes_and_int_lists() -> None:
    raw = FtpPayload(9, 1, FtpOp.Ack).pack()
    assert from_message(_Fake("FILE_TRANSFER_PROTOCOL", list(raw))) == raw
    assert from_message(_Fake("FILE_TRANSFER_PROTOCOL", raw)) == raw
    assert struct.unpack_from("<H", raw)[0] == 9
