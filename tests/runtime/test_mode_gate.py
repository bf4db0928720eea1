"""The autopilot's mode as the crew's command (pure): what each mode lets a flight of AUTO do,
and the mode as the freshest report tells it (HEARTBEAT, or a later MISSION_CURRENT); what the
mode and its published place let a flight to the autopilot's place do."""

from __future__ import annotations

import pytest

from helixd.base.frames import ne_to_latlon
from helixd.link.vehicle import MissionCurrent, PositionTarget, VehicleState
from helixd.runtime.mode_gate import (
    AUTO_MODE,
    AUTOPILOT_STEPS_AHEAD,
    LEFT_AUTO,
    Gate,
    autopilot_step,
    crew_mode,
    crew_mode_rx_s,
    current_target,
    gate_of,
    goto_gate,
    item_set_by_crew,
    same_place,
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
    # AUTO entered and left between two HEARTBEATs (GUIDED, Start Mission, Pause): the
    # HEARTBEAT's GUIDED is older than the AUTO just left, never a mode to go back to
    assert crew_mode("GUIDED", 10.0, 0, 10.9, True, auto_rx_s=10.5) == LEFT_AUTO
    assert crew_mode("GUIDED", 10.0, 0, 10.9, True, auto_rx_s=9.5) == "GUIDED"
    assert crew_mode("GUIDED", 10.0, 0, 10.9, False, auto_rx_s=10.5) == "GUIDED"


def test_auto_entered_and_left_within_one_heartbeat_is_not_the_older_mode() -> None:
    """QGroundControl's Start Mission (GUIDED, arm, MISSION_START) refused at once: the
    HEARTBEAT still names GUIDED when MISSION_CURRENT says AUTO (10.2), then not AUTO (10.4,
    helixd's HOLD). The mode is not GUIDED again (no place to drive to): AUTO was left."""
    assert crew_mode("GUIDED", 10.0, 1, 10.2, True, auto_rx_s=10.2) == AUTO_MODE
    assert crew_mode("GUIDED", 10.0, 0, 10.4, True, auto_rx_s=10.2) == LEFT_AUTO
    # AUTO last reported before the HEARTBEAT: that HEARTBEAT's mode stands
    assert crew_mode("GUIDED", 10.0, 0, 10.4, True, auto_rx_s=9.5) == "GUIDED"
    assert crew_mode("GUIDED", 10.0, 0, 10.4, True) == "GUIDED"
    # the next HEARTBEAT names the new mode
    assert crew_mode("HOLD", 11.0, 0, 10.4, True, auto_rx_s=10.2) == "HOLD"


def test_when_the_mode_was_reported_is_the_report_it_rests_on() -> None:
    st_ = VehicleState()
    assert crew_mode_rx_s(st_) is None
    st_.mode, st_.last_heartbeat_s = "GUIDED", 10.0
    assert crew_mode_rx_s(st_) == 10.0
    st_.mission_current = MissionCurrent(1, 4, 0, 9.8, 0)  # older than the HEARTBEAT
    assert crew_mode_rx_s(st_) == 10.0
    st_.mission_current = MissionCurrent(1, 4, 0, 10.3, 0)  # 0 from a firmware not seen to fill
    assert crew_mode_rx_s(st_) == 10.0  # tells nothing: the HEARTBEAT's
    st_.mission_current = MissionCurrent(1, 4, 0, 10.3, 1)
    assert crew_mode_rx_s(st_) == 10.3  # AUTO entered, told then
    st_.mission_mode_reported = True
    st_.mission_current = MissionCurrent(1, 4, 0, 10.5, 0)
    assert crew_mode_rx_s(st_) == 10.5  # not AUTO, told then


def test_the_crews_set_current_waypoint_is_any_move_but_on_to_the_next_item() -> None:
    assert not item_set_by_crew(None, 3)  # the first report
    assert not item_set_by_crew(2, 2)
    assert not item_set_by_crew(2, 3)  # ArduPilot's own progress (or the next set by hand)
    assert item_set_by_crew(1, 3)
    assert item_set_by_crew(3, 1)
    assert not item_set_by_crew(3, 0)  # no current item (a reset), not a place to go


def place(north_m: float, east_m: float, rx_s: float = 10.0) -> PositionTarget:
    lat, lon = ne_to_latlon(north_m, east_m, 52.0, 13.0)
    return PositionTarget(round(lat * 1e7), round(lon * 1e7), rx_s)


def test_a_flight_of_auto_hands_over_to_a_mode_with_a_place_only() -> None:
    assert gate_of("GUIDED", AUTO_MODE, place_to_go=True) is Gate.HANDOVER
    assert gate_of("RTL", AUTO_MODE, place_to_go=True) is Gate.HANDOVER
    assert gate_of("GUIDED", AUTO_MODE, place_to_go=False) is Gate.HOLD  # no place yet
    assert gate_of("LOITER", AUTO_MODE, place_to_go=True) is Gate.HOLD  # not driven by helixd
    assert gate_of("AUTO", AUTO_MODE, place_to_go=True) is Gate.DRIVE


@pytest.mark.parametrize(
    ("mode", "target", "gate"),
    [
        ("GUIDED", (0.2, 0.0), Gate.DRIVE),  # the same place (within 0.5 m)
        ("RTL", (0.0, 0.0), Gate.DRIVE),  # the place came before the HEARTBEAT naming RTL
        ("SMART_RTL", (0.0, 0.3), Gate.DRIVE),
        ("GUIDED", (5.0, 0.0), Gate.HANDOVER),  # a new click
        ("RTL", (0.0, 30.0), Gate.HANDOVER),  # RTL's place is elsewhere
        ("AUTO", (0.0, 0.0), Gate.HANDOVER),  # the crew's Start Mission / Auto
        ("GUIDED", None, Gate.HOLD),  # GUIDED from the menu, or the place not renewed
        ("HOLD", None, Gate.HOLD),  # Pause
        (LEFT_AUTO, None, Gate.HOLD),
        ("MANUAL", (0.0, 0.0), Gate.RELEASE),
        ("ACRO", None, Gate.RELEASE),
    ],
)
def test_what_each_mode_and_place_let_a_flight_to_a_place_do(
    mode: str, target: tuple[float, float] | None, gate: Gate
) -> None:
    current = None if target is None else place(*target)
    assert goto_gate(mode, place(0.0, 0.0), current, 0.5) is gate


def test_the_current_place_is_the_modes_own_and_renewed() -> None:
    t = place(1.0, 2.0, rx_s=10.0)
    assert current_target("GUIDED", t, 9.0, 10.5, 1.5) is t
    assert current_target("SMART_RTL", t, None, 10.5, 1.5) is t
    assert current_target("GUIDED", t, 10.0, 10.5, 1.5) is None  # before the mode's HEARTBEAT
    assert current_target("GUIDED", t, 9.0, 11.6, 1.5) is None  # not renewed: no place
    assert current_target("AUTO", t, 9.0, 10.5, 1.5) is None  # AUTO flies helixd's mission
    assert current_target("GUIDED", None, 9.0, 10.5, 1.5) is None


def test_same_place_within_the_distance() -> None:
    assert same_place(place(0.0, 0.0), place(0.3, 0.3), 0.5)
    assert not same_place(place(0.0, 0.0), place(0.4, 0.4), 0.5)
    assert same_place(place(3.0, 4.0), place(3.0, 4.0), 0.0)


# items 1..5: WP, DO_CHANGE_SPEED, WP, WP, DO_JUMP to 2 once: the walk flies 1, 3, 4, 3, 4
WALK = (1, 3, 4, 3, 4)


def test_the_autopilots_own_progress_follows_the_walk_back_through_its_jump() -> None:
    assert autopilot_step(WALK, None, 1) == 0  # the flight's first report
    assert autopilot_step(WALK, 0, 1) == 0
    assert autopilot_step(WALK, 0, 3) == 1
    assert autopilot_step(WALK, 1, 4) == 2
    assert autopilot_step(WALK, 2, 3) == 3  # back through the DO_JUMP: the walk's own move
    assert autopilot_step(WALK, 3, 4) == 4
    assert autopilot_step(WALK, 0, 4) == 2  # a short step passed between two reports
    assert AUTOPILOT_STEPS_AHEAD == 2


def test_a_move_the_walk_does_not_make_is_the_crews() -> None:
    assert autopilot_step(WALK, 3, 1) is None  # item 1 on the second lap: set by hand
    assert autopilot_step(WALK, 1, 1) is None  # back to item 1: the walk never goes there
    assert autopilot_step(WALK, 0, 9) is None  # not in the walk at all
    assert autopilot_step(WALK, 4, 3) is None  # after the last step nothing comes back
    assert autopilot_step(WALK, None, 4) == 2
    assert autopilot_step(WALK, None, 3) == 1


def test_a_do_item_before_the_first_step_at_the_flights_start_is_that_step() -> None:
    # soak seed 10's hour: AUTO from item 4 (a DO_CHANGE_SPEED before waypoint 5) ended each
    # flight at once as the crew's set current, and the next started there again: 580 flights
    walk = (5, 7)
    assert autopilot_step(walk, None, 4) == 0
    assert autopilot_step(walk, 0, 4) is None  # later, a move the walk does not make
    assert autopilot_step(walk, None, 9) is None


def test_no_current_item_leaves_the_autopilot_where_it_was() -> None:
    assert autopilot_step(WALK, 3, 0) == 3
    assert autopilot_step(WALK, None, 0) == 0
    assert autopilot_step((), None, 5) is None
