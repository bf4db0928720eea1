"""A crew's action ends a flight in its own words and colour, never as a fault."""

from __future__ import annotations

from helixd.recorder.outcome import (
    CREW_COLOR,
    FAULT_COLOR,
    crew_ending,
    ending_color,
    ending_label,
    pause_spans,
    result_word,
)


def test_the_crews_endings_are_not_faults() -> None:
    rtl = "handover: mode RTL to 53.5232500 -113.5263200: the next flight drives"
    assert result_word(False, rtl) == "handed over by the crew (new place or mode)"
    assert result_word(False, "paused: pause from the ground station") == "paused by the crew"
    assert result_word(False, "signal: SIGINT") == "stopped by the operator (run or service stop)"
    assert result_word(False, "pilot_takeover: mode changed to MANUAL") == "taken over by the pilot"
    assert result_word(False, "gps_lost: GPS_RAW_INT stopped") == "NOT completed"
    assert result_word(True, None) == "completed"
    assert ending_color(rtl) == CREW_COLOR and ending_label(rtl).startswith("crew: handover")
    assert ending_color("stall: not moving") == FAULT_COLOR
    assert ending_label("stall: x") == "fault: stall: x" and crew_ending("stall: x") is None


def test_pauses_from_the_mode_gate_events() -> None:
    events = [
        {"event": "mode_gate", "gate": "drive", "t_mono_s": 1.0},
        {"event": "mode_gate", "gate": "hold", "t_mono_s": 5.0},
        {"event": "progress", "t_mono_s": 6.0},
        {"event": "mode_gate", "gate": "drive", "t_mono_s": 9.5},
        {"event": "mode_gate", "gate": "hold", "t_mono_s": 12.0},
        {"event": "mode_gate", "gate": "hold", "t_mono_s": "garbled"},
    ]
    assert pause_spans(events) == [(5.0, 9.5), (12.0, None)]
