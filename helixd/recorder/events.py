"""Reading a run's ``events.jsonl`` (written by :mod:`helixd.recorder.logging_setup`'s tee).

Every event carries ``event``, ``level``, ``ts`` (ISO UTC) and ``t_mono_s`` (monotonic clock,
the same clock as ``flight.csv``'s ``t_mono_s``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from helixd.recorder.clocks import ClockMap

RUN_STARTED_EVENT = "run_started"
# Events that mark the moment a fault was detected or acted on (earliest one wins); an event
# whose ``cause`` equals the summary's ``fault`` also counts.
FAULT_EVENTS = frozenset({"fault", "fault_detected", "fallback"})
# Low-value periodic events left out of the replay timeline by default.
PERIODIC_EVENTS = frozenset({"progress"})
INTERNAL_KEYS = ("event", "level", "ts", "t_mono_s")
FIELD_TEXT_MAX_CHARS = 160

Event = dict[str, Any]


def read_events(path: Path) -> list[Event]:
    """All events in file order; torn or non-JSON lines (crash mid-write) are skipped."""
    events: list[Event] = []
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        return events
    for line in text.splitlines():
        try:
            item = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(item, dict) and "event" in item:
            events.append(item)
    return events


def _mono(ev: Event) -> float | None:
    value = ev.get("t_mono_s")
    return float(value) if isinstance(value, int | float) else None


def run_start_mono_s(events: list[Event]) -> float | None:
    """Monotonic time the run started (the ``run_started`` event, else the first event)."""
    for ev in events:
        if ev.get("event") == RUN_STARTED_EVENT and _mono(ev) is not None:
            return _mono(ev)
    for ev in events:
        t = _mono(ev)
        if t is not None:
            return t
    return None


def fault_event(events: list[Event], fault: str | None) -> Event | None:
    """The earliest event marking the fault, or None."""
    for ev in events:
        if ev.get("event") in FAULT_EVENTS or (fault is not None and ev.get("cause") == fault):
            return ev
    return None


def fault_time_mono_s(events: list[Event], fault: str | None) -> float | None:
    ev = fault_event(events, fault)
    return None if ev is None else _mono(ev)


@dataclass(frozen=True, slots=True)
class TimelineEntry:
    # wall (monotonic) seconds since the first control step when a ClockMap with rows was
    # given, else since the run started; None if unknown
    t_s: float | None
    ts: str  # ISO-8601 UTC wall clock
    level: str
    event: str
    fields: str  # other keys as compact key=value text
    t_ap_s: float | None = None  # autopilot seconds since the first control step, if known


def _field_text(ev: Event) -> str:
    parts = []
    for key, value in ev.items():
        if key in INTERNAL_KEYS or value is None:
            continue
        text = json.dumps(value, default=str) if not isinstance(value, str) else value
        parts.append(f"{key}={text}")
    joined = " ".join(parts)
    if len(joined) > FIELD_TEXT_MAX_CHARS:
        joined = joined[: FIELD_TEXT_MAX_CHARS - 1] + "…"
    return joined


def timeline(
    events: list[Event], *, include_periodic: bool = False, clocks: ClockMap | None = None
) -> list[TimelineEntry]:
    """Events as timeline entries. With ``clocks`` (from ``flight.csv``) the times count from
    the first control step on both clocks; without, wall time from the run start."""
    t0 = run_start_mono_s(events)
    if clocks is not None and clocks.zero_mono_s is not None:
        t0 = clocks.zero_mono_s
    out: list[TimelineEntry] = []
    for ev in events:
        name = str(ev.get("event"))
        if not include_periodic and name in PERIODIC_EVENTS:
            continue
        t = _mono(ev)
        out.append(
            TimelineEntry(
                t_s=None if t is None or t0 is None else t - t0,
                ts=str(ev.get("ts", "")),
                level=str(ev.get("level", "")),
                event=name,
                fields=_field_text(ev),
                t_ap_s=None if clocks is None or t is None else clocks.autopilot_s(t),
            )
        )
    return out


__all__ = [
    "FAULT_EVENTS",
    "TimelineEntry",
    "fault_event",
    "fault_time_mono_s",
    "read_events",
    "run_start_mono_s",
    "timeline",
]
