"""MAVLink FTP client, sans-IO: upload one file to the autopilot (e.g. a Lua script into
``APM/scripts/`` for ``helixd autopilot install-guard``), and ask whether a directory exists.

:class:`FtpUpload` and :class:`DirectoryProbe` are state machines over FTP payloads
(:mod:`helixd.mav.ftp_wire`) sharing one request machinery: ``start(now_s)``,
``on_reply(payload, now_s)`` and ``on_time(now_s)`` return the request payloads to send, each
to go out as a FILE_TRANSFER_PROTOCOL message to the autopilot (``helixd.mav.ftp_wire.to_message``).
``done`` says it ended, ``error`` why it failed (None: success), ``deadline_s`` when
``on_time`` is due next. They read no clock, do no I/O and log nothing; :func:`run_ftp` is the
thin async shell over an :class:`FtpLink` (``helixd.link.services.ftp_link`` adapts the Autopilot).

A :class:`DirectoryProbe` sends ListDirectory of its path at offset 0: an ACK (entries) or an
EndOfFile NAK (an empty directory) means it exists, a FileNotFound NAK that it does not
(``GCS_FTP::Session::list_dir``: opendir's ENOENT); then TerminateSession frees the slot.

The exchange (ArduPilot ``GCS_FTP.cpp``; pymavlink's ``mavftp`` ``put`` sends the same
CreateFile, WriteFile…, TerminateSession core):

1. ResetSessions (closes whatever this GCS left open; ArduPilot always ACKs it).
2. CreateFile (O_TRUNC). If ArduPilot answers FileNotFound (ENOENT: a directory is missing)
   and ``create_dirs``: CreateDirectory of each parent, top down, a FileExists NAK being fine,
   then CreateFile once more.
3. WriteFile of ``chunk_len`` (≤ 239) bytes at offsets 0, chunk_len, … each ACK echoing it.
4. TerminateSession: ArduPilot closes the file (on the autopilot's FAT card the size is only
   written at close).
5. With ``verify_crc``: CalcFileCRC32 of the path, compared with :func:`crc32_ardupilot` of
   the bytes sent, then TerminateSession again to free the session slot.

One request is outstanding at a time. A reply counts only if it is an ACK/NAK of that request
(req_opcode, seq_number + 1, and for WriteFile the offset): duplicates and stale replies are
ignored. Without one for ``reply_timeout_s`` the request is sent again unchanged (same seq
number, so ArduPilot answers a request it already ran with its last reply instead of running
it twice), at most ``retries`` times in a row. A NoSessionsAvailable NAK is waited out the
same way (ArduPilot frees a slot idle for 3 s). Any other NAK ends the upload with an
:class:`FtpTransferError` naming the path, the operation and ArduPilot's error (with its errno
after FailErrno), and a last TerminateSession is sent, unanswered, so no file stays open.

Sessions: ArduPilot 4.7 keeps a slot per (sender, link, session number); a request whose
session matches no slot claims one, and one with session 0 gets a fresh session id, which its
reply carries. The client sends ``session`` (default 1, not 0) from the start, so a repeat of
its first request finds the slot that request claimed and gets the kept reply (with session 0
the repeat would claim another slot, and on a one-slot server wait 3 s for it). It still takes
the session number from every accepted reply, so a server that assigns one is followed.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from enum import Enum
from typing import Protocol, TypeVar

from helixd.base.clock import now_s
from helixd.link.services.inbox import drive
from helixd.mav.ftp_wire import (
    MAX_DATA_LEN,
    FtpErr,
    FtpOp,
    FtpPayload,
    FtpPayloadError,
    Nak,
    crc32_ardupilot,
    encode_path,
    parse_nak,
)

__all__ = [
    "DEFAULT_REPLY_TIMEOUT_S",
    "DEFAULT_RETRIES",
    "DirectoryProbe",
    "FtpExchange",
    "FtpLink",
    "FtpTransferError",
    "FtpUpload",
    "run_ftp",
]

DEFAULT_REPLY_TIMEOUT_S = 0.5  # pymavlink mavftp retry_time
DEFAULT_RETRIES = 10  # 5 s at the default timeout: longer than ArduPilot's 3 s session timeout
_MAX_FILE_BYTES = 0xFFFF_FFFF  # offsets are u32


class FtpTransferError(Exception):
    """Why an FTP transfer failed: ``path``, the operation ``op`` that failed, the autopilot's
    NAK (``nak``; None for a timeout or a local check) and whether the autopilot stopped
    answering (``timed_out``: a link problem rather than a refusal)."""

    def __init__(
        self,
        message: str,
        *,
        path: str,
        op: FtpOp | None = None,
        nak: Nak | None = None,
        timed_out: bool = False,
    ) -> None:
        super().__init__(message)
        self.path = path
        self.op = op
        self.nak = nak
        self.timed_out = timed_out


class _Stage(Enum):
    RESET = "reset"
    CREATE = "create"
    MKDIR = "mkdir"
    WRITE = "write"
    CLOSE = "close"
    CRC = "crc"
    RELEASE = "release"


def _parents(path: str) -> list[str]:
    """'/APM/scripts/x.lua' → ['/APM', '/APM/scripts']."""
    parts = [p for p in path.split("/") if p]
    lead = "/" if path.startswith("/") else ""
    return [lead + "/".join(parts[:i]) for i in range(1, len(parts))]


class FtpExchange:
    """The request machinery :class:`FtpUpload` and :class:`DirectoryProbe` share: one request
    outstanding, replies matched to it, sent again on a timeout, failures named by ``path``.

    ``what`` names the exchange in errors ("upload", "listing").
    """

    what = "exchange"

    def __init__(
        self,
        path: str,
        *,
        reply_timeout_s: float = DEFAULT_REPLY_TIMEOUT_S,
        retries: int = DEFAULT_RETRIES,
        session: int = 1,
    ) -> None:
        try:
            self._path_bytes = encode_path(path)
        except FtpPayloadError as exc:
            raise ValueError(str(exc)) from exc
        if not (isinstance(reply_timeout_s, int | float) and math.isfinite(reply_timeout_s)):
            raise ValueError("reply_timeout_s must be a finite number")
        if reply_timeout_s <= 0.0:
            raise ValueError("reply_timeout_s must be > 0")
        if not isinstance(retries, int) or retries < 0:
            raise ValueError("retries must be an int >= 0")
        if not isinstance(session, int) or not 0 <= session <= 255:
            raise ValueError("session must be 0..255 (0: let ArduPilot 4.7 assign one)")
        self.path = path
        self.reply_timeout_s = float(reply_timeout_s)
        self.retries = retries

        self.done = False
        self.error: FtpTransferError | None = None
        self.deadline_s = math.inf
        self.resends = 0  # requests sent again on timeout (for tests and logs)
        self._seq = 0
        self._session = session
        self._pending: FtpPayload | None = None
        self._tries = 0
        self._last_nak: Nak | None = None
        self._started = False  # a session may hold something open: release on failure

    # --- driving --------------------------------------------------------------------------

    def start(self, now_s: float) -> list[bytes]:
        """The first request."""
        if self._pending is not None or self.done:
            return []
        return self._first(now_s)

    def on_reply(self, payload: bytes, now_s: float) -> list[bytes]:
        """A received FILE_TRANSFER_PROTOCOL payload from the autopilot."""
        pending = self._pending
        if self.done or pending is None:
            return []
        try:
            reply = FtpPayload.unpack(payload)
        except FtpPayloadError:
            return []
        if reply.opcode not in (FtpOp.Ack, FtpOp.Nack):
            return []
        if reply.req_opcode != pending.opcode:
            return []
        if reply.seq_number != (pending.seq_number + 1) & 0xFFFF:
            return []
        if (
            reply.opcode == FtpOp.Ack
            and pending.opcode == FtpOp.WriteFile
            and reply.offset != pending.offset
        ):
            return []
        nak = parse_nak(reply) if reply.opcode == FtpOp.Nack else None
        if nak is not None and nak.error == FtpErr.NoSessionsAvailable:
            self._last_nak = nak
            return []  # sent again at the deadline, as after a lost reply
        self._session = reply.session
        self._pending = None
        self._last_nak = None
        return self._advance(pending, reply, nak, now_s)

    def on_time(self, now_s: float) -> list[bytes]:
        """Send the outstanding request again if its reply is overdue; give up after
        ``retries`` times in a row."""
        pending = self._pending
        if self.done or pending is None or now_s < self.deadline_s:
            return []
        if self._tries >= self.retries:
            last = f" (last answer: {self._last_nak})" if self._last_nak is not None else ""
            return self._fail(
                f"no reply to {self._what(pending)} after {self._tries} retries{last}",
                FtpOp(pending.opcode),
                self._last_nak,
                timed_out=True,
            )
        self._tries += 1
        self.resends += 1
        self.deadline_s = now_s + self.reply_timeout_s
        return [pending.pack()]

    # --- for the exchanges ----------------------------------------------------------------

    def _first(self, now_s: float) -> list[bytes]:
        raise NotImplementedError

    def _advance(
        self, sent: FtpPayload, reply: FtpPayload, nak: Nak | None, now_s: float
    ) -> list[bytes]:
        raise NotImplementedError

    def _send(self, op: FtpOp, now_s: float, *, data: bytes = b"", offset: int = 0) -> list[bytes]:
        request = FtpPayload.request(op, self._seq, self._session, data=data, offset=offset)
        self._seq = (self._seq + 1) & 0xFFFF
        self._pending = request
        self._tries = 0
        self.deadline_s = now_s + self.reply_timeout_s
        return [request.pack()]

    def _what(self, request: FtpPayload) -> str:
        op = FtpOp(request.opcode)
        if op == FtpOp.WriteFile:
            return f"WriteFile at offset {request.offset}"
        if op == FtpOp.CreateDirectory:
            return f"CreateDirectory {request.data.decode('ascii')}"
        return op.name

    def _refused(self, sent: FtpPayload, nak: Nak) -> list[bytes]:
        return self._fail(f"{self._what(sent)} refused: {nak}", FtpOp(sent.opcode), nak)

    def _fail(
        self,
        reason: str,
        op: FtpOp | None,
        nak: Nak | None,
        *,
        release: bool = True,
        timed_out: bool = False,
    ) -> list[bytes]:
        self.error = FtpTransferError(
            f"FTP {self.what} of {self.path}: {reason}",
            path=self.path,
            op=op,
            nak=nak,
            timed_out=timed_out,
        )
        out: list[bytes] = []
        if release and self._started:
            # best effort, unanswered: close what this session may hold open
            out = self._send(FtpOp.TerminateSession, 0.0)
        self._finish()
        return out

    def _succeed(self) -> list[bytes]:
        self._finish()
        return []

    def _finish(self) -> None:
        self.done = True
        self._pending = None
        self.deadline_s = math.inf


class FtpUpload(FtpExchange):
    """Write ``data`` to ``path`` on the autopilot (replacing any file there)."""

    what = "upload"

    def __init__(
        self,
        path: str,
        data: bytes,
        *,
        reply_timeout_s: float = DEFAULT_REPLY_TIMEOUT_S,
        retries: int = DEFAULT_RETRIES,
        create_dirs: bool = True,
        verify_crc: bool = True,
        chunk_len: int = MAX_DATA_LEN,
        session: int = 1,
    ) -> None:
        super().__init__(path, reply_timeout_s=reply_timeout_s, retries=retries, session=session)
        if path.endswith("/"):
            raise ValueError(f"FTP path {path!r}: names a directory, not a file")
        if not isinstance(data, bytes | bytearray):
            raise ValueError(f"FTP upload of {path}: data must be bytes")
        if len(data) > _MAX_FILE_BYTES:
            raise ValueError(f"FTP upload of {path}: {len(data)} bytes do not fit u32 offsets")
        if not isinstance(chunk_len, int) or not 1 <= chunk_len <= MAX_DATA_LEN:
            raise ValueError(f"chunk_len must be 1..{MAX_DATA_LEN}")
        self.data = bytes(data)
        self.create_dirs = create_dirs
        self.verify_crc = verify_crc
        self.chunk_len = chunk_len
        self.local_crc32 = crc32_ardupilot(self.data)
        self.remote_crc32: int | None = None  # what CalcFileCRC32 answered
        self.bytes_acked = 0  # file bytes the autopilot acknowledged
        self._stage = _Stage.RESET
        self._dirs: list[str] = []
        self._dirs_tried = False
        self._mismatch: str | None = None

    def _first(self, now_s: float) -> list[bytes]:
        """ResetSessions."""
        return self._send(FtpOp.ResetSessions, now_s)

    # --- the exchange ---------------------------------------------------------------------

    def _advance(
        self, sent: FtpPayload, reply: FtpPayload, nak: Nak | None, now_s: float
    ) -> list[bytes]:
        op = FtpOp(sent.opcode)
        stage = self._stage
        if stage is _Stage.MKDIR:
            if nak is not None and nak.error != FtpErr.FileExists:
                return self._refused(sent, nak)
            self._dirs.pop(0)
            if self._dirs:
                return self._send(FtpOp.CreateDirectory, now_s, data=self._dirs[0].encode())
            self._stage = _Stage.CREATE
            return self._send(FtpOp.CreateFile, now_s, data=self._path_bytes)
        if stage is _Stage.RELEASE:
            if self._mismatch is not None:
                return self._fail(self._mismatch, FtpOp.CalcFileCRC32, None, release=False)
            return self._succeed()
        if nak is not None:
            if stage is _Stage.CREATE and nak.error == FtpErr.FileNotFound:
                self._dirs = _parents(self.path) if self.create_dirs else []
                if self._dirs and not self._dirs_tried:
                    self._dirs_tried = True
                    self._stage = _Stage.MKDIR
                    return self._send(FtpOp.CreateDirectory, now_s, data=self._dirs[0].encode())
            return self._refused(sent, nak)
        if stage is _Stage.RESET:
            self._stage = _Stage.CREATE
            self._started = True
            return self._send(FtpOp.CreateFile, now_s, data=self._path_bytes)
        if stage is _Stage.CREATE or stage is _Stage.WRITE:
            if stage is _Stage.WRITE:
                self.bytes_acked = sent.offset + sent.size
            self._stage = _Stage.WRITE
            if self.bytes_acked < len(self.data):
                return self._send_write(now_s)
            self._stage = _Stage.CLOSE
            return self._send(FtpOp.TerminateSession, now_s)
        if stage is _Stage.CLOSE:
            if not self.verify_crc:
                return self._succeed()
            self._stage = _Stage.CRC
            return self._send(FtpOp.CalcFileCRC32, now_s, data=self._path_bytes)
        # _Stage.CRC
        if reply.size < 4:
            return self._fail(f"{op.name} answered without a checksum", op, None)
        (self.remote_crc32,) = struct.unpack_from("<I", reply.data)
        if self.remote_crc32 != self.local_crc32:
            self._mismatch = (
                f"CRC32 mismatch after writing {len(self.data)} bytes: autopilot "
                f"0x{self.remote_crc32:08x}, sent 0x{self.local_crc32:08x}"
            )
        self._stage = _Stage.RELEASE
        return self._send(FtpOp.TerminateSession, now_s)

    def _send_write(self, now_s: float) -> list[bytes]:
        offset = self.bytes_acked
        chunk = self.data[offset : offset + self.chunk_len]
        return self._send(FtpOp.WriteFile, now_s, data=chunk, offset=offset)


class DirectoryProbe(FtpExchange):
    """Does directory ``path`` exist on the autopilot? ``exists`` holds the answer once done
    without error."""

    what = "listing"
    exists: bool | None = None  # the answer, once done without error

    def _first(self, now_s: float) -> list[bytes]:
        self._started = True
        return self._send(FtpOp.ListDirectory, now_s, data=self._path_bytes)

    def _advance(
        self, sent: FtpPayload, reply: FtpPayload, nak: Nak | None, now_s: float
    ) -> list[bytes]:
        if sent.opcode == FtpOp.TerminateSession:
            return self._succeed()
        if nak is None or nak.error == FtpErr.EndOfFile:
            self.exists = True
        elif nak.error == FtpErr.FileNotFound:
            self.exists = False
        else:
            return self._refused(sent, nak)
        return self._send(FtpOp.TerminateSession, now_s)


class FtpLink(Protocol):
    """What :func:`run_ftp` needs: send a payload to the autopilot, receive its payloads
    (already filtered to FILE_TRANSFER_PROTOCOL from the autopilot, addressed to us)."""

    def send(self, payload: bytes) -> None: ...

    async def recv(self, timeout_s: float) -> bytes | None:
        """The next payload, or None if none came within ``timeout_s``."""
        ...


E = TypeVar("E", bound=FtpExchange)


async def run_ftp(exchange: E, link: FtpLink, clock: Callable[[], float] = now_s) -> E:
    """Drive ``exchange`` over ``link`` until it ends; raises its error if it failed."""
    await drive(exchange, link.send, link.recv, exchange.on_reply, clock)
    return exchange
