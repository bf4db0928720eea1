"""What helixd is doing, as the ground station shows it (pure: events and times in, messages out).

:class:`GcsReporter` turns the daemon's phase changes, waypoints reached and faults into
STATUSTEXT, and its cross-track error and waypoint index into NAMED_VALUE_FLOAT
(``xtrack_m``, ``wp_index``; names ≤ 10 characters as the message allows). It opens no socket,
reads no clock and logs nothing: :meth:`GcsReporter.feed` takes one event,
:meth:`GcsReporter.tick` the current time, and both return the pymavlink messages to send now.

Severities (MAV_SEVERITY): a fault CRITICAL when it stopped the run, otherwise WARNING; a phase
change NOTICE; a waypoint reached INFO. Texts are ASCII (anything else becomes '?'); one of up
to 50 characters goes out as one STATUSTEXT with id 0, a longer one as several such texts,
split between words (:func:`gcs_lines`), each a whole line on a ground station that does not
reassemble chunks. :func:`chunk_statustext` is ArduPilot's own chunking (GCS::send_statustext,
GCS_Common.cpp: 50-character chunks sharing a fresh non-zero id, the last shorter than 50 —
an empty one when the length is a multiple of 50), which
:class:`helixd.link.statustext.StatusTextAssembler` reassembles.

A text the same as one queued within ``repeat_window_s`` is not queued again: a burst of
the same news (a refusal said by two parts of the service, a fault seen twice) shows once.

Rate limit: a token bucket (``rate_hz`` texts per second on average, ``burst`` back to back).
Waiting texts are queued, faults ahead of everything else; when the queue is full the oldest
non-fault text is dropped (a fault only when every queued text is a fault), and once the queue
drains a NOTICE says how many were dropped. NAMED_VALUE_FLOAT goes out at
``named_value_rate_hz`` while a value is known; a non-finite value is never sent. A
non-finite time is ignored (an event fed with one is queued for the next good tick).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.recorder import GcsReportConfig
from helixd.mav.constants import (
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_ERROR,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_NOTICE,
    MAV_SEVERITY_WARNING,
)
from helixd.safety.watchdogs import OPERATOR_CAUSES, cause_words

__all__ = [
    "CHUNK_CHARS",
    "GcsReporter",
    "PhaseChange",
    "Progress",
    "ReportedFault",
    "Said",
    "WaypointReached",
    "chunk_statustext",
    "fault_text",
    "gcs_lines",
    "prefixed_lines",
]

CHUNK_CHARS = 50  # MAVLINK_MSG_STATUSTEXT_FIELD_TEXT_LEN
MAX_CHUNKS = 256  # chunk_seq is a uint8
FLOAT32_MAX = 3.4028234663852886e38
PREFIX = "helixd: "
XTRACK_NAME = "xtrack_m"
WP_INDEX_NAME = "wp_index"

_mav = mavlink.MAVLink(None)


@dataclass(frozen=True, slots=True)
class PhaseChange:
    phase: str  # e.g. "preflight", "armed", "run", "hold", "done"


@dataclass(frozen=True, slots=True)
class WaypointReached:
    index: int  # 0-based (a mission with commands: its item, home 0, less one)
    total: int  # the operator's waypoints (a mission with commands: its items)
    lap: str = ""  # "lap 2 of 3" where a DO_JUMP repeats the item


@dataclass(frozen=True, slots=True)
class ReportedFault:
    name: str
    detail: str = ""
    stopped: bool = True  # the run was stopped by it (CRITICAL) or it is a warning


@dataclass(frozen=True, slots=True)
class Said:
    """A line of the service's own (``helixd serve``: state changes, a mission refused), at
    the MAV_SEVERITY given; ERROR and worse go ahead of other texts as faults do."""

    text: str
    severity: int


@dataclass(frozen=True, slots=True)
class Progress:
    """Latest guidance numbers; None clears one (no longer sent)."""

    xtrack_m: float | None
    wp_index: int | None


Event = PhaseChange | WaypointReached | ReportedFault | Said | Progress


# what helixd's own texts use beyond ASCII, spelt in ASCII (anything else becomes '?')
_ASCII_SPELLING = str.maketrans({"—": "-", "–": "-", "→": "->", "°": " deg", "×": "x", "µ": "u"})


def _ascii(text: str) -> str:
    return "".join(c if " " <= c <= "~" else "?" for c in text.translate(_ASCII_SPELLING))


def fault_text(cause: str, detail: str = "") -> str:
    """A fault as the ground station shows it: "FAULT: GPS lost: …" in words
    (:func:`helixd.safety.watchdogs.cause_words`), a person's stop "stopped: pilot took
    over: …"; never the cause's identifier."""
    head = "stopped" if cause in OPERATOR_CAUSES else "FAULT"
    return f"{head}: {cause_words(cause)}" + (f": {detail}" if detail else "")


def chunk_statustext(severity: int, text: str, text_id: int) -> list[Any]:
    """STATUSTEXT message(s) for ``text`` as GCS::send_statustext splits it.

    ``text_id`` is used only when the text needs more than one message (then it must be
    1..65535); a text of ≤ 50 characters goes out alone with id 0.
    """
    text = _ascii(text)[: CHUNK_CHARS * (MAX_CHUNKS - 1)]
    if len(text) <= CHUNK_CHARS:
        return [_mav.statustext_encode(severity, text.encode("ascii"), 0, 0)]
    if not 1 <= text_id <= 65535:
        raise ValueError("a chunked STATUSTEXT needs an id 1..65535")
    chunks = [text[i : i + CHUNK_CHARS] for i in range(0, len(text), CHUNK_CHARS)]
    if len(chunks[-1]) == CHUNK_CHARS:
        chunks.append("")  # a short chunk ends the text
    return [
        _mav.statustext_encode(severity, c.encode("ascii"), text_id, seq)
        for seq, c in enumerate(chunks)
    ]


@dataclass(slots=True)
class _Queued:
    severity: int
    text: str
    fault: bool


class GcsReporter:
    def __init__(self, config: GcsReportConfig, start_s: float) -> None:
        if not math.isfinite(start_s):
            raise ValueError("start_s must be finite")
        self.config = config
        self.start_s = start_s
        self._tokens = float(config.burst)
        self._last_s = start_s
        self._queue: list[_Queued] = []
        self._dropped = 0
        self._xtrack_m: float | None = None
        self._wp_index: int | None = None
        self._next_value_s = start_s
        self._recent: dict[str, float] = {}  # text → when it was last queued

    @property
    def dropped(self) -> int:
        """Texts dropped because the queue was full and not yet reported."""
        return self._dropped

    @property
    def queued(self) -> int:
        return len(self._queue)

    def feed(self, event: Event, now_s: float) -> list[Any]:
        """One daemon event; returns what may go out at once."""
        if not self.config.enabled:
            return []
        if isinstance(event, Progress):
            x = event.xtrack_m
            # NAMED_VALUE_FLOAT carries a float32: beyond its range is as bad as inf
            self._xtrack_m = x if x is not None and abs(x) <= FLOAT32_MAX else None
            idx = event.wp_index
            self._wp_index = idx if idx is not None and 0 <= idx < 2**24 else None  # exact in f32
            return []
        if isinstance(event, PhaseChange):
            self._enqueue(_Queued(MAV_SEVERITY_NOTICE, f"{PREFIX}{event.phase}", False), now_s)
        elif isinstance(event, Said):
            urgent = event.severity <= MAV_SEVERITY_ERROR
            self._enqueue(_Queued(event.severity, f"{PREFIX}{event.text}", urgent), now_s)
        elif isinstance(event, WaypointReached):
            text = f"{PREFIX}reached WP {event.index + 1}/{event.total}"
            if event.lap:
                text += f" ({event.lap})"
            self._enqueue(_Queued(MAV_SEVERITY_INFO, text, False), now_s)
        else:
            severity = MAV_SEVERITY_CRITICAL if event.stopped else MAV_SEVERITY_WARNING
            text = PREFIX + fault_text(event.name, event.detail)
            self._enqueue(_Queued(severity, text, True), now_s)
        return self._drain(now_s) if math.isfinite(now_s) else []

    def tick(self, now_s: float) -> list[Any]:
        """The passing of time: queued texts the rate now allows, and the named values due."""
        if not self.config.enabled or not math.isfinite(now_s):
            return []
        out = self._drain(now_s)
        if now_s >= self._next_value_s:
            period_s = 1.0 / self.config.named_value_rate_hz
            # catch up without a burst after a stall
            self._next_value_s = max(self._next_value_s + period_s, now_s + period_s / 2)
            boot_ms = int(max(0.0, now_s - self.start_s) * 1000.0) & 0xFFFFFFFF
            if self._xtrack_m is not None:
                name = XTRACK_NAME.encode("ascii")
                out.append(_mav.named_value_float_encode(boot_ms, name, self._xtrack_m))
            if self._wp_index is not None:
                name = WP_INDEX_NAME.encode("ascii")
                out.append(_mav.named_value_float_encode(boot_ms, name, float(self._wp_index)))
        return out

    def _repeated(self, text: str, now_s: float) -> bool:
        """The same text queued within ``repeat_window_s``: not again (the pane has it)."""
        window_s = self.config.repeat_window_s
        if window_s <= 0.0 or not math.isfinite(now_s):
            return False
        recent = self._recent
        for old in [t for t, at in recent.items() if not 0.0 <= now_s - at < window_s]:
            del recent[old]
        if text in recent:
            return True
        recent[text] = now_s
        return False

    def _enqueue(self, item: _Queued, now_s: float) -> None:
        if self._repeated(item.text, now_s):
            return
        if len(self._queue) >= self.config.queue_max:
            victim = next((i for i, q in enumerate(self._queue) if not q.fault), None)
            if victim is None:
                if not item.fault:
                    self._dropped += 1
                    return
                victim = 0  # all faults: the oldest goes
            del self._queue[victim]
            self._dropped += 1
        if item.fault:
            pos = next((i for i, q in enumerate(self._queue) if not q.fault), len(self._queue))
            self._queue.insert(pos, item)
        else:
            self._queue.append(item)

    def _refill(self, now_s: float) -> None:
        elapsed = now_s - self._last_s
        if math.isfinite(elapsed) and elapsed > 0.0:
            cap = float(self.config.burst)
            self._tokens = min(cap, self._tokens + elapsed * self.config.rate_hz)
            self._last_s = now_s

    def _drain(self, now_s: float) -> list[Any]:
        self._refill(now_s)
        out: list[Any] = []
        while self._tokens >= 1.0:
            if self._queue:
                item = self._queue.pop(0)
            elif self._dropped:
                text = f"{PREFIX}{self._dropped} messages dropped (rate limit)"
                item = _Queued(MAV_SEVERITY_NOTICE, text, False)
                self._dropped = 0
            else:
                break
            self._tokens -= 1.0
            out.extend(self._statustext(item.severity, item.text))
        return out

    def _statustext(self, severity: int, text: str) -> list[Any]:
        lines = prefixed_lines(_ascii(text), self.config.max_text_chars)
        return [_mav.statustext_encode(severity, line.encode("ascii"), 0, 0) for line in lines]


def prefixed_lines(text: str, max_chars: int, width: int = CHUNK_CHARS) -> list[str]:
    """:func:`gcs_lines` of a text that starts with ``helixd: ``, the prefix on every line: a
    ground station's message pane shows each as a line of its own, and a continuation without
    it reads as another sender's (or the autopilot's) text. The text's own characters stay
    within ``max_chars``; the prefixes repeated on continuation lines do not count."""
    if not text.startswith(PREFIX):
        return gcs_lines(text, max_chars, width)
    body_width = width - len(PREFIX)
    most = max(1, math.ceil(max_chars / body_width))
    lines = gcs_lines(text[len(PREFIX) :], most * body_width, body_width)
    return [PREFIX + line for line in lines]


def gcs_lines(text: str, max_chars: int, width: int = CHUNK_CHARS) -> list[str]:
    """``text`` as whole lines of at most ``width`` characters, split between words, each
    sent as a STATUSTEXT of its own: many ground stations show every chunk of a chunked text
    as a line, so a 50-character cut split words across lines and a text of exactly 100 or
    150 characters ended in an empty line. At most ``max_chars // width`` lines; a text
    longer than that (helixd's own texts are kept shorter) ends its last line with '...'."""
    lines: list[str] = []
    current = ""
    for word in text.split():
        while len(word) > width:  # one word longer than a line: only it is cut
            if current:
                lines.append(current)
                current = ""
            lines.append(word[:width])
            word = word[width:]
        if not current:
            current = word
        elif len(current) + 1 + len(word) <= width:
            current += " " + word
        else:
            lines.append(current)
            current = word
    if current or not lines:
        lines.append(current)
    most = max(1, max_chars // width)
    if len(lines) > most:
        lines = lines[:most]
        last = lines[-1]
        while len(last) > width - 3 and " " in last:  # cut between words, not in one
            last = last.rsplit(" ", 1)[0]
        lines[-1] = last[: width - 3].rstrip() + "..."
    return lines
