"""structlog configuration shared by every ``helixd`` command.

* On a terminal: a concise, coloured console line per event on stderr.
* Not on a terminal (systemd/journald, pipes): one logfmt line per event
  (``ts=… level=… event=… key=value``), control characters escaped, never an ANSI code.
* A tee processor writes every event as one JSON line to the active run's ``events.jsonl``
  (:func:`attach_events_file` / :func:`detach_events_file`) and, optionally, to a JSON stream
  given at configuration time. A failing sink (disk full, unwritable) is dropped and ONE
  ``events_file_degraded`` warning is logged; the caller never sees an exception.

Every event carries ``ts`` (ISO-8601 UTC) and ``t_mono_s`` (the monotonic clock, the same clock
as ``flight.csv``'s ``t_mono_s``) so plots and replay can place events on the flight timeline.
"""

from __future__ import annotations

import json
import logging
import sys
import threading
from collections.abc import Callable, MutableMapping
from pathlib import Path
from typing import IO, Any

import structlog
from structlog.typing import EventDict, Processor, WrappedLogger

from helixd.base.clock import now_s

LEVELS = {
    "debug": logging.DEBUG,
    "info": logging.INFO,
    "warning": logging.WARNING,
    "error": logging.ERROR,
    "critical": logging.CRITICAL,
}
TS_KEY = "ts"
MONO_KEY = "t_mono_s"
CONSOLE_TS_SLICE = slice(11, 23)  # HH:MM:SS.mmm out of an ISO-8601 timestamp
LOGFMT_HEAD = (TS_KEY, "level", "event")

log = structlog.get_logger(__name__)


# ---------------------------------------------------------------------------------------------
# Console output


class _StreamLogger:
    """Writes rendered lines to a stream looked up at write time.

    Resolving ``sys.stderr`` on every write (instead of once at configuration) lets rich's
    live display redirect stderr so log lines appear above the operator panel.
    """

    def __init__(self, stream: IO[str] | None) -> None:
        self._stream = stream
        self._lock = threading.Lock()

    def msg(self, message: str) -> None:
        stream = self._stream if self._stream is not None else sys.stderr
        try:
            with self._lock:
                stream.write(message + "\n")
                stream.flush()
        except (OSError, ValueError):
            # stderr gone (journald restarted, pipe closed): nothing left to log it to; count it
            # so `dropped_console_lines()` can report it.
            _CONSOLE_DROPS[0] += 1

    log = debug = info = warn = warning = err = error = critical = exception = fatal = msg


_CONSOLE_DROPS = [0]


def dropped_console_lines() -> int:
    """Number of console log lines that could not be written (stderr closed or broken)."""
    return _CONSOLE_DROPS[0]


def _escape(text: str) -> str:
    out = []
    for ch in text:
        code = ord(ch)
        if ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif code < 0x20 or 0x7F <= code < 0xA0:
            out.append(f"\\x{code:02x}")
        else:
            out.append(ch)
    return "".join(out)


def _logfmt_value(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(round(value, 6))
    if isinstance(value, list | tuple):
        # ``[1,2,3]`` rather than Python's ``"[1, 2, 3]"`` (dicts are flattened by the caller)
        value = "[" + ",".join(_logfmt_value(v) for v in value) + "]"
    text = _escape(value if isinstance(value, str) else str(value))
    if text == "" or any(c in text for c in ' ="'):
        return '"' + text.replace('"', '\\"') + '"'
    return text


def _flat_items(prefix: str, value: Any) -> list[tuple[str, Any]]:
    """``stats={"rx": 5}`` → ``stats.rx=5`` (nested dicts too), everything else as is."""
    if not isinstance(value, dict):
        return [(prefix, value)]
    if not value:
        return [(prefix, "{}")]
    out: list[tuple[str, Any]] = []
    for k, v in value.items():
        out += _flat_items(f"{prefix}.{k}", v)
    return out


def _flatten_dicts(_: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
    """Console only (after the JSON tee): dict values become dotted keys and lists ``[a,b]``,
    as in the logfmt lines, instead of Python reprs."""
    if not any(isinstance(v, dict | list | tuple) for v in event_dict.values()):
        return event_dict
    flat: EventDict = {}
    for k, v in event_dict.items():
        for fk, fv in _flat_items(str(k), v):
            flat[fk] = _logfmt_value(fv) if isinstance(fv, list | tuple) else fv
    return flat


def render_logfmt(_: WrappedLogger, __: str, event_dict: EventDict) -> str:
    """One line, ``ts=… level=… event=… k=v``; control characters escaped, no ANSI codes.

    Dict values are flattened to dotted keys (``stats.rx_messages=10059``), lists and tuples
    written as ``[a,b]``, so no line carries a Python repr.
    """
    parts = [f"{k}={_logfmt_value(event_dict[k])}" for k in LOGFMT_HEAD if k in event_dict]
    parts += [
        f"{_escape(str(fk))}={_logfmt_value(fv)}"
        for k, v in event_dict.items()
        if k not in LOGFMT_HEAD
        for fk, fv in _flat_items(str(k), v)
    ]
    return " ".join(parts)


def _drop_internal(_: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
    event_dict.pop(MONO_KEY, None)
    return event_dict


def _short_ts(_: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
    ts = event_dict.get(TS_KEY)
    if isinstance(ts, str):
        event_dict[TS_KEY] = ts[CONSOLE_TS_SLICE]
    return event_dict


# ---------------------------------------------------------------------------------------------
# JSON tee


def event_json(event_dict: MutableMapping[str, Any]) -> str:
    """The JSON line written for an event (exceptions rendered as text)."""
    data: MutableMapping[str, Any] = dict(event_dict)
    if "exc_info" in data:
        data = structlog.processors.format_exc_info(None, "", data)
    try:
        return json.dumps(data, default=str, ensure_ascii=False)
    except (TypeError, ValueError) as exc:  # circular structure etc.: keep the event readable
        return json.dumps({k: repr(v) for k, v in data.items()} | {"tee_error": str(exc)})


class _LogSink:
    def __init__(self, stream: IO[str], path: str, owned: bool) -> None:
        self.stream = stream
        self.path = path
        self.owned = owned


class _Tee:
    """structlog processor copying every event to JSON sinks; a failing sink is dropped."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.run: _LogSink | None = None
        self.extra: _LogSink | None = None
        # told instead of the events_file_degraded warning when the run's file fails
        self.on_run_error: Callable[[str, OSError], None] | None = None

    def __call__(self, _: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
        if self.run is None and self.extra is None:
            return event_dict
        line = event_json(event_dict) + "\n"
        failed: list[tuple[str, _LogSink, OSError]] = []
        with self._lock:
            for attr in ("run", "extra"):
                sink: _LogSink | None = getattr(self, attr)
                if sink is None:
                    continue
                try:
                    sink.stream.write(line)
                    sink.stream.flush()
                except OSError as exc:
                    setattr(self, attr, None)
                    failed.append((attr, sink, exc))
        for attr, sink, err in failed:
            _close_quietly(sink)
            on_error = self.on_run_error if attr == "run" else None
            if on_error is not None:
                on_error(sink.path, err)  # the run recorder's one record_cut warning
                continue
            log.warning(
                "events_file_degraded",
                path=sink.path,
                errno=err.errno,
                error=err.strerror or str(err),
                note="events are no longer written to this file; the mission continues",
            )
        return event_dict

    def attach_run(self, sink: _LogSink) -> _LogSink | None:
        with self._lock:
            old, self.run = self.run, sink
        return old

    def detach_run(self) -> _LogSink | None:
        with self._lock:
            old, self.run = self.run, None
            self.on_run_error = None
        return old

    def set_extra(self, sink: _LogSink | None) -> None:
        with self._lock:
            self.extra = sink


def _close_quietly(sink: _LogSink) -> OSError | None:
    """Close a sink we opened; return (not raise) the error, the caller decides how to log it."""
    if not sink.owned:
        return None
    try:
        sink.stream.close()
    except OSError as exc:
        return exc
    return None


_TEE = _Tee()


def attach_events_file(path: Path, on_error: Callable[[str, OSError], None] | None = None) -> None:
    """Start teeing every event as JSON lines to ``path`` (append). Raises OSError if it cannot
    be opened — the caller (the run recorder) decides whether that refuses the run. A write
    error later calls ``on_error(path, error)`` (the run recorder's record cut) instead of
    logging ``events_file_degraded``."""
    stream = path.open("a", encoding="utf-8")
    _TEE.on_run_error = on_error
    old = _TEE.attach_run(_LogSink(stream, str(path), owned=True))
    if old is not None:
        _report_close(old)


def detach_events_file() -> None:
    """Stop teeing to the run's events file and close it. Never raises."""
    old = _TEE.detach_run()
    if old is not None:
        _report_close(old)


def events_file_path() -> str | None:
    """Path of the attached events file, or None when none is attached (or it was dropped)."""
    sink = _TEE.run
    return None if sink is None else sink.path


def _report_close(sink: _LogSink) -> None:
    err = _close_quietly(sink)
    if err is not None:
        log.warning(
            "events_file_degraded", path=sink.path, errno=err.errno, error=err.strerror or str(err)
        )


# ---------------------------------------------------------------------------------------------
# Configuration


def configure_logging(
    *,
    tty: bool,
    level: str = "info",
    json_file: IO[str] | None = None,
    stream: IO[str] | None = None,
    clock: Callable[[], float] = now_s,
) -> None:
    """Configure structlog for the whole process (safe to call again, e.g. in tests).

    ``tty``: console renderer (True) or logfmt lines without escape codes (False).
    ``level``: debug | info | warning | error | critical: what the console shows. The events
    tee (events.jsonl) gets every event from info up whatever the console shows (debug too at
    ``level="debug"``): a quiet console (``make demo``'s ``--log-level warning``) never
    thins the run's record.
    ``json_file``: an extra stream receiving every event as a JSON line (not closed here).
    ``stream``: where console lines go (default: ``sys.stderr`` looked up at each write).
    ``clock``: monotonic clock stamped as ``t_mono_s`` on every event.
    """
    try:
        level_no = LEVELS[level.lower()]
    except KeyError:
        raise ValueError(f"unknown log level {level!r}; allowed: {', '.join(LEVELS)}") from None

    def stamp_mono(_: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
        event_dict[MONO_KEY] = round(clock(), 6)
        return event_dict

    record_level_no = min(level_no, LEVELS["info"])

    def console_only(_: WrappedLogger, __: str, event_dict: EventDict) -> EventDict:
        if LEVELS.get(str(event_dict.get("level")), level_no) < level_no:  # tee only
            raise structlog.DropEvent
        return event_dict

    _TEE.set_extra(None if json_file is None else _LogSink(json_file, "json_file", owned=False))
    processors: list[Processor] = [
        structlog.contextvars.merge_contextvars,
        structlog.processors.add_log_level,
        structlog.processors.TimeStamper(fmt="iso", utc=True, key=TS_KEY),
        stamp_mono,
        structlog.processors.StackInfoRenderer(),
        _TEE,
        console_only,
        _drop_internal,
    ]
    if tty:
        processors += [
            _flatten_dicts,
            _short_ts,
            structlog.dev.ConsoleRenderer(
                colors=True,
                timestamp_key=TS_KEY,
                exception_formatter=structlog.dev.plain_traceback,
                pad_event_to=24,
            ),
        ]
    else:
        processors += [structlog.processors.format_exc_info, render_logfmt]
    structlog.configure(
        processors=processors,
        wrapper_class=structlog.make_filtering_bound_logger(record_level_no),
        logger_factory=lambda *_: _StreamLogger(stream),
        cache_logger_on_first_use=False,
    )


__all__ = [
    "LEVELS",
    "attach_events_file",
    "configure_logging",
    "detach_events_file",
    "dropped_console_lines",
    "event_json",
    "events_file_path",
    "render_logfmt",
]
