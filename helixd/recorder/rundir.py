"""The flight recorder's run directory: ``<run_root>/<UTC stamp>-<mission>/``.

Contents: ``config.yaml`` and ``mission.yaml`` (the exact resolved inputs), ``events.jsonl``
(every structlog event, via :mod:`helixd.recorder.logging_setup`), ``flight.csv`` (one row per
control
step, see :mod:`helixd.recorder.rows`) and ``summary.json`` (written atomically at the end);
``link.tlog`` (every MAVLink frame of the link, written by :mod:`helixd.link.wire.tlog`).

``flight.csv`` is written through a buffer, flushed to the OS at least every
``flush_interval_s`` and fsync'ed (with ``events.jsonl``) by a background thread, so the
control loop never waits for the disk and a crash or power loss loses at most about one
flush interval of rows.

A disk that fails must not stop the safety logic: with ``on_write_error: continue`` the
recorder stops writing and logs ONE ``record_cut`` WARNING (naming the file and errno; the
daemon passes it to the ground station through ``on_cut``); ``record()``/``finish()`` never
raise. ``summary.json`` is still written, and says from when the record is missing
(``record_cut_at_s``): its space is reserved when the run directory is created (a
``SUMMARY_RESERVE_BYTES`` file, removed just before the summary is written). With
``refuse``, :meth:`RunRecorder.create` raises :class:`RecorderUnavailable` so the daemon
refuses to start; once running, write errors degrade as with ``continue``.
"""

from __future__ import annotations

import errno as errno_mod
import os
import re
import shutil
import threading
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import IO

import structlog

from helixd.base.clock import now_s
from helixd.base.run_files import (
    CONFIG_FILE,
    EVENTS_FILE,
    FLIGHT_FILE,
    INPUTS_FILE,
    MISSION_FILE,
    SUMMARY_FILE,
)
from helixd.config.recorder import RecorderConfig
from helixd.recorder import logging_setup
from helixd.recorder.events import RUN_STARTED_EVENT
from helixd.recorder.rows import FlightRow, RowFormatter
from helixd.recorder.summary import RunSummary

log = structlog.get_logger(__name__)

CSV_BUFFER_BYTES = 64 * 1024  # > one flush interval of rows at 50 Hz (~330 B/row)
SYNC_JOIN_TIMEOUT_S = 5.0  # wait this long for the last fsync when closing
MAX_NAME_COLLISIONS = 100  # runs started within the same second get -2, -3, …
STAMP_FORMAT = "%Y%m%dT%H%M%SZ"
# Space kept for summary.json from the start of the run: a summary is ~3 kB; the margin covers
# a long arrivals list and the filesystem's block rounding.
SUMMARY_RESERVE_BYTES = 256 * 1024
RESERVE_FILE = ".summary.reserve"

Opener = Callable[[Path, str], IO[str]]


def default_opener(path: Path, mode: str) -> IO[str]:
    return path.open(mode, encoding="utf-8", newline="", buffering=CSV_BUFFER_BYTES)


class RecorderUnavailable(Exception):
    """The run directory cannot be written and ``on_write_error`` is ``refuse``."""

    def __init__(self, path: Path, exc: OSError) -> None:
        self.path = path
        self.errno = exc.errno
        reason = exc.strerror or str(exc)
        code = errno_mod.errorcode.get(exc.errno or 0, "?")
        super().__init__(
            f"flight recorder cannot write {path}: {reason} (errno {exc.errno} {code}). "
            "Free disk space or fix the permissions of recorder.run_root, or set "
            "recorder.on_write_error: continue to fly without a recording."
        )


def run_dir_name(mission_name: str, now_utc: datetime) -> str:
    """``20261121T031500Z-square``: UTC stamp and a filesystem-safe mission name."""
    stamp = (now_utc if now_utc.tzinfo else now_utc.replace(tzinfo=UTC)).astimezone(UTC)
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", mission_name).strip("._") or "mission"
    return f"{stamp.strftime(STAMP_FORMAT)}-{safe}"


def _make_unique_dir(run_root: Path, name: str) -> Path:
    run_root.mkdir(parents=True, exist_ok=True)
    for n in range(1, MAX_NAME_COLLISIONS + 1):
        candidate = run_root / (name if n == 1 else f"{name}-{n}")
        try:
            candidate.mkdir()
        except FileExistsError:
            continue
        return candidate
    raise FileExistsError(errno_mod.EEXIST, "too many runs with the same name", str(run_root))


class _Syncer:
    """Background fsync of the run's files, woken after each flush (keeps the loop off disk)."""

    def __init__(self, fds: list[int]) -> None:
        self._fds = fds
        self._wake = threading.Event()
        self._stopping = False
        self.error: OSError | None = None
        self._thread = threading.Thread(target=self._run, name="helixd-recorder-sync", daemon=True)
        self._thread.start()

    def request(self) -> None:
        self._wake.set()

    def stop(self) -> bool:
        """Last fsync, then stop; True when the thread finished within the timeout."""
        self._stopping = True
        self._wake.set()
        self._thread.join(SYNC_JOIN_TIMEOUT_S)
        return not self._thread.is_alive()

    def _run(self) -> None:
        while True:
            self._wake.wait()
            self._wake.clear()
            for fd in list(self._fds):
                try:
                    os.fsync(fd)
                except OSError as exc:
                    if exc.errno in (errno_mod.EINVAL, errno_mod.EROFS):
                        self._fds.remove(fd)  # a special file that cannot be synced: stop trying
                    else:
                        self.error = exc
            if self._stopping:
                return


class RunRecorder:
    """Writes one run directory. Create with :meth:`create`; the daemon calls :meth:`record`
    every control step and :meth:`finish` at the end (or :meth:`close` if it has no summary)."""

    def __init__(self, cfg: RecorderConfig, clock: Callable[[], float], opener: Opener) -> None:
        self._cfg = cfg
        self._clock = clock
        self._opener = opener
        self._fmt = RowFormatter()
        self.run_dir: Path | None = None
        self.degraded = False
        self.rows_written = 0
        self._csv: IO[str] | None = None
        self._csv_path: Path | None = None
        self._syncer: _Syncer | None = None
        self._events_fd = -1  # read-only fd of events.jsonl, only for fsync
        self._last_flush_s = 0.0
        self._bad_row_logged = False
        self._closed = False
        self._first_t_boot_s: float | None = None
        self._last_t_boot_s: float | None = None
        self.cut_at_s: float | None = None  # record cut: from this flight time on (s)
        self.cut_files: tuple[str, ...] = ()
        self.on_cut: Callable[[str], None] | None = None  # the one text for the ground station
        self._cut_lock = threading.Lock()

    # -- creation ---------------------------------------------------------------------------

    @classmethod
    def create(
        cls,
        run_root: Path,
        mission_name: str,
        config_yaml: str,
        mission_yaml: str,
        cfg: RecorderConfig,
        now_utc: datetime,
        *,
        run_dir: Path | None = None,
        clock: Callable[[], float] = now_s,
        opener: Opener = default_opener,
        inputs_json: str | None = None,
    ) -> RunRecorder:
        """Make the run directory and start recording.

        ``run_dir`` overrides the ``<run_root>/<stamp>-<mission>`` name. ``clock`` drives the
        flush schedule; ``opener(path, mode)`` opens every file written (tests inject failures).
        Raises RecorderUnavailable only when ``cfg.on_write_error == "refuse"``.
        """
        rec = cls(cfg, clock, opener)
        target = run_dir if run_dir is not None else run_root / run_dir_name(mission_name, now_utc)
        try:
            rec._open(
                run_root, run_dir, mission_name, now_utc, config_yaml, mission_yaml, inputs_json
            )
        except OSError as exc:
            failed = Path(exc.filename) if exc.filename else rec.run_dir or target
            if cfg.on_write_error == "refuse":
                rec._release()
                logging_setup.detach_events_file()
                raise RecorderUnavailable(failed, exc) from exc
            rec._degrade(exc, failed, stage="create")
        return rec

    def _open(
        self,
        run_root: Path,
        run_dir: Path | None,
        mission_name: str,
        now_utc: datetime,
        config_yaml: str,
        mission_yaml: str,
        inputs_json: str | None = None,
    ) -> None:
        if run_dir is not None:
            run_dir.mkdir(parents=True, exist_ok=True)
            self.run_dir = run_dir
        else:
            self.run_dir = _make_unique_dir(run_root, run_dir_name(mission_name, now_utc))
        self._reserve_summary_space()
        events_path = self.run_dir / EVENTS_FILE
        logging_setup.attach_events_file(events_path, on_error=self._events_cut)
        self._write_text(self.run_dir / CONFIG_FILE, config_yaml)
        self._write_text(self.run_dir / MISSION_FILE, mission_yaml)
        if inputs_json is not None:  # hashes of mission and config, for `run --resume`
            self._write_text(self.run_dir / INPUTS_FILE, inputs_json)
        self._csv_path = self.run_dir / FLIGHT_FILE
        self._csv = self._opener(self._csv_path, "w")
        self._csv.write(FlightRow.csv_header())
        self._flush_checked(self._csv, self._csv_path)
        self._last_flush_s = self._clock()
        self._events_fd = _readonly_fd(events_path)
        self._syncer = _Syncer([fd for fd in (_fileno(self._csv), self._events_fd) if fd >= 0])
        log.info(
            RUN_STARTED_EVENT,
            run_dir=str(self.run_dir),
            mission=mission_name,
            disk_free_mb=_free_mb(self.run_dir),
        )

    def _reserve_summary_space(self) -> None:
        """Hold SUMMARY_RESERVE_BYTES for summary.json (written and fsync'ed, so the blocks are
        allocated). A card already too full for it: the run goes on without the reserve."""
        assert self.run_dir is not None
        path = self.run_dir / RESERVE_FILE
        try:
            with path.open("wb") as fh:
                fh.write(b"\0" * SUMMARY_RESERVE_BYTES)
                fh.flush()
                _fsync_if_supported(fh.fileno())
        except OSError as exc:
            log.warning("summary_reserve_failed", path=str(path), errno=exc.errno, error=str(exc))
            path.unlink(missing_ok=True)

    def _free_reserve(self) -> None:
        if self.run_dir is None:
            return
        try:
            (self.run_dir / RESERVE_FILE).unlink(missing_ok=True)
        except OSError as exc:
            log.debug("summary_reserve_unlink_failed", error=str(exc))

    def _events_cut(self, path: str, exc: OSError) -> None:
        self.cut(Path(path), exc, stage="events")

    def _write_text(self, path: Path, text: str) -> None:
        fh = self._opener(path, "w")
        try:
            fh.write(text)
            self._flush_checked(fh, path)
        except OSError:
            _close_after_error(fh)
            raise
        fh.close()

    @staticmethod
    def _flush_checked(fh: IO[str], path: Path) -> None:
        try:
            fh.flush()
        except OSError as exc:
            if exc.filename is None:
                exc.filename = str(path)
            raise

    # -- hot path ---------------------------------------------------------------------------

    def record(self, row: FlightRow) -> None:
        """Append one control step. Cheap; never raises."""
        csv = self._csv
        if csv is None:
            return
        try:
            line = self._fmt.line(row)
        except (TypeError, ValueError) as exc:
            if not self._bad_row_logged:
                self._bad_row_logged = True
                log.error("recorder_bad_row", error=str(exc), note="row skipped")
            return
        if self._first_t_boot_s is None:
            self._first_t_boot_s = row.t_boot_s
        self._last_t_boot_s = row.t_boot_s
        try:
            csv.write(line)
        except OSError as exc:
            self._degrade(exc, self._csv_path, stage="write")
            return
        self.rows_written += 1
        now = self._clock()
        if now - self._last_flush_s >= self._cfg.flush_interval_s:
            self._flush(now)

    def maybe_flush(self) -> None:
        """Flush if due; call from a periodic task so rows are flushed when steps pause."""
        if self._csv is not None:
            now = self._clock()
            if now - self._last_flush_s >= self._cfg.flush_interval_s:
                self._flush(now)

    def _flush(self, now: float) -> None:
        self._last_flush_s = now
        if not self._flushed():
            return
        if self._syncer is not None:
            if self._syncer.error is not None:
                self._degrade(self._syncer.error, self._csv_path, stage="fsync")
                return
            self._syncer.request()

    # -- end --------------------------------------------------------------------------------

    def finish(self, summary: RunSummary) -> None:
        """Write summary.json atomically (tmp + rename), close everything. Never raises."""
        if self._closed:
            return
        if self.run_dir is not None:
            if not self.degraded:
                self._close_csv()
            self._release()
            summary = self.annotate(summary)
            self._free_reserve()
            self._write_summary(summary)
        self.close()

    def annotate(self, summary: RunSummary) -> RunSummary:
        """``summary`` with the record cut (from when, which files) if the record was cut."""
        if self.cut_at_s is None or summary.record_cut_at_s is not None:
            return summary
        return summary.model_copy(
            update={"record_cut_at_s": self.cut_at_s, "record_cut_files": self.cut_files}
        )

    def close(self) -> None:
        """Flush and close without a summary (also called by finish). Never raises."""
        if self._closed:
            return
        if not self.degraded:
            self._close_csv()
        self._release()
        self._closed = True
        log.info(
            "run_recorded",
            run_dir=str(self.run_dir),
            rows=self.rows_written,
            degraded=self.degraded,
        )
        logging_setup.detach_events_file()

    def _flushed(self) -> bool:
        """flight.csv's buffer handed to the OS; False when there is no open flight.csv or the
        flush failed (the recorder degraded)."""
        if self._csv is None:
            return False
        try:
            self._csv.flush()
        except OSError as exc:
            self._degrade(exc, self._csv_path, stage="flush")
            return False
        return True

    def _close_csv(self) -> None:
        if not self._flushed():
            return
        syncer, self._syncer = self._syncer, None
        if syncer is not None and syncer.stop() and syncer.error is not None:
            self._degrade(syncer.error, self._csv_path, stage="fsync")
            return
        csv, self._csv = self._csv, None
        try:
            if csv is not None:
                csv.close()
        except OSError as exc:
            self._degrade(exc, self._csv_path, stage="close")

    def _write_summary(self, summary: RunSummary) -> None:
        assert self.run_dir is not None
        final = self.run_dir / SUMMARY_FILE
        tmp = self.run_dir / (SUMMARY_FILE + ".tmp")
        try:
            fh = self._opener(tmp, "w")
            try:
                fh.write(summary.to_json())
                self._flush_checked(fh, tmp)
                fd = _fileno(fh)
                if fd >= 0:
                    _fsync_if_supported(fd)
            except OSError:
                _close_after_error(fh)
                raise
            fh.close()
            os.replace(tmp, final)
            dir_fd = os.open(self.run_dir, os.O_RDONLY)
            try:
                _fsync_if_supported(dir_fd)
            finally:
                os.close(dir_fd)
        except OSError as exc:
            if self.degraded:  # the record was already cut: one warning only
                log.debug("summary_write_failed", path=str(tmp), error=str(exc))
            else:
                self._degrade(exc, tmp, stage="summary")

    # -- failure ----------------------------------------------------------------------------

    def _degrade(self, exc: OSError, path: Path | None, *, stage: str) -> None:
        if self.degraded:
            return
        self.degraded = True
        self._release()
        self.cut(path, exc, stage=stage)

    def cut(self, path: Path | None, exc: OSError, *, stage: str = "write") -> None:
        """One of the run's files stopped being written (flight.csv, events.jsonl, link.tlog):
        the first cut logs the ONE ``record_cut`` warning and tells the ground station; later
        ones only add their file to the list. Never raises; callable from any thread."""
        name = path.name if path is not None else "run directory"
        with self._cut_lock:
            first_cut = self.cut_at_s is None
            if name not in self.cut_files:
                self.cut_files = (*self.cut_files, name)
            if first_cut:
                first, last = self._first_t_boot_s, self._last_t_boot_s
                at = 0.0 if first is None or last is None else round(last - first, 2)
                self.cut_at_s = at
        code = errno_mod.errorcode.get(exc.errno or 0)
        if not first_cut:
            log.info("record_cut_also", path=str(path), file=name, errno=exc.errno, stage=stage)
            return
        assert self.cut_at_s is not None
        log.warning(
            "record_cut",
            path=str(path),
            file=name,
            errno=exc.errno,
            errno_name=code,
            error=exc.strerror or str(exc),
            stage=stage,
            rows_written=self.rows_written,
            record_cut_at_s=self.cut_at_s,
            note="flight recording stopped; the mission and the safety logic continue",
        )
        if self.on_cut is not None:
            try:
                self.on_cut(f"record cut at {self.cut_at_s:.0f}s: {name} {code or exc.errno}")
            except Exception:  # the ground station's text must not stop the recorder
                log.exception("record_cut_report_failed")

    def _release(self) -> None:
        """Drop the csv and the sync thread without raising (error paths)."""
        syncer, self._syncer = self._syncer, None
        joined = syncer.stop() if syncer is not None else True
        csv, self._csv = self._csv, None
        if csv is not None:
            try:
                csv.close()
            except OSError as exc:  # pending rows could not be written: already degrading
                log.debug("recorder_close_failed", error=str(exc))
        fd, self._events_fd = self._events_fd, -1
        if joined and fd >= 0:  # a stuck fsync thread may still use it: leak rather than race
            try:
                os.close(fd)
            except OSError as exc:
                log.debug("recorder_close_failed", error=str(exc))

    def __enter__(self) -> RunRecorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _close_after_error(fh: IO[str]) -> None:
    """Close a file whose write already failed; that first error is the one reported."""
    try:
        fh.close()
    except OSError as exc:
        log.debug("recorder_close_failed", error=str(exc))


def _fileno(fh: IO[str]) -> int:
    try:
        return fh.fileno()
    except (OSError, ValueError):
        return -1


def _readonly_fd(path: Path) -> int:
    try:
        return os.open(path, os.O_RDONLY)
    except OSError as exc:
        log.debug("recorder_events_fsync_unavailable", path=str(path), error=str(exc))
        return -1


def _fsync_if_supported(fd: int) -> None:
    try:
        os.fsync(fd)
    except OSError as exc:
        if exc.errno not in (errno_mod.EINVAL, errno_mod.EROFS):
            raise


def _free_mb(path: Path) -> float | None:
    try:
        return round(shutil.disk_usage(path).free / 1e6, 1)
    except OSError:
        return None


__all__ = [
    "RESERVE_FILE",
    "SUMMARY_RESERVE_BYTES",
    "RecorderUnavailable",
    "RunRecorder",
    "default_opener",
    "run_dir_name",
]
