"""MAVLink FTP (FILE_TRANSFER_PROTOCOL, message 110): the payload both ends speak.

The message carries one 251-byte ``payload``; MAVLink FTP puts a 12-byte little-endian header
and up to 239 bytes of data in it (ArduPilot ``libraries/GCS_MAVLink/GCS_FTP.cpp``,
``handle_file_transfer_protocol`` / ``send_reply``; pymavlink ``mavftp_op.FTP_OP.pack``)::

    0  seq_number      u16   the reply carries the request's + 1
    2  session         u8
    3  opcode          u8    FtpOp
    4  size            u8    bytes of data that count (≤ 239)
    5  req_opcode      u8    in a reply: the opcode answered
    6  burst_complete  u8
    7  padding         u8
    8  offset          u32
    12 data[239]

:class:`FtpPayload` is one payload, checked when built: :meth:`FtpPayload.unpack` is the edge
where wire bytes become one (it raises only :class:`FtpPayloadError`), :meth:`FtpPayload.pack`
gives the 251 bytes back. :class:`FtpHeader` reads the header alone (any 12 bytes are a header),
for a server that must answer a payload whose ``size`` is out of range. A NAK's data is the
error code (:class:`FtpErr`) and, after ``FailErrno``, the errno byte: :func:`parse_nak`.

Opcodes and error codes are ArduPilot's ``FTP_OP`` / ``FTP_ERROR`` (``GCS_FTP.h``), which are
the MAVLink ``MAV_FTP_OPCODE`` / ``MAV_FTP_ERR`` enums; the values are read from pymavlink's
dialect. :func:`crc32_ardupilot` is the checksum ArduPilot answers CalcFileCRC32 with
(``AP_Filesystem::crc32`` running ``crc_crc32`` of ``AP_Math/crc.cpp`` from 0).
"""

from __future__ import annotations

import errno as _errno
import struct
import zlib
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as _mav

__all__ = [
    "HEADER_LEN",
    "MAX_DATA_LEN",
    "MAX_PATH_LEN",
    "MSG_ID_FILE_TRANSFER_PROTOCOL",
    "PAYLOAD_LEN",
    "FtpErr",
    "FtpHeader",
    "FtpOp",
    "FtpPayload",
    "FtpPayloadError",
    "Nak",
    "crc32_ardupilot",
    "encode_path",
    "from_message",
    "op_name",
    "parse_nak",
    "to_message",
]

MSG_ID_FILE_TRANSFER_PROTOCOL = int(_mav.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL)
HEADER_LEN = 12
MAX_DATA_LEN = 239  # GCS_FTP::Transaction::data
PAYLOAD_LEN = HEADER_LEN + MAX_DATA_LEN  # FILE_TRANSFER_PROTOCOL.payload, uint8_t[251]
# A name is read as a C string whose byte 238 ArduPilot forces to 0 ("ensure the path is null
# terminated"), so 238 bytes is the longest name that arrives whole.
MAX_PATH_LEN = MAX_DATA_LEN - 1

_HEADER = struct.Struct("<HBBBBBBI")  # seq, session, opcode, size, req_opcode, burst, pad, offset
_U8 = 0xFF
_U16 = 0xFFFF
_U32 = 0xFFFF_FFFF


class FtpOp(IntEnum):
    """ArduPilot's ``GCS_FTP::FTP_OP`` (= MAV_FTP_OPCODE); ``None_`` is ArduPilot's ``None``."""

    None_ = int(_mav.MAV_FTP_OPCODE_NONE)
    TerminateSession = int(_mav.MAV_FTP_OPCODE_TERMINATESESSION)
    ResetSessions = int(_mav.MAV_FTP_OPCODE_RESETSESSION)
    ListDirectory = int(_mav.MAV_FTP_OPCODE_LISTDIRECTORY)
    OpenFileRO = int(_mav.MAV_FTP_OPCODE_OPENFILERO)
    ReadFile = int(_mav.MAV_FTP_OPCODE_READFILE)
    CreateFile = int(_mav.MAV_FTP_OPCODE_CREATEFILE)
    WriteFile = int(_mav.MAV_FTP_OPCODE_WRITEFILE)
    RemoveFile = int(_mav.MAV_FTP_OPCODE_REMOVEFILE)
    CreateDirectory = int(_mav.MAV_FTP_OPCODE_CREATEDIRECTORY)
    RemoveDirectory = int(_mav.MAV_FTP_OPCODE_REMOVEDIRECTORY)
    OpenFileWO = int(_mav.MAV_FTP_OPCODE_OPENFILEWO)
    TruncateFile = int(_mav.MAV_FTP_OPCODE_TRUNCATEFILE)
    Rename = int(_mav.MAV_FTP_OPCODE_RENAME)
    CalcFileCRC32 = int(_mav.MAV_FTP_OPCODE_CALCFILECRC)
    BurstReadFile = int(_mav.MAV_FTP_OPCODE_BURSTREADFILE)
    Ack = int(_mav.MAV_FTP_OPCODE_ACK)
    Nack = int(_mav.MAV_FTP_OPCODE_NAK)


class FtpErr(IntEnum):
    """ArduPilot's ``GCS_FTP::FTP_ERROR`` (= MAV_FTP_ERR), the first data byte of a NAK."""

    None_ = int(_mav.MAV_FTP_ERR_NONE)
    Fail = int(_mav.MAV_FTP_ERR_FAIL)
    FailErrno = int(_mav.MAV_FTP_ERR_FAILERRNO)
    InvalidDataSize = int(_mav.MAV_FTP_ERR_INVALIDDATASIZE)
    InvalidSession = int(_mav.MAV_FTP_ERR_INVALIDSESSION)
    NoSessionsAvailable = int(_mav.MAV_FTP_ERR_NOSESSIONSAVAILABLE)
    EndOfFile = int(_mav.MAV_FTP_ERR_EOF)
    UnknownCommand = int(_mav.MAV_FTP_ERR_UNKNOWNCOMMAND)
    FileExists = int(_mav.MAV_FTP_ERR_FILEEXISTS)
    FileProtected = int(_mav.MAV_FTP_ERR_FILEPROTECTED)
    FileNotFound = int(_mav.MAV_FTP_ERR_FILENOTFOUND)


class FtpPayloadError(ValueError):
    """A payload (or a field meant for one) that MAVLink FTP cannot carry."""


def op_name(opcode: int) -> str:
    """'CreateFile' for a known opcode, 'opcode 200' otherwise."""
    try:
        return FtpOp(opcode).name
    except ValueError:
        return f"opcode {opcode}"


def _as_bytes(payload: object) -> bytes:
    if isinstance(payload, bytes):
        return payload
    if isinstance(payload, bytearray | memoryview):
        return bytes(payload)
    raise FtpPayloadError(f"an FTP payload is bytes, not {type(payload).__name__}")


def _padded(payload: object) -> bytes:
    """The 251 payload bytes: a shorter buffer lost trailing zeros (MAVLink 2 truncation)."""
    raw = _as_bytes(payload)
    if len(raw) > PAYLOAD_LEN:
        raise FtpPayloadError(f"FTP payload of {len(raw)} bytes (at most {PAYLOAD_LEN})")
    return raw.ljust(PAYLOAD_LEN, b"\0")


def _check_int(name: str, value: object, top: int) -> None:
    if not isinstance(value, int) or isinstance(value, bool):
        raise FtpPayloadError(f"FTP {name} must be an int, not {type(value).__name__}")
    if not 0 <= value <= top:
        raise FtpPayloadError(f"FTP {name} {value} out of range 0..{top}")


@dataclass(frozen=True, slots=True)
class FtpHeader:
    """The 12-byte header alone; every byte string of ≤ 251 bytes has one."""

    seq_number: int
    session: int
    opcode: int
    size: int
    req_opcode: int
    burst_complete: int
    offset: int

    @classmethod
    def unpack(cls, payload: bytes) -> FtpHeader:
        seq, session, opcode, size, req_opcode, burst, _pad, offset = _HEADER.unpack_from(
            _padded(payload)
        )
        return cls(seq, session, opcode, size, req_opcode, burst, offset)


@dataclass(frozen=True, slots=True)
class FtpPayload:
    """One FTP payload. ``data`` is what counts of the data field: ``len(data) ≤ size ≤ 239``.

    ``size`` may exceed ``len(data)`` in requests that carry a length but no data (ReadFile,
    BurstReadFile: how many bytes to read); the field is zero-padded on the wire.
    """

    seq_number: int
    session: int
    opcode: int
    size: int = 0
    req_opcode: int = 0
    burst_complete: int = 0
    offset: int = 0
    data: bytes = b""

    def __post_init__(self) -> None:
        _check_int("seq_number", self.seq_number, _U16)
        _check_int("session", self.session, _U8)
        _check_int("opcode", self.opcode, _U8)
        _check_int("size", self.size, MAX_DATA_LEN)
        _check_int("req_opcode", self.req_opcode, _U8)
        _check_int("burst_complete", self.burst_complete, _U8)
        _check_int("offset", self.offset, _U32)
        if not isinstance(self.data, bytes):
            raise FtpPayloadError(f"FTP data must be bytes, not {type(self.data).__name__}")
        if len(self.data) > self.size:
            raise FtpPayloadError(f"FTP data of {len(self.data)} bytes but size {self.size}")

    @classmethod
    def request(
        cls,
        opcode: FtpOp,
        seq_number: int,
        session: int,
        *,
        data: bytes = b"",
        offset: int = 0,
        size: int | None = None,
    ) -> FtpPayload:
        """A request; ``size`` defaults to ``len(data)``."""
        return cls(
            seq_number=seq_number,
            session=session,
            opcode=int(opcode),
            size=len(data) if size is None else size,
            offset=offset,
            data=bytes(data),
        )

    @classmethod
    def unpack(cls, payload: bytes) -> FtpPayload:
        """Read wire bytes (≤ 251; fewer: MAVLink 2 cut trailing zeros); raises only
        :class:`FtpPayloadError`, for a non-bytes value, > 251 bytes or size > 239."""
        raw = _padded(payload)
        seq, session, opcode, size, req_opcode, burst, _pad, offset = _HEADER.unpack_from(raw)
        if size > MAX_DATA_LEN:
            raise FtpPayloadError(f"FTP size {size} > {MAX_DATA_LEN}")
        data = raw[HEADER_LEN : HEADER_LEN + size]
        return cls(seq, session, opcode, size, req_opcode, burst, offset, data)

    def pack(self) -> bytes:
        """The 251 payload bytes (padding byte and unused data zero)."""
        head = _HEADER.pack(
            self.seq_number,
            self.session,
            self.opcode,
            self.size,
            self.req_opcode,
            self.burst_complete,
            0,
            self.offset,
        )
        return (head + self.data).ljust(PAYLOAD_LEN, b"\0")

    @property
    def header(self) -> FtpHeader:
        return FtpHeader(
            self.seq_number,
            self.session,
            self.opcode,
            self.size,
            self.req_opcode,
            self.burst_complete,
            self.offset,
        )

    def __str__(self) -> str:
        req = f" req={op_name(self.req_opcode)}" if self.opcode in (FtpOp.Ack, FtpOp.Nack) else ""
        return (
            f"FTP {op_name(self.opcode)}{req} seq={self.seq_number} session={self.session}"
            f" size={self.size} offset={self.offset}"
        )


@dataclass(frozen=True, slots=True)
class Nak:
    """Why the other end said NAK: ``error`` is None when the NAK carried no error byte."""

    error: int | None
    errno: int | None = None

    @property
    def code(self) -> FtpErr | None:
        """The error as :class:`FtpErr`, or None (no byte, or a code ArduPilot does not have)."""
        if self.error is None:
            return None
        try:
            return FtpErr(self.error)
        except ValueError:
            return None

    def __str__(self) -> str:
        if self.error is None:
            return "NAK without an error code"
        code = self.code
        name = code.name if code is not None else f"unknown error {self.error}"
        if self.errno is None:
            return name
        sym = _errno.errorcode.get(self.errno)
        return f"{name} (errno {self.errno}{' ' + sym if sym else ''})"


def parse_nak(reply: FtpPayload) -> Nak:
    """The error of a NAK reply (``GCS_FTP::error``: data[0] the code; after FailErrno a
    size of 2 adds the errno). Raises :class:`FtpPayloadError` if ``reply`` is no NAK."""
    if reply.opcode != FtpOp.Nack:
        raise FtpPayloadError(f"{reply} is not a NAK")
    if reply.size < 1:
        return Nak(None)
    err = reply.data[0]
    if err == FtpErr.FailErrno and reply.size >= 2:
        return Nak(err, reply.data[1])
    return Nak(err)


def encode_path(path: str) -> bytes:
    """A remote path as FTP request data: ASCII, no NUL, 1..238 bytes (ArduPilot cuts byte 238).

    Raises :class:`FtpPayloadError` naming the path."""
    if not isinstance(path, str) or not path:
        raise FtpPayloadError(f"FTP path {path!r}: must be a non-empty string")
    try:
        raw = path.encode("ascii")
    except UnicodeEncodeError as exc:
        raise FtpPayloadError(f"FTP path {path!r}: only ASCII names are sent") from exc
    if b"\0" in raw:
        raise FtpPayloadError(f"FTP path {path!r}: contains NUL")
    if len(raw) > MAX_PATH_LEN:
        raise FtpPayloadError(f"FTP path {path!r}: {len(raw)} bytes (at most {MAX_PATH_LEN})")
    return raw


def crc32_ardupilot(data: bytes, crc: int = 0) -> int:
    """ArduPilot's ``crc_crc32(crc, buf, size)`` (AP_Math/crc.cpp): the reflected 0xEDB88320
    table CRC without the usual pre/post inversion; CalcFileCRC32 starts it from 0.

    zlib's crc32 inverts on entry and exit, so crc_crc32(c, d) = ~zlib.crc32(d, ~c)."""
    if not 0 <= crc <= _U32:
        raise FtpPayloadError(f"CRC32 start value {crc} out of range")
    return zlib.crc32(bytes(data), crc ^ _U32) ^ _U32


_codec = _mav.MAVLink(None)


def to_message(payload: FtpPayload, target_system: int, target_component: int) -> Any:
    """A pymavlink FILE_TRANSFER_PROTOCOL message carrying ``payload`` (target_network 0)."""
    _check_int("target_system", target_system, _U8)
    _check_int("target_component", target_component, _U8)
    return _codec.file_transfer_protocol_encode(0, target_system, target_component, payload.pack())


def from_message(msg: Any) -> bytes:
    """The payload bytes of a received FILE_TRANSFER_PROTOCOL message (pymavlink gives a list
    of 251 ints). Raises :class:`FtpPayloadError` for anything else."""
    try:
        kind = msg.get_type()
        raw = msg.payload
    except AttributeError as exc:
        raise FtpPayloadError("not a FILE_TRANSFER_PROTOCOL message") from exc
    if kind != "FILE_TRANSFER_PROTOCOL":
        raise FtpPayloadError(f"{kind} is not FILE_TRANSFER_PROTOCOL")
    if isinstance(raw, bytes | bytearray):
        out = bytes(raw)
    else:
        if not isinstance(raw, list | tuple) or not all(
            type(b) is int and 0 <= b <= _U8 for b in raw
        ):
            raise FtpPayloadError("FILE_TRANSFER_PROTOCOL payload is not a list of bytes")
        out = bytes(raw)
    if len(out) > PAYLOAD_LEN:
        raise FtpPayloadError(f"FTP payload of {len(out)} bytes (at most {PAYLOAD_LEN})")
    return out
