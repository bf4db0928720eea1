"""ArduPilot's MAVLink FTP server (FILE_TRANSFER_PROTOCOL), sans-IO, over a directory on disk.

:meth:`FtpServer.handle` takes one request payload (the 251 bytes of the message, with the
sender's sysid/compid and the link it came in on) and the time, and returns the reply payloads
to send back to that sender (none, one, or a burst). Files live under ``root``: a remote path
``/APM/scripts/x.lua`` (or ``APM/scripts/x.lua``) is ``root/APM/scripts/x.lua``; ``@ROMFS/...``
is ``root/@ROMFS/...`` and read-only. Open files are real file descriptors: :meth:`close` (or
``with``) releases them.

Written from ArduPilot master (4.7-dev) ``libraries/GCS_MAVLink/GCS_FTP.cpp`` / ``GCS_FTP.h``,
where FTP became multi-session (PR #30628, 2025); each rule below names its function:

* Sessions (``GCS_FTP::worker``): ``max_sessions`` slots (``AP_MAVLINK_FTP_MAX_SESSIONS``,
  5; pass 1 for one session at a time). A request belongs to the slot of its (sysid, compid,
  link, session). Otherwise it claims the slot idle longest, unless that slot sent within
  ``SESSION_TIMEOUT_S`` (3 s): then NAK NoSessionsAvailable. Claiming closes what the slot had
  open; a request with session 0 gets a fresh id (1..255, cycling) which its reply carries,
  any other session number is kept. A slot with a reply sent more than
  ``SESSION_KILL_TIMEOUT_S`` (20 s) ago is closed. TerminateSession's reply marks its slot idle.
* ResetSessions closes every slot of the sender (on that link) and is always ACKed.
* Replies (``setup_reply``): req_opcode = the request's opcode, the request's session,
  seq_number + 1 (uint16), size 0, offset 0. NAK (``GCS_FTP::error``): data[0] the error, size
  1; FailErrno becomes FileExists for EEXIST, FileNotFound for ENOENT, otherwise data[1] is
  the errno (size 2).
* A repeated request (same sysid, compid, session after the claim, seq_number + 1 equal to the
  last reply's; the opcode is not compared) is answered with the last reply again instead of
  being run twice, unless that reply was NoSessionsAvailable. There is one "last reply" for the
  whole server, so only the latest request can be repeated.
* ``Session::handle_request``: size > 239 → InvalidDataSize. None → ACK. TerminateSession
  closes the file. OpenFileRO: a file already open → Fail (unless idle > 3 s: closed first);
  ACK data = file size (u32). ReadFile / BurstReadFile need an open file (FileNotFound) opened
  for reading (Fail); read at offset, end of file → EndOfFile; burst: up to 2000 ACKs with
  consecutive seq numbers and offsets, the last one (or the EndOfFile NAK) with
  burst_complete. CreateFile (O_TRUNC) / OpenFileWO (no truncation), both O_CREAT: a file
  already open → Fail. WriteFile: open for writing, written at offset, ACK echoes the offset.
  CreateDirectory (mkdir), RemoveFile / RemoveDirectory (both rmdir-then-unlink, as
  ``AP_Filesystem_Posix::unlink``), CalcFileCRC32 (``AP_Filesystem::crc32``: ``crc_crc32``
  from 0; ACK data u32), Rename (two NUL-separated names). TruncateFile and unknown opcodes →
  UnknownCommand; Ack/Nack requests get no reply. Names go through ``check_name_len`` (size is
  the length, or the length + its NUL): else InvalidDataSize.
* ListDirectory (``Session::list_dir``): ``F<name>\\t<size>\\0`` / ``D<name>\\0`` entries, as
  many as fit, after skipping ``offset`` entries; none left → EndOfFile.
* ``@ROMFS`` is read-only (``AP_Filesystem_ROMFS``: writes, mkdir, unlink → EROFS).

Offsets go to ``lseek`` as int32 (``AP_Filesystem::lseek``): ≥ 2**31 fails with EINVAL.

The simulator's own rules (no ArduPilot counterpart): a path with a ``..`` component, one that
resolves outside ``root`` (a symlink out) or that names ``root`` itself for removal/renaming is
refused with FileProtected; a
write ending past ``max_file_bytes`` fails with ENOSPC (SITL caps its disk similarly); ``.``
and ``..`` are not listed (as on the autopilot's FAT/littlefs card); errno values are the
host's. Not modelled: the request queue (5 deep) dropping requests, the burst pacing delay.
"""

from __future__ import annotations

import errno as _errno
import math
import os
import struct
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from types import TracebackType

from helixd.mav.ftp_wire import (
    HEADER_LEN,
    MAX_DATA_LEN,
    PAYLOAD_LEN,
    FtpErr,
    FtpHeader,
    FtpOp,
    FtpPayload,
    FtpPayloadError,
    crc32_ardupilot,
)

__all__ = [
    "BURST_TRANSFER_SIZE",
    "DEFAULT_MAX_FILE_BYTES",
    "MAX_SESSIONS",
    "ROMFS_PREFIX",
    "SESSION_KILL_TIMEOUT_S",
    "SESSION_TIMEOUT_S",
    "FtpServer",
]

SESSION_TIMEOUT_S = 3.0  # FTP_SESSION_TIMEOUT (ms 3000)
SESSION_KILL_TIMEOUT_S = 20.0  # FTP_SESSION_KILL_TIMEOUT (ms 20000)
MAX_SESSIONS = 5  # AP_MAVLINK_FTP_MAX_SESSIONS
BURST_TRANSFER_SIZE = 2000  # BurstReadFile: replies per request
ROMFS_PREFIX = "@ROMFS"
DEFAULT_MAX_FILE_BYTES = 16 * 1024 * 1024
_U32 = 0xFFFF_FFFF
_CRC_CHUNK = 64 * 1024


class _Mode(Enum):
    READ = "read"
    WRITE = "write"


class _FtpRefused(Exception):
    """A path the simulator will not touch (outside root, or root itself)."""


@dataclass(slots=True)
class _Session:
    """GCS_FTP::Session; ``last_send_s`` None is ArduPilot's last_send_ms == 0."""

    session_id: int = 0
    sysid: int = 0
    compid: int = 0
    link: int = 0
    fd: int = -1
    mode: _Mode = _Mode.READ
    last_send_s: float | None = None

    def idle_s(self, now_s: float) -> float:
        return math.inf if self.last_send_s is None else now_s - self.last_send_s

    def close(self) -> int:
        """Session::close: 0, or the errno of a failed close."""
        result = 0
        if self.fd != -1:
            try:
                os.close(self.fd)
            except OSError as exc:
                result = exc.errno or _errno.EIO
            self.fd = -1
        self.last_send_s = None
        return result


@dataclass(slots=True)
class _Transaction:
    """GCS_FTP::Transaction: a request, or the reply being built (data is all 239 bytes)."""

    seq_number: int
    session: int
    opcode: int
    size: int
    req_opcode: int
    burst_complete: bool
    offset: int
    sysid: int
    compid: int
    link: int
    data: bytearray = field(default_factory=lambda: bytearray(MAX_DATA_LEN))

    def pack(self) -> bytes:
        return FtpPayload(
            seq_number=self.seq_number & 0xFFFF,
            session=self.session & 0xFF,
            opcode=self.opcode,
            size=self.size,
            req_opcode=self.req_opcode,
            burst_complete=1 if self.burst_complete else 0,
            offset=self.offset & _U32,
            data=bytes(self.data[: self.size]),
        ).pack()


def _strnlen(buf: bytearray | bytes, limit: int) -> int:
    end = buf.find(0, 0, limit)
    return limit if end < 0 else end


def _check_name_len(request: _Transaction) -> bool:
    """Session::check_name_len: size is the name's length, or that + 1 with a final NUL."""
    name_len = _strnlen(request.data, MAX_DATA_LEN)
    if request.size == 0:
        return False
    if name_len == request.size:
        return True
    return request.size - name_len == 1 and request.data[MAX_DATA_LEN - 1] == 0


def _c_name(data: bytearray) -> bytes:
    """The name as ArduPilot reads it once it forced the last byte to NUL."""
    data[MAX_DATA_LEN - 1] = 0
    return bytes(data[: data.index(0)])


def _error(reply: _Transaction, err: FtpErr, errno: int = 0) -> None:
    """GCS_FTP::error (``errno`` is read only for FailErrno)."""
    reply.opcode = FtpOp.Nack
    reply.data[0] = err
    reply.size = 1
    if err == FtpErr.FailErrno:
        if errno == _errno.EEXIST:
            reply.data[0] = FtpErr.FileExists
        elif errno == _errno.ENOENT:
            reply.data[0] = FtpErr.FileNotFound
        else:
            reply.data[1] = errno & 0xFF
            reply.size = 2


def _os_error(reply: _Transaction, exc: OSError) -> None:
    _error(reply, FtpErr.FailErrno, exc.errno or _errno.EIO)


def _check_id(name: str, value: int, top: int) -> None:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= top:
        raise ValueError(f"{name} {value!r} out of range 0..{top}")


class FtpServer:
    """ArduPilot's FTP server over ``root`` (an existing directory)."""

    def __init__(
        self,
        root: str | os.PathLike[str],
        *,
        max_sessions: int = MAX_SESSIONS,
        max_file_bytes: int = DEFAULT_MAX_FILE_BYTES,
    ) -> None:
        if not isinstance(max_sessions, int) or not 1 <= max_sessions <= 255:
            raise ValueError(f"max_sessions {max_sessions!r} must be 1..255")
        if not isinstance(max_file_bytes, int) or max_file_bytes < 0:
            raise ValueError(f"max_file_bytes {max_file_bytes!r} must be >= 0")
        self.root = Path(root).resolve(strict=True)
        if not self.root.is_dir():
            raise ValueError(f"FTP root {self.root} is not a directory")
        self.max_file_bytes = max_file_bytes
        self._sessions = [_Session() for _ in range(max_sessions)]
        self._next_session_id = 1  # static uint8_t next_session_id = 1 (worker)
        self._reply: _Transaction | None = None  # the worker's one reply
        self._now_s = 0.0

    # --- lifetime -------------------------------------------------------------------------

    def close(self) -> None:
        """Close every open file (the server stays usable)."""
        for s in self._sessions:
            s.close()

    def __enter__(self) -> FtpServer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @property
    def open_files(self) -> int:
        """How many sessions have a file open."""
        return sum(1 for s in self._sessions if s.fd != -1)

    # --- the worker -----------------------------------------------------------------------

    def handle(
        self, payload: bytes, *, sysid: int, compid: int, now_s: float, link: int = 0
    ) -> list[bytes]:
        """One FILE_TRANSFER_PROTOCOL payload from (sysid, compid) on ``link`` at ``now_s``:
        the payloads to send back to that sender, in order."""
        _check_id("sysid", sysid, 255)
        _check_id("compid", compid, 255)
        _check_id("link", link, 2**31)
        if not math.isfinite(now_s):
            raise ValueError(f"now_s {now_s!r} must be finite")
        try:
            head = FtpHeader.unpack(payload)
        except FtpPayloadError:
            return []  # not a payload MAVLink could have delivered
        raw = bytes(payload).ljust(PAYLOAD_LEN, b"\0")
        self._now_s = now_s
        self._kill_dead_sessions(now_s)
        request = _Transaction(
            seq_number=head.seq_number,
            session=head.session,
            opcode=head.opcode,
            size=head.size,
            req_opcode=head.req_opcode,
            burst_complete=head.burst_complete != 0,
            offset=head.offset,
            sysid=sysid,
            compid=compid,
            link=link,
            data=bytearray(raw[HEADER_LEN:]),
        )
        out: list[bytes] = []

        if request.opcode == FtpOp.ResetSessions:
            for s in self._sessions:
                if (s.sysid, s.compid, s.link) == (sysid, compid, link):
                    s.close()
            reply = self._setup_reply(request)
            reply.opcode = FtpOp.Ack
            out.append(reply.pack())
            return out

        session = self._find_session(request)
        if session is None:
            session = max(self._sessions, key=lambda s: s.idle_s(now_s))  # first of equals
            if session.last_send_s is not None and session.idle_s(now_s) < SESSION_TIMEOUT_S:
                reply = self._setup_reply(request)
                _error(reply, FtpErr.NoSessionsAvailable)
                out.append(reply.pack())
                return out
            session.close()
            if request.session == 0:
                session.session_id = self._next_session_id
                self._next_session_id = self._next_session_id % 255 + 1
                request.session = session.session_id
            else:
                session.session_id = request.session
            session.sysid, session.compid, session.link = sysid, compid, link

        last = self._reply
        if (
            last is not None
            and request.sysid == last.sysid
            and request.compid == last.compid
            and request.session == last.session
            and request.seq_number + 1 == last.seq_number
            and last.data[0] != FtpErr.NoSessionsAvailable
        ):
            self._push_reply(session, last, out)
            return out

        reply = self._setup_reply(request)
        if not self._handle_request(session, request, reply, out):
            self._push_reply(session, reply, out)
        return out

    def _kill_dead_sessions(self, now_s: float) -> None:
        for s in self._sessions:
            if s.last_send_s is not None and now_s - s.last_send_s > SESSION_KILL_TIMEOUT_S:
                s.close()

    def _find_session(self, request: _Transaction) -> _Session | None:
        for s in self._sessions:
            if (s.sysid, s.compid, s.link, s.session_id) == (
                request.sysid,
                request.compid,
                request.link,
                request.session,
            ):
                return s
        return None

    def _setup_reply(self, request: _Transaction) -> _Transaction:
        reply = _Transaction(
            seq_number=(request.seq_number + 1) & 0xFFFF,
            session=request.session,
            opcode=FtpOp.None_,
            size=0,
            req_opcode=request.opcode,
            burst_complete=False,
            offset=0,
            sysid=request.sysid,
            compid=request.compid,
            link=request.link,
        )
        self._reply = reply
        return reply

    def _push_reply(self, session: _Session, reply: _Transaction, out: list[bytes]) -> None:
        session.last_send_s = self._now_s
        out.append(reply.pack())
        if reply.req_opcode == FtpOp.TerminateSession:
            session.last_send_s = None

    # --- paths ----------------------------------------------------------------------------

    def _named(self, request: _Transaction, reply: _Transaction, use: str = "read") -> Path | None:
        """The host path of the name the request carries, to ``use`` ("read", "write" or
        "remove"); None with the NAK in ``reply`` (a name too long; a write or a remove in
        the read-only part: EROFS). Raises _FtpRefused."""
        if not _check_name_len(request):
            _error(reply, FtpErr.InvalidDataSize)
            return None
        path, read_only = self._path(_c_name(request.data), removing=use == "remove")
        if use != "read" and read_only:
            _error(reply, FtpErr.FailErrno, _errno.EROFS)
            return None
        return path

    def _path(self, name: bytes, *, removing: bool = False) -> tuple[Path, bool]:
        """(host path, read-only) of a remote name; raises _FtpRefused."""
        parts = [p for p in os.fsdecode(name).split("/") if p not in ("", ".")]
        if ".." in parts:
            raise _FtpRefused(name)
        try:
            path = self.root.joinpath(*parts).resolve(strict=False)
        except (OSError, RuntimeError) as exc:  # a symlink loop under root
            raise _FtpRefused(name) from exc
        if path != self.root and not path.is_relative_to(self.root):
            raise _FtpRefused(name)
        if removing and path == self.root:
            raise _FtpRefused(name)
        rel = path.relative_to(self.root).parts
        return path, bool(rel) and rel[0] == ROMFS_PREFIX

    # --- Session::handle_request ----------------------------------------------------------

    def _handle_request(
        self, session: _Session, request: _Transaction, reply: _Transaction, out: list[bytes]
    ) -> bool:
        """Run one request; True if its reply(s) went out already (or none is due)."""
        if request.size > MAX_DATA_LEN:
            _error(reply, FtpErr.InvalidDataSize)
            return False
        op = request.opcode
        try:
            if op == FtpOp.None_:
                reply.opcode = FtpOp.Ack
            elif op == FtpOp.TerminateSession:
                err = session.close()
                if err:
                    _error(reply, FtpErr.FailErrno, err)
                else:
                    reply.opcode = FtpOp.Ack
            elif op == FtpOp.ListDirectory:
                self._list_dir(request, reply)
            elif op == FtpOp.OpenFileRO:
                self._open_ro(session, request, reply)
            elif op == FtpOp.ReadFile:
                self._read(session, request, reply)
            elif op in (FtpOp.Ack, FtpOp.Nack):
                return True  # "eat these, we just didn't expect them"
            elif op in (FtpOp.OpenFileWO, FtpOp.CreateFile):
                self._open_wo(session, request, reply)
            elif op == FtpOp.WriteFile:
                self._write(session, request, reply)
            elif op == FtpOp.CreateDirectory:
                self._mkdir(request, reply)
            elif op in (FtpOp.RemoveDirectory, FtpOp.RemoveFile):
                self._remove(request, reply)
            elif op == FtpOp.CalcFileCRC32:
                self._crc32(request, reply)
            elif op == FtpOp.BurstReadFile:
                return self._burst_read(session, request, reply, out)
            elif op == FtpOp.Rename:
                self._rename(request, reply)
            else:  # TruncateFile, and anything unknown
                _error(reply, FtpErr.UnknownCommand)
        except _FtpRefused:
            _error(reply, FtpErr.FileProtected)
        return False

    def _open_ro(self, session: _Session, request: _Transaction, reply: _Transaction) -> None:
        if session.fd != -1 and session.idle_s(self._now_s) > SESSION_TIMEOUT_S:
            session.close()
        if session.fd != -1:
            _error(reply, FtpErr.Fail)
            return
        path = self._named(request, reply)
        if path is None:
            return
        try:
            file_size = os.stat(path).st_size
            session.fd = os.open(path, os.O_RDONLY)
        except OSError as exc:
            _os_error(reply, exc)
            return
        session.mode = _Mode.READ
        reply.opcode = FtpOp.Ack
        reply.size = 4
        reply.data[0:4] = struct.pack("<I", file_size & _U32)

    def _at_offset(
        self, session: _Session, request: _Transaction, reply: _Transaction, mode: _Mode
    ) -> bool:
        """The session's file, opened for ``mode``, at the request's offset; else the NAK in
        ``reply`` (no file open: FileNotFound; opened for the other mode: Fail)."""
        if session.fd == -1:
            _error(reply, FtpErr.FileNotFound)
            return False
        if session.mode != mode:
            _error(reply, FtpErr.Fail)
            return False
        return self._seek(session, request, reply)

    def _seek(self, session: _Session, request: _Transaction, reply: _Transaction) -> bool:
        """lseek to the request's offset; AP_Filesystem's lseek takes an int32."""
        offset = request.offset - (1 << 32) if request.offset >= 1 << 31 else request.offset
        try:
            os.lseek(session.fd, offset, os.SEEK_SET)
        except OSError as exc:
            _os_error(reply, exc)
            return False
        return True

    def _read(self, session: _Session, request: _Transaction, reply: _Transaction) -> None:
        if not self._at_offset(session, request, reply, _Mode.READ):
            return
        try:
            chunk = os.read(session.fd, min(MAX_DATA_LEN, request.size))
        except OSError as exc:
            _os_error(reply, exc)
            return
        if not chunk:
            _error(reply, FtpErr.EndOfFile)
            return
        reply.opcode = FtpOp.Ack
        reply.offset = request.offset
        reply.size = len(chunk)
        reply.data[: len(chunk)] = chunk

    def _open_wo(self, session: _Session, request: _Transaction, reply: _Transaction) -> None:
        if session.fd != -1:
            _error(reply, FtpErr.Fail)
            return
        path = self._named(request, reply, "write")
        if path is None:
            return
        flags = os.O_WRONLY | os.O_CREAT
        if request.opcode == FtpOp.CreateFile:
            flags |= os.O_TRUNC
        try:
            session.fd = os.open(path, flags, 0o666)
        except OSError as exc:
            _os_error(reply, exc)
            return
        session.mode = _Mode.WRITE
        reply.opcode = FtpOp.Ack

    def _write(self, session: _Session, request: _Transaction, reply: _Transaction) -> None:
        if not self._at_offset(session, request, reply, _Mode.WRITE):
            return
        if request.offset + request.size > self.max_file_bytes:
            _error(reply, FtpErr.FailErrno, _errno.ENOSPC)
            return
        try:
            os.write(session.fd, bytes(request.data[: request.size]))
        except OSError as exc:
            _os_error(reply, exc)
            return
        reply.opcode = FtpOp.Ack
        reply.offset = request.offset

    def _mkdir(self, request: _Transaction, reply: _Transaction) -> None:
        path = self._named(request, reply, "write")
        if path is None:
            return
        try:
            os.mkdir(path, 0o775)
        except OSError as exc:
            _os_error(reply, exc)
            return
        reply.opcode = FtpOp.Ack

    def _remove(self, request: _Transaction, reply: _Transaction) -> None:
        path = self._named(request, reply, "remove")
        if path is None:
            return
        try:  # AP_Filesystem_Posix::unlink: rmdir, then unlink
            os.rmdir(path)
        except OSError:
            try:
                os.unlink(path)
            except OSError as exc:
                _os_error(reply, exc)
                return
        reply.opcode = FtpOp.Ack

    def _crc32(self, request: _Transaction, reply: _Transaction) -> None:
        path = self._named(request, reply)
        if path is None:
            return
        checksum = 0
        try:
            fd = os.open(path, os.O_RDONLY)
        except OSError as exc:
            _os_error(reply, exc)
            return
        try:
            while chunk := os.read(fd, _CRC_CHUNK):
                checksum = crc32_ardupilot(chunk, checksum)
        except OSError as exc:
            _os_error(reply, exc)
            return
        finally:
            os.close(fd)
        reply.data[:] = bytes(MAX_DATA_LEN)
        reply.size = 4
        reply.data[0:4] = struct.pack("<I", checksum)
        reply.opcode = FtpOp.Ack

    def _burst_read(
        self, session: _Session, request: _Transaction, reply: _Transaction, out: list[bytes]
    ) -> bool:
        max_read = MAX_DATA_LEN if request.size == 0 else request.size
        if not self._at_offset(session, request, reply, _Mode.READ):
            return False
        reply.offset = request.offset
        for i in range(BURST_TRANSFER_SIZE):
            try:
                chunk = os.read(session.fd, min(MAX_DATA_LEN, max_read))
            except OSError as exc:
                reply.burst_complete = True
                _os_error(reply, exc)
                break
            reply.data[:] = chunk.ljust(MAX_DATA_LEN, b"\0")
            if not chunk:
                reply.burst_complete = True
                _error(reply, FtpErr.EndOfFile)
                break
            reply.opcode = FtpOp.Ack
            reply.burst_complete = i == BURST_TRANSFER_SIZE - 1
            reply.size = len(chunk)
            self._push_reply(session, reply, out)
            reply.offset += len(chunk)
            reply.seq_number = (reply.seq_number + 1) & 0xFFFF
        # the last NAK goes out with the normal reply; ACKs went out already
        return reply.opcode != FtpOp.Nack

    def _rename(self, request: _Transaction, reply: _Transaction) -> None:
        data = request.data
        len1 = _strnlen(data, MAX_DATA_LEN - 2)
        len2 = _strnlen(data[len1 + 1 :], MAX_DATA_LEN - (len1 + 1))
        tnull = request.size - (len1 + len2) == 2 and data[MAX_DATA_LEN - 1] == 0
        if data[len1] != 0 or (len1 + len2 + 1 != request.size and not tnull) or request.size == 0:
            _error(reply, FtpErr.InvalidDataSize)
            return
        data[MAX_DATA_LEN - 1] = 0
        name1 = bytes(data[:len1])
        tail = data[len1 + 1 :]  # holds the forced NUL at byte 238
        name2 = bytes(tail[: tail.index(0)])
        src, src_ro = self._path(name1, removing=True)
        dst, dst_ro = self._path(name2, removing=True)
        if src_ro or dst_ro:
            _error(reply, FtpErr.FailErrno, _errno.EROFS)
            return
        try:
            os.rename(src, dst)
        except OSError as exc:
            _os_error(reply, exc)
            return
        reply.opcode = FtpOp.Ack

    # --- Session::list_dir / gen_dir_entry ------------------------------------------------

    @staticmethod
    def _dir_entry(entry: os.DirEntry[str], space: int) -> bytes | None:
        """gen_dir_entry: the entry's text (its length is what ArduPilot's snprintf returns),
        or None (-1: no room to try, an unlistable type, or a file that cannot be stat'ed)."""
        if space < 3:
            return None
        try:
            is_file = entry.is_symlink() or entry.is_file(follow_symlinks=False)
            if not is_file and not entry.is_dir(follow_symlinks=False):
                return None
            name = os.fsencode(entry.name)
            if not is_file:
                return b"D" + name + b"\0"
            size = os.stat(entry.path).st_size
        except OSError:
            return None
        return b"F" + name + b"\t" + str(size & _U32).encode() + b"\0"

    def _list_dir(self, request: _Transaction, reply: _Transaction) -> None:
        reply.offset = request.offset
        if not _check_name_len(request):
            _error(reply, FtpErr.InvalidDataSize)
            return
        name = _c_name(request.data)
        if len(name) > 1 and name.endswith(b"/"):
            name = name[:-1]
        path, _ = self._path(name)
        try:
            entries = iter(list(os.scandir(path)))
        except OSError as exc:
            _os_error(reply, exc)
            return
        skip = request.offset
        while skip > 0:
            entry = next(entries, None)
            if entry is None:
                _error(reply, FtpErr.EndOfFile)
                return
            text = self._dir_entry(entry, MAX_DATA_LEN)
            if text is None or len(text) >= MAX_DATA_LEN:
                continue
            skip -= 1
        index = 0
        for entry in entries:
            text = self._dir_entry(entry, MAX_DATA_LEN - index)
            if text is None or len(text) >= MAX_DATA_LEN:
                continue  # never sendable: dropped
            if len(text) + index >= MAX_DATA_LEN:
                break  # for the next listing
            reply.data[index : index + len(text)] = text
            index += len(text)
        if index == 0:
            _error(reply, FtpErr.EndOfFile)
            return
        reply.opcode = FtpOp.Ack
        reply.size = index
