"""helixd serve's decisions, with numbers alone (helixd.serve.core)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import ne_to_latlon
from helixd.link.vehicle import PositionTarget
from helixd.mav.constants import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
)
from helixd.safety.watchdogs import FaultCause
from helixd.serve.core import (
    AutoWatch,
    GotoWatch,
    Request,
    ServeState,
    ServeView,
    SwitchEdge,
    SwitchWatch,
    answer_auto,
    answer_command,
    answer_goto,
    answer_switch,
    crew_paused,
    radio_live,
    state_after_flight,
)

GCS = frozenset({255})


def view(state: ServeState = ServeState.READY, **kw: object) -> ServeView:
    base: dict[str, object] = {
        "state": state,
        "busy": False,
        "refusal": "",
        "resumable": False,
        "switch_low": False,
        "last_item": 4,
    }
    return ServeView(**{**base, **kw})  # type: ignore[arg-type]


def test_mission_start_from_a_ground_station_starts_a_checked_mission() -> None:
    a = answer_command(view(), MAV_CMD_MISSION_START, (0.0, 0.0), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.START)  # nothing to continue
    a = answer_command(view(resumable=True), MAV_CMD_MISSION_START, (0.0, 4.0), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.CONTINUE)
    a = answer_command(view(resumable=True), MAV_CMD_MISSION_START, (1.0, 0.0), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.START)  # from item 1


@pytest.mark.parametrize(
    ("state", "kw", "result", "why"),
    [
        (ServeState.READY, {"busy": True}, MAV_RESULT_TEMPORARILY_REJECTED, "busy"),
        (ServeState.FLYING, {}, MAV_RESULT_TEMPORARILY_REJECTED, "busy: flying"),
        (ServeState.REFUSED, {"refusal": "wp 2 too far"}, MAV_RESULT_DENIED, "wp 2 too far"),
        (ServeState.IDLE, {}, MAV_RESULT_DENIED, "no mission checked"),
        (ServeState.CONNECTING, {}, MAV_RESULT_DENIED, "no autopilot"),
        (ServeState.READY, {"switch_low": True}, MAV_RESULT_DENIED, "start switch is low"),
    ],
)
def test_mission_start_refused_with_the_reason(
    state: ServeState, kw: dict[str, object], result: int, why: str
) -> None:
    a = answer_command(view(state, **kw), MAV_CMD_MISSION_START, (0.0, 0.0), 255, GCS)
    assert a.result == result and why in a.text and a.request is None


@pytest.mark.parametrize(
    ("params", "why"),
    [
        ((5.0, 0.0), "param1 (first item) 5 is not in the mission: 0 (continue) or an item 1..4"),
        ((-1.0, 0.0), "param1"),
        ((math.nan, 0.0), "param1"),
        ((0.5, 0.0), "param1"),
        ((0.0, 3.0), "param2"),
        ((2.0, 3.0), "param2"),
        ((0.0, -2.0), "param2"),
        ((0.0, math.inf), "param2"),
    ],
)
def test_mission_start_params_outside_what_helixd_flies_are_denied(
    params: tuple[float, float], why: str
) -> None:
    a = answer_command(view(), MAV_CMD_MISSION_START, params, 255, GCS)
    assert a.result == MAV_RESULT_DENIED and why in a.text and a.request is None


@pytest.mark.parametrize("last", [0.0, -1.0, 4.0])
@pytest.mark.parametrize("first", [2, 3, 4])
def test_mission_start_from_a_later_item_to_the_end(first: int, last: float) -> None:
    a = answer_command(view(resumable=True), MAV_CMD_MISSION_START, (float(first), last), 255, GCS)
    assert (a.result, a.request, a.item) == (MAV_RESULT_ACCEPTED, Request.FROM_ITEM, first)
    assert a.text == f"starting from item {first}"


def test_mission_start_from_a_later_item_is_refused_as_any_start() -> None:
    a = answer_command(view(ServeState.FLYING), MAV_CMD_MISSION_START, (3.0, 0.0), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_TEMPORARILY_REJECTED, None)
    a = answer_command(view(switch_low=True), MAV_CMD_MISSION_START, (3.0, 0.0), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_DENIED, None)


def test_commands_from_other_systems_are_denied_and_others_unsupported() -> None:
    a = answer_command(view(), MAV_CMD_MISSION_START, (0.0, 0.0), 250, GCS)
    assert a.result == MAV_RESULT_DENIED and "system 250" in a.text and "255" in a.text
    a = answer_command(view(), MAV_CMD_DO_SET_MODE, (1.0, 4.0), 255, GCS)
    assert a.result == MAV_RESULT_UNSUPPORTED


def test_pause_and_continue() -> None:
    flying = view(ServeState.FLYING)
    a = answer_command(flying, MAV_CMD_DO_PAUSE_CONTINUE, (0.0,), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.PAUSE)
    assert a.text == "pausing: pause from the ground station"  # words, not DO_PAUSE_CONTINUE 0
    assert a.reason == "pause from the ground station"  # what the flight's pause is told
    a = answer_command(view(), MAV_CMD_DO_PAUSE_CONTINUE, (0.0,), 255, GCS)
    assert a.result == MAV_RESULT_DENIED and "not flying" in a.text
    # soak seed 4002: the crew's Start Mission not yet taken (helixd reconnecting, reading the
    # mission), then Pause: that start is cancelled (HOLD asked), not denied and flown later
    for state in (ServeState.CONNECTING, ServeState.IDLE, ServeState.READY, ServeState.FAULTED):
        a = answer_command(
            view(state, self_driving=True), MAV_CMD_DO_PAUSE_CONTINUE, (0.0,), 255, GCS
        )
        assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.HOLD), state
    paused = view(ServeState.PAUSED, resumable=True)
    a = answer_command(paused, MAV_CMD_DO_PAUSE_CONTINUE, (1.0,), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.CONTINUE)
    a = answer_command(paused, MAV_CMD_DO_PAUSE_CONTINUE, (2.0,), 255, GCS)
    assert a.result == MAV_RESULT_DENIED


@given(
    st.sampled_from(list(ServeState)),
    st.booleans(),
    st.booleans(),
    st.booleans(),
    st.sampled_from([MAV_CMD_MISSION_START, MAV_CMD_DO_PAUSE_CONTINUE]),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=2),
    st.integers(1, 255),
)
def test_only_a_ground_station_with_a_startable_mission_ever_gets_a_start(
    state: ServeState,
    busy: bool,
    resumable: bool,
    switch_low: bool,
    command: int,
    params: list[float],
    sender: int,
) -> None:
    """Total on any input; a start or continue is accepted only from a ground station, not
    busy, with a checked mission (READY, PAUSED, FAULTED, COMPLETED) and the switch not low."""
    v = view(state, busy=busy, resumable=resumable, switch_low=switch_low)
    a = answer_command(v, command, tuple(params), sender, GCS)
    if a.request in (Request.START, Request.CONTINUE):
        assert sender in GCS and not busy and not switch_low
        assert state in (
            ServeState.READY,
            ServeState.PAUSED,
            ServeState.FAULTED,
            ServeState.COMPLETED,
        )
    if a.request in (Request.PAUSE, Request.RELEASE):
        assert state is ServeState.FLYING and sender in GCS
    if a.result != MAV_RESULT_ACCEPTED:
        assert a.request is None


def test_continue_releases_a_loiter_without_end_in_flight() -> None:
    held = view(ServeState.FLYING, holding=True)
    a = answer_command(held, MAV_CMD_DO_PAUSE_CONTINUE, (1.0,), 255, GCS)
    assert (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.RELEASE)
    a = answer_command(view(ServeState.FLYING), MAV_CMD_DO_PAUSE_CONTINUE, (1.0,), 255, GCS)
    assert a.result == MAV_RESULT_TEMPORARILY_REJECTED and a.request is None
    a = answer_command(held, MAV_CMD_DO_PAUSE_CONTINUE, (1.0,), 250, GCS)
    assert a.result == MAV_RESULT_DENIED


def test_a_switch_found_high_is_no_start_until_seen_low() -> None:
    w = SwitchWatch(threshold_us=1700)
    assert w.update(None) is SwitchEdge.NONE and w.low
    assert w.update(1900) is SwitchEdge.NONE  # high at boot: not a start
    assert w.update(1900) is SwitchEdge.NONE
    assert w.update(1100) is SwitchEdge.FALLING
    assert w.low
    assert w.update(1100) is SwitchEdge.NONE
    assert w.update(1900) is SwitchEdge.RISING
    assert not w.low
    assert w.update(0) is SwitchEdge.NONE  # not sent: no change
    assert w.update(1600) is SwitchEdge.FALLING


def test_switch_edges_start_and_pause() -> None:
    a = answer_switch(view(), SwitchEdge.RISING)
    assert a is not None and (a.result, a.request) == (MAV_RESULT_ACCEPTED, Request.START)
    a = answer_switch(view(ServeState.PAUSED, resumable=True), SwitchEdge.RISING)
    assert a is not None and a.request is Request.CONTINUE
    a = answer_switch(view(ServeState.REFUSED, refusal="too far"), SwitchEdge.RISING)
    assert a is not None and a.result == MAV_RESULT_DENIED and "too far" in a.text
    a = answer_switch(view(ServeState.FLYING), SwitchEdge.FALLING)
    assert a is not None and a.request is Request.PAUSE
    assert (a.text, a.reason) == ("pausing: start switch low", "start switch low")
    assert answer_switch(view(), SwitchEdge.FALLING) is None
    assert answer_switch(view(ServeState.FLYING), SwitchEdge.NONE) is None


@pytest.mark.parametrize(
    ("code", "cause", "paused", "state"),
    [
        (ExitCode.OK, None, False, ServeState.COMPLETED),
        (ExitCode.OPERATOR_STOP, FaultCause.PAUSED, True, ServeState.PAUSED),
        (ExitCode.OPERATOR_STOP, FaultCause.SIGNAL, True, ServeState.PAUSED),  # while starting
        # the service stopped (SIGINT/SIGTERM) mid-flight: the crew's stop, not a fault
        (ExitCode.OPERATOR_STOP, FaultCause.SIGNAL, False, ServeState.PAUSED),
        (ExitCode.OPERATOR_STOP, FaultCause.PILOT_TAKEOVER, False, ServeState.FAULTED),
        (ExitCode.OPERATOR_STOP, FaultCause.PILOT_TAKEOVER, True, ServeState.FAULTED),
        (ExitCode.FAULT, FaultCause.LINK_LOST, False, ServeState.FAULTED),
        (ExitCode.PREFLIGHT, FaultCause.PREFLIGHT, False, ServeState.FAULTED),
        # a flight of AUTO the crew released to the pilot (MANUAL): AUTO again goes on
        (ExitCode.OPERATOR_STOP, FaultCause.RELEASED, False, ServeState.PAUSED),
        # the crew set another item, or gave the autopilot a new place: the next flight drives
        (ExitCode.OPERATOR_STOP, FaultCause.ITEM_SET, False, ServeState.PAUSED),
        (ExitCode.OPERATOR_STOP, FaultCause.HANDOVER, False, ServeState.PAUSED),
        (ExitCode.FAULT, FaultCause.STALL, True, ServeState.FAULTED),  # a fault mid-pause
    ],
)
def test_state_after_flight(
    code: ExitCode, cause: FaultCause | None, paused: bool, state: ServeState
) -> None:
    assert state_after_flight(code, cause, paused) is state


@pytest.mark.parametrize(
    ("cause", "paused", "crew"),
    [
        (FaultCause.PAUSED, True, True),
        (FaultCause.PAUSED, False, True),
        (None, True, True),  # paused while it was still starting
        (None, False, False),
        (FaultCause.STALL, True, False),  # a fault came first: told as a fault
        (FaultCause.SIGNAL, False, False),
    ],
)
def test_crew_paused(cause: FaultCause | None, paused: bool, crew: bool) -> None:
    assert crew_paused(cause, paused) is crew


def test_armed_in_auto_is_a_start_only_after_being_seen_otherwise() -> None:
    w = AutoWatch()
    assert not w.update(True, "AUTO", False, 1.0)  # found armed in AUTO: not a start
    assert not w.update(True, "HOLD", False, 2.0)
    assert w.update(True, "AUTO", False, 3.0)  # AUTO after HOLD: pending
    assert w.update(True, "AUTO", False, 3.0)  # until taken
    w.taken()
    assert not w.update(True, "AUTO", False, 4.0)
    # disarmed in AUTO is no start (ArduPilot enters AUTO disarmed; nothing moves)
    w = AutoWatch()
    assert not w.update(False, "GUIDED", False, 1.0)
    assert not w.update(False, "AUTO", False, 2.0)
    assert w.update(True, "AUTO", False, 3.0)  # QGroundControl armed, then MISSION_START


def test_the_watch_is_blind_while_flying_and_told_how_a_flight_ended() -> None:
    w = AutoWatch()
    w.update(True, "HOLD", False, 1.0)
    assert w.update(True, "AUTO", False, 2.0)
    w.taken()
    # a pause and a continue inside the flight are the flight's
    assert not w.update(True, "HOLD", True, 3.0)
    assert not w.update(True, "AUTO", True, 4.0)
    # completed (or faulted): the autopilot still shows AUTO until the fall-back's HOLD
    w.flight_ended(left_auto=False)
    assert not w.update(True, "AUTO", False, 5.0)
    assert not w.update(True, "HOLD", False, 6.0)
    assert w.update(True, "AUTO", False, 7.0)
    w.taken()
    # released to the pilot (MANUAL): AUTO again, however soon, starts the next flight
    w.flight_ended(left_auto=True)
    assert w.update(True, "AUTO", False, 8.0)


def test_after_a_refused_starts_hold_the_next_auto_reported_is_a_start() -> None:
    """The HOLD a refused start asked was acknowledged at 10.0 s; the crew's next Start Mission
    puts the autopilot back in AUTO before any report showed the HOLD."""
    w = AutoWatch()
    w.update(True, "HOLD", False, 1.0)
    assert w.update(True, "AUTO", False, 2.0)
    w.taken()  # the start read the mission, refused it and asked HOLD
    assert not w.update(True, "AUTO", True, 9.9)  # blind while the refusal ran
    w.left(acked_s=10.0)
    # the mode held is from before the acknowledgement: no start, however often looked at
    assert not w.update(True, "AUTO", False, 9.9)
    assert not w.update(True, "AUTO", False, 10.0)
    # the first report after it: AUTO again (the crew's Start Mission) is a start
    assert w.update(True, "AUTO", False, 10.2)
    w.taken()
    assert not w.update(True, "AUTO", False, 10.4)


def test_after_a_refused_starts_hold_a_report_of_the_hold_is_the_hold_seen() -> None:
    w = AutoWatch()
    w.left(acked_s=10.0)
    assert not w.update(True, "AUTO", False, None)  # nothing reported yet: no news
    assert not w.update(True, "HOLD", False, 10.1)
    assert w.update(True, "AUTO", False, 12.0)  # the crew's start, seconds later
    # a flight's end forgets the acknowledgement: the ordinary rule again
    w.left(acked_s=20.0)
    w.flight_ended(left_auto=False)
    assert not w.update(True, "AUTO", False, 19.0)
    assert not w.update(True, "AUTO", False, 21.0)


def test_a_pending_start_from_auto_is_answered_once_the_mission_is_judged() -> None:
    a = answer_auto(view(ServeState.READY))
    assert a is not None and a.result == MAV_RESULT_ACCEPTED and a.request is Request.AUTO
    for state in (ServeState.COMPLETED, ServeState.PAUSED, ServeState.FAULTED):
        a = answer_auto(view(state))
        assert a is not None and a.request is Request.AUTO
    assert answer_auto(view(ServeState.IDLE, refusal="reading the autopilot's mission")) is None
    assert answer_auto(view(ServeState.FLYING)) is None
    assert answer_auto(view(busy=True)) is None
    # a refused mission may have been replaced by a same-size upload: the start reads it again
    a = answer_auto(view(ServeState.REFUSED, refusal="too far"))
    assert a is not None and a.request is Request.AUTO and "reading the mission again" in a.text
    a = answer_auto(view(ServeState.REFUSED, refusal="too far", switch_low=True))
    assert a is not None and a.result == MAV_RESULT_DENIED
    a = answer_auto(view(ServeState.IDLE, refusal="no mission on the autopilot: upload one"))
    assert a is not None and a.result == MAV_RESULT_DENIED
    a = answer_auto(view(switch_low=True))  # the pilot's veto holds for the ground station too
    assert a is not None and a.result == MAV_RESULT_DENIED and "switch" in a.text
    a = answer_auto(view(flies_file=True))  # not the autopilot's mission: AUTO means nothing
    assert a is not None and a.result == MAV_RESULT_DENIED and "mission_file" in a.text


def place(north_m: float, east_m: float) -> PositionTarget:
    lat, lon = ne_to_latlon(north_m, east_m, 52.0, 13.0)
    return PositionTarget(round(lat * 1e7), round(lon * 1e7), 0.0)


def test_each_new_place_of_the_autopilot_is_a_start_once() -> None:
    w = GotoWatch(0.5)
    a, b = place(10.0, 0.0), place(0.0, 12.0)
    assert w.update(True, "GUIDED", a, flying=False) is None  # found there: not a start
    assert w.update(True, "GUIDED", place(10.2, 0.0), flying=False) is None  # the same place
    assert w.update(True, "GUIDED", b, flying=False) is b  # a new click
    w.taken(b)
    assert w.update(True, "GUIDED", b, flying=False) is None  # taken: the flight ended there
    assert w.update(True, "GUIDED", a, flying=True) is None  # blind while flying
    assert w.update(True, "RTL", a, flying=False) is a  # RTL's place, another one
    w.taken(a)
    assert w.update(True, "HOLD", None, flying=False) is None  # seen out: a fault's HOLD
    assert w.update(True, "RTL", a, flying=False) is a  # RTL again: the crew's command
    assert w.update(False, "GUIDED", b, flying=False) is None  # disarmed: nothing moves
    assert w.update(True, "GUIDED", None, flying=False) is None  # GUIDED with no place
    assert w.update(True, "AUTO", a, flying=False) is None  # AUTO flies helixd's mission


def test_a_place_is_flown_only_with_a_motion_mode_and_the_switch_not_low() -> None:
    a = answer_goto(view(ServeState.IDLE), "GUIDED", True)
    assert a.result == MAV_RESULT_ACCEPTED and a.request is Request.GOTO  # no mission needed
    assert answer_goto(view(ServeState.CONNECTING), "RTL", True).result == MAV_RESULT_DENIED
    no_mode = answer_goto(view(), "GUIDED", False)
    assert no_mode.result == MAV_RESULT_DENIED and "ground_station_mode" in no_mode.text
    assert answer_goto(view(switch_low=True), "RTL", True).result == MAV_RESULT_DENIED


def test_a_handover_leaves_the_service_paused_not_faulted() -> None:
    state = state_after_flight(ExitCode.OPERATOR_STOP, FaultCause.HANDOVER, False)
    assert state is ServeState.PAUSED


def test_the_start_switch_is_read_only_from_a_live_radio() -> None:
    stale_s = 1.0
    assert radio_live(True, 10.0, 10.5, stale_s)
    assert radio_live(None, 10.0, 11.0, stale_s)  # the receiver bit not reported: RC_CHANNELS
    assert not radio_live(False, 10.0, 10.1, stale_s)  # ArduPilot's radio failsafe
    assert not radio_live(True, 10.0, 11.2, stale_s)  # RC_CHANNELS stopped
    assert not radio_live(True, None, 0.0, stale_s)  # never heard
    assert not radio_live(True, 12.0, 10.0, stale_s)  # a clock gone backwards is no reading


def test_a_switch_high_after_the_radio_came_back_is_no_start_until_seen_low() -> None:
    w = SwitchWatch(threshold_us=1700)
    assert w.update(1100) is SwitchEdge.NONE
    w.lost()  # the radio failsafe: the switch vetoes a start
    assert w.low
    assert w.update(1900) is SwitchEdge.NONE  # back, high: not the pilot's start
    assert w.update(1100) is SwitchEdge.FALLING
    assert w.update(1900) is SwitchEdge.RISING


def test_a_change_of_speed_to_helixd_is_judged_as_rover_judges_one() -> None:
    flying = view(ServeState.FLYING)
    a = answer_command(flying, MAV_CMD_DO_CHANGE_SPEED, (1.0, 0.3, -1.0), 255, GCS)
    assert (a.result, a.request, a.speed_mps) == (MAV_RESULT_ACCEPTED, Request.SPEED, 0.3)
    a = answer_command(flying, MAV_CMD_DO_CHANGE_SPEED, (0.0, 0.4), 255, GCS)  # "airspeed"
    assert (a.result, a.speed_mps) == (MAV_RESULT_ACCEPTED, 0.4)
    for kind in (2.0, 3.0, 1.5, math.nan):  # climb, descent, not a type
        a = answer_command(flying, MAV_CMD_DO_CHANGE_SPEED, (kind, 0.3), 255, GCS)
        assert a.result == MAV_RESULT_DENIED and "speed type" in a.text, kind
    for speed in (-1.0, 0.0, 0.04, math.nan, math.inf):  # -1: no change
        a = answer_command(flying, MAV_CMD_DO_CHANGE_SPEED, (1.0, speed), 255, GCS)
        assert a.result == MAV_RESULT_FAILED and a.request is None, speed
    a = answer_command(view(ServeState.READY), MAV_CMD_DO_CHANGE_SPEED, (1.0, 0.3), 255, GCS)
    assert (a.result, a.text) == (MAV_RESULT_DENIED, "change speed: not flying")
    a = answer_command(flying, MAV_CMD_DO_CHANGE_SPEED, (1.0, 0.3), 250, GCS)
    assert a.result == MAV_RESULT_DENIED and "serve.gcs_system_ids" in a.text
    a = answer_command(flying, MAV_CMD_DO_CHANGE_SPEED, (), 255, GCS)
    assert a.result == MAV_RESULT_DENIED


@given(
    st.sampled_from(list(ServeState)),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=0, max_size=7),
)
def test_a_change_of_speed_is_total_and_asks_only_a_finite_speed(
    state: ServeState, params: list[float]
) -> None:
    a = answer_command(view(state), MAV_CMD_DO_CHANGE_SPEED, tuple(params), 255, GCS)
    if a.request is Request.SPEED:
        assert state is ServeState.FLYING
        assert a.speed_mps is not None and math.isfinite(a.speed_mps) and a.speed_mps >= 0.05
