"""The link's telemetry log (``.tlog``) as MAVProxy, MAVExplorer and UAVLogViewer read it.

The format is pymavlink's ``mavlogfile``: for every frame, in either direction, an 8-byte
big-endian unsigned count of microseconds since the UNIX epoch, then the raw MAVLink frame
as it went over the wire. Nothing else: no header, no direction flag.

:class:`TlogWriter` is the small I/O shell: :meth:`TlogWriter.write` only appends to a memory
buffer (no system call, safe to call from the event loop for every frame), and the caller calls
:meth:`TlogWriter.flush` at least every 0.5 s, which puts the buffer on disk in one ``write``.
It is bounded: a record that would take the file past ``max_bytes`` is not written and the log
stops there (whole records only, so the file stays readable), and the buffer cannot grow
past ``max_bytes`` either. Disk errors fail soft: the first one is logged, the log closes and
every later call does nothing; flying never depends on the log.

:class:`LinkTlog` puts a writer on the daemon's link: the codec
(:class:`helixd.link.wire.codec.MavlinkConnection`) hands it every frame it sends and every frame it
reads, stamped with the wall clock; the first frame buffered after a flush arms one event-loop
timer that flushes :data:`FLUSH_INTERVAL_S` later (no task of its own, nothing when the link is
quiet). :func:`attach_tlog` opens one on an open Autopilot.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

import structlog

from helixd.base.clock import unix_s

__all__ = [
    "FLUSH_INTERVAL_S",
    "MAX_FRAME_BYTES",
    "LinkTlog",
    "TlogWriter",
    "attach_tlog",
    "tlog_record",
]

MAX_FRAME_BYTES = 280  # MAVLink2: 10 header + 255 payload + 2 crc + 13 signature
MAVLINK_MAGICS = (0xFD, 0xFE)
_STAMP = struct.Struct(">Q")

log = structlog.get_logger(__name__)


def tlog_record(frame: bytes, unix_time_s: float) -> bytes | None:
    """One .tlog record; None for what is not a MAVLink frame or a time that is not valid."""
    if not (math.isfinite(unix_time_s) and 0.0 <= unix_time_s < 2**64 / 1e6):
        return None
    if not (2 <= len(frame) <= MAX_FRAME_BYTES) or frame[0] not in MAVLINK_MAGICS:
        return None
    return _STAMP.pack(int(unix_time_s * 1e6)) + bytes(frame)


class TlogWriter:
    def __init__(self, path: Path, max_bytes: int) -> None:
        if max_bytes < 1:
            raise ValueError("max_bytes must be >= 1")
        self.path = path
        self.max_bytes = max_bytes
        self.written_bytes = 0
        self.dropped_records = 0
        self._buffer = bytearray()
        self._file: BinaryIO | None = None
        self._stopped = False
        self._full = False
        self.on_error: Callable[[Path, OSError], None] | None = None  # instead of tlog_error
        try:
            self._file = path.open("ab")
            self.written_bytes = self._file.tell()
        except OSError as exc:
            self._fail("open", exc)

    @property
    def active(self) -> bool:
        """False once stopped by a disk error, the size cap or :meth:`close`."""
        return not self._stopped and not self._full

    @property
    def buffered_bytes(self) -> int:
        return len(self._buffer)

    def write(self, frame: bytes, unix_time_s: float) -> bool:
        """Buffer one frame (sent or received); False if it was not logged."""
        if not self.active:
            self.dropped_records += 1
            return False
        record = tlog_record(frame, unix_time_s)
        if record is None:
            self.dropped_records += 1
            return False
        if self.written_bytes + len(self._buffer) + len(record) > self.max_bytes:
            self._full = True
            self.dropped_records += 1
            log.warning(
                "tlog_full", path=str(self.path), max_bytes=self.max_bytes, action="stop logging"
            )
            return False
        self._buffer += record
        return True

    def flush(self) -> None:
        """Put the buffer on disk (call at least every 0.5 s)."""
        if self._file is None or not self._buffer:
            return
        data, self._buffer = bytes(self._buffer), bytearray()
        try:
            self._file.write(data)
            self._file.flush()
        except OSError as exc:
            self._fail("write", exc)
            return
        self.written_bytes += len(data)

    def close(self) -> None:
        self.flush()
        if self._file is not None:
            try:
                self._file.close()
            except OSError as exc:
                self._fail("close", exc)
        self._file = None
        self._stopped = True

    def _fail(self, what: str, exc: OSError) -> None:
        if not self._stopped:
            if self.on_error is not None:  # the run recorder reports it (one record_cut)
                self.on_error(self.path, exc)
            else:
                log.error("tlog_error", path=str(self.path), op=what, error=str(exc))
        self._stopped = True
        self._buffer = bytearray()
        file, self._file = self._file, None
        if file is not None:
            with contextlib.suppress(OSError):  # already reported; the log is given up
                file.close()


FLUSH_INTERVAL_S = 0.25  # a buffered frame reaches the disk within this (the brief: <= 0.5 s)


class LinkTlog:
    """A :class:`TlogWriter` fed from the event loop, flushed by a one-shot timer.

    Create it inside the running loop that owns the link; :meth:`record` must be called from
    that loop (the codec's reader callback and its writes are)."""

    def __init__(
        self,
        writer: TlogWriter,
        flush_interval_s: float = FLUSH_INTERVAL_S,
        clock: Callable[[], float] = unix_s,
    ) -> None:
        if not (math.isfinite(flush_interval_s) and 0.0 < flush_interval_s <= 0.5):
            raise ValueError("flush_interval_s must be in (0, 0.5]")
        self.writer = writer
        self.flush_interval_s = flush_interval_s
        self._clock = clock
        self._loop = asyncio.get_running_loop()
        self._timer: asyncio.TimerHandle | None = None

    @property
    def flush_due(self) -> asyncio.TimerHandle | None:
        """The armed flush timer (None: nothing buffered)."""
        return self._timer

    def record(self, frame: bytes) -> None:
        """One frame sent or received, stamped now; never raises for a bad frame."""
        if self.writer.write(frame, self._clock()) and self._timer is None:
            self._timer = self._loop.call_later(self.flush_interval_s, self._flush)

    def _flush(self) -> None:
        self._timer = None
        self.writer.flush()

    def close(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        self.writer.close()


def attach_tlog(ap: Any, path: Path, max_bytes: int) -> LinkTlog:
    """Log every frame of an open :class:`helixd.link.connection.Autopilot`'s link to ``path``
    (closed with the link). Call it right after ``Autopilot.connect`` in the event loop.

    Attached through the facade's public :meth:`Autopilot.attach_tlog`."""
    tlog = LinkTlog(TlogWriter(path, max_bytes))
    ap.attach_tlog(tlog)
    log.info("tlog_open", path=str(path), max_bytes=max_bytes, active=tlog.writer.active)
    return tlog
