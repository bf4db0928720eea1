"""The autopilot's mode as the crew's command (pure): what each mode lets a flight of AUTO do,
and the mode as the freshest report tells it (HEARTBEAT, or a later MISSION_CURRENT)."""

from __future__ import annotations

import pytest

from helixd.runtime.mode_gate import (
    AUTO_MODE,
    LEFT_AUTO,
    Gate,
    crew_mode,
    gate_of,
    item_set_by_crew,
)


@pytest.mark.parametrize(
    ("mode", "gate"),
    [
        ("AUTO", Gate.DRIVE),
        ("HOLD", Gate.HOLD),  # QGroundControl's Pause for a rover
        ("LOITER", Gate.HOLD),
        ("GUIDED", Gate.HOLD),
        ("RTL", Gate.HOLD),
        ("SMART_RTL", Gate.HOLD),
        (LEFT_AUTO, Gate.HOLD),  # AUTO left, the new mode not yet in a HEARTBEAT
        ("", Gate.HOLD),
        ("MANUAL", Gate.RELEASE),  # the pilot drives
        ("ACRO", Gate.RELEASE),
        ("STEERING", Gate.RELEASE),
    ],
)
def test_what_each_mode_lets_a_flight_of_auto_do(mode: str, gate: Gate) -> None:
    assert gate_of(mode, AUTO_MODE) is gate


def test_the_freshest_report_tells_the_mode() -> None:
    # no MISSION_CURRENT newer than the HEARTBEAT, or an autopilot that does not fill it
    assert crew_mode("AUTO", 10.0, 0, 9.9, True) == "AUTO"
    assert crew_mode("AUTO", 10.0, 0, 10.1, False) == "AUTO"  # 0 from any firmware
    assert crew_mode("HOLD", 10.0, 1, 10.1, False) == AUTO_MODE  # 1 only from one that fills
    assert crew_mode("AUTO", 10.0, None, 10.1, True) == "AUTO"
    assert crew_mode("HOLD", 10.0, 1, None, True) == "HOLD"
    # a later MISSION_CURRENT says AUTO was left, or entered, before the next HEARTBEAT
    assert crew_mode("AUTO", 10.0, 0, 10.1, True) == LEFT_AUTO
    assert crew_mode("HOLD", 10.0, 1, 10.1, True) == AUTO_MODE
    assert crew_mode("HOLD", None, 1, 10.1, True) == AUTO_MODE
    # agreeing reports: the HEARTBEAT's mode (it names it)
    assert crew_mode("MANUAL", 10.0, 0, 10.1, True) == "MANUAL"
    assert crew_mode("AUTO", 10.0, 1, 10.1, True) == "AUTO"


def test_the_crews_set_current_waypoint_is_any_move_but_on_to_the_next_item() -> None:
    assert not item_set_by_crew(None, 3)  # the first report
    assert not item_set_by_crew(2, 2)
    assert not item_set_by_crew(2, 3)  # ArduPilot's own progress (or the next set by hand)
    assert item_set_by_crew(1, 3)
    assert item_set_by_crew(3, 1)
    assert not item_set_by_crew(3, 0)  # no current item (a reset), not a place to go
