"""How a flight ended, in the words the records use (pure): a crew's action — a pause, a
handover to a new place or mode (the crew's RTL, Go to location), another item, a release to
the pilot, a pilot's takeover, a stop of the run or service — is an outcome of its own, not a
fault; the replay's result line and the plots say it in its own words and colour."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

# the summary's fault starts with its cause ("handover: mode RTL …"); these are the crew's
CREW_ENDINGS: dict[str, str] = {
    "paused": "paused by the crew",
    "released": "released to the pilot",
    "handover": "handed over by the crew (new place or mode)",
    "item_set": "moved on to another item by the crew",
    "pilot_takeover": "taken over by the pilot",
    "signal": "stopped by the operator (run or service stop)",
}
FAULT_COLOR = "red"
CREW_COLOR = "tab:purple"
PAUSE_GATE = "hold"  # a mode_gate event's gate while the crew holds the flight


def ending_cause(fault: str | None) -> str:
    """The cause a summary's ``fault`` ("cause: detail") starts with ("" for none)."""
    return (fault or "").split(":", 1)[0].strip()


def crew_ending(fault: str | None) -> str | None:
    """The crew's ending in words, or None: no ending of the crew's (a fault, or none)."""
    return CREW_ENDINGS.get(ending_cause(fault))


def result_word(completed: bool, fault: str | None) -> str:
    """The result line's word: completed, the crew's ending, or NOT completed."""
    if completed:
        return "completed"
    return crew_ending(fault) or "NOT completed"


def ending_label(fault: str) -> str:
    """A plot's label for where the flight ended: ``crew: handover: …`` or ``fault: …``."""
    return f"{'crew' if crew_ending(fault) else 'fault'}: {fault}"


def ending_color(fault: str | None) -> str:
    return CREW_COLOR if crew_ending(fault) else FAULT_COLOR


def pause_spans(events: Iterable[Mapping[str, Any]]) -> list[tuple[float, float | None]]:
    """The monotonic (start, end) of each time the flight was held for the crew, from its
    ``mode_gate`` events (end None: held until the flight ended)."""
    spans: list[tuple[float, float | None]] = []
    start: float | None = None
    for ev in events:
        t = ev.get("t_mono_s")
        if ev.get("event") != "mode_gate" or not isinstance(t, int | float):
            continue
        held = ev.get("gate") == PAUSE_GATE
        if held and start is None:
            start = float(t)
        elif not held and start is not None:
            spans.append((start, float(t)))
            start = None
    if start is not None:
        spans.append((start, None))
    return spans


__all__ = [
    "CREW_COLOR",
    "CREW_ENDINGS",
    "FAULT_COLOR",
    "crew_ending",
    "ending_cause",
    "ending_color",
    "ending_label",
    "pause_spans",
    "result_word",
]
