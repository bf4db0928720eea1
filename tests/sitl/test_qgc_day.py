"""A QGroundControl day on real ArduPilot Rover SITL (opt-in: ``HELIXD_SITL_BIN``), every step's
latency printed: upload, a same-size re-upload, Start, Pause, Continue, set current waypoint,
Go to location, RTL, MANUAL.

The ground station is QGroundControl-like (system 255 on SERIAL2) and talks only to the
autopilot, as QGroundControl's buttons do (tests.support.sitl_steps names the functions each
step copies). The re-upload moves every waypoint 3 m with the same item count: ArduPilot
tells only the uploading link "Flight plan received" and MISSION_CURRENT keeps its count, so
helixd learns of it at the start (``serve.mission_poll_s`` is long here), flies it and says
which plan. Run for rover-skid and for the Helix plant on hard ground.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from helixd.base.frames import ne_to_latlon
from tests.sitl.conftest import (
    AUTOPILOT_COMPID,
    AUTOPILOT_SYSID,
    NEUTRAL_US,
    SitlVehicle,
    outputs_near,
    start_test_sitl,
)
from tests.sitl.test_sitl_serve import HOME_LATLON, GroundStation, mono_of, serve_proc
from tests.support import sitl_steps as crew
from tests.support.daemon import DaemonProc

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1500)]

MODE_MANUAL, MODE_HOLD, MODE_AUTO, MODE_RTL, MODE_GUIDED = 0, 4, 10, 11, 15
PLAN_A = [(10.0, 0.0), (10.0, 8.0), (0.0, 8.0), (-4.0, 8.0)]  # from home (m)
PLAN_B = [(n, e + 3.0) for n, e in PLAN_A]  # re-uploaded: the same count, moved 3 m east
GOTO_NE_M = (6.0, -6.0)
CONFIG: dict[str, Any] = {
    "mission": {"ground_station_mode": "roll"},
    "startup": {"start_switch_channel": None},
    "serve": {"mission_poll_s": 3600.0, "tick_s": 0.05},  # the start notices the re-upload
    "link": {"own_id_watch_s": 0.5},
}
START_MAX_S = 1.0
PAUSE_MAX_S = 0.5
CONTINUE_MAX_S = 1.0


@pytest.fixture(params=[None, "hard"], ids=["rover-skid", "helix"])
def day_sitl(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[SitlVehicle]:
    yield from start_test_sitl(tmp_path, guard=True, terrain=request.param)


def go_to_location(gcs: GroundStation, north_m: float, east_m: float) -> float:
    """APMFirmwarePlugin::guidedModeGotoLocation: COMMAND_INT DO_REPOSITION with the
    change-mode flag to the autopilot; when it was sent."""
    lat, lon = ne_to_latlon(north_m, east_m, *HOME_LATLON)
    with gcs._cond:
        seen = len(gcs.acks)
    flag = float(mavlink2.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE)
    msg = gcs.mav.command_int_encode(
        AUTOPILOT_SYSID, AUTOPILOT_COMPID, mavlink2.MAV_FRAME_GLOBAL,
        mavlink2.MAV_CMD_DO_REPOSITION, 0, 0, -1.0, flag, 0.0, math.nan,
        round(lat * 1e7), round(lon * 1e7), 584.0,
    )  # fmt: skip
    sent = time.monotonic()
    gcs.send(msg)

    def ack() -> int | None:
        return next((r for c, r in gcs.acks[seen:] if c == mavlink2.MAV_CMD_DO_REPOSITION), None)

    result = gcs.wait_value(ack, crew.STEP_WAIT_S, "DO_REPOSITION's COMMAND_ACK")
    assert result == mavlink2.MAV_RESULT_ACCEPTED, result
    return sent


def logged_after(d: DaemonProc, needle: str, since_s: float, mark: int) -> float:
    """Wall seconds from ``since_s`` to the daemon's line containing ``needle``."""
    return mono_of(d.wait_line(needle, crew.STEP_WAIT_S, after=mark)) - since_s


def test_qgc_day(day_sitl: SitlVehicle, tmp_path: Path) -> None:
    sitl = day_sitl
    obs = sitl.obs
    gcs = crew.ground_station(sitl)
    steps = crew.ServoSteps(sitl, "QGC day", crew.STEP_WAIT_S, lambda: d.ended())
    note, after, figures = steps.note, steps.after, steps.figures

    def set_mode(mode: int) -> float:
        sent = time.monotonic()
        assert gcs.set_mode(mode) == mavlink2.MAV_RESULT_ACCEPTED, mode
        return sent

    d = serve_proc(tmp_path, sitl, CONFIG)
    try:
        t_up = time.monotonic()
        crew.upload_when_asked(d, lambda: gcs.upload(PLAN_A, 30.0))  # Plan view: Upload
        note("upload → ready", time.monotonic() - t_up)
        gcs.upload(PLAN_B, 30.0)  # a waypoint moved, uploaded again: the same count

        # Start Mission: Guided, arm, MISSION_START; the new plan is read, checked and flown
        mark = d.mark()
        set_mode(MODE_GUIDED)
        obs.wait_until(lambda: obs.mode() == MODE_GUIDED, crew.STEP_WAIT_S, "GUIDED")
        arm = gcs.command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        assert arm == mavlink2.MAV_RESULT_ACCEPTED, f"a normal arm was refused ({arm})"
        obs.wait_until(lambda: bool(obs.armed()), crew.STEP_WAIT_S, "armed")
        t_start = time.monotonic()
        result = gcs.command_long(mavlink2.MAV_CMD_MISSION_START, (0.0, 0.0))
        assert result == mavlink2.MAV_RESULT_ACCEPTED, result
        start_s = after(t_start, crew.driven, "scrolls driven after Start Mission")
        note("Start Mission (re-uploaded plan) → scrolls driven", start_s)
        flying = d.wait_line("event=serve_state state=flying", crew.STEP_WAIT_S, after=mark)
        assert "the new plan" in flying, flying
        sitl.wait_driving(d, 1.0, crew.STATE_WAIT_S)

        # Pause (Hold) and Continue (Auto)
        t_pause = set_mode(MODE_HOLD)
        pause_s = after(t_pause, lambda p: outputs_near(p, NEUTRAL_US), "trim after Pause")
        note("Pause (HOLD) → outputs at trim", pause_s)
        t_continue = set_mode(MODE_AUTO)
        continue_s = after(t_continue, crew.driven, "scrolls driven after Continue")
        note("Continue (AUTO) → scrolls driven", continue_s)

        # set current waypoint 3 (DO_SET_MISSION_CURRENT to the autopilot)
        mark = d.mark()
        t_item = time.monotonic()
        item = gcs.command_long(mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT, (3.0,))
        assert item == mavlink2.MAV_RESULT_ACCEPTED, item
        note("set current 3 → new flight", logged_after(d, "event=auto_start item=3", t_item, mark))

        # Go to location: DO_REPOSITION → GUIDED; helixd drives there
        mark = d.mark()
        t_goto = go_to_location(gcs, *GOTO_NE_M)
        note("Go to location → flight there", logged_after(d, "event=goto_start", t_goto, mark))

        # RTL: the crew's return; helixd drives home
        mark = d.mark()
        t_rtl = set_mode(MODE_RTL)
        note("RTL → flight home", logged_after(d, "event=goto_start mode=RTL", t_rtl, mark))

        # MANUAL: helixd lets go at once
        mark = d.mark()
        t_manual = set_mode(MODE_MANUAL)
        note("MANUAL → overrides released", logged_after(d, "rc_override_released", t_manual, mark))
        assert obs.armed() and obs.mode() == MODE_MANUAL
    finally:
        crew.close_serve(d, gcs, tmp_path)
    print("QGC day on SITL: " + "; ".join(figures))
    assert start_s <= START_MAX_S, figures
    assert pause_s <= PAUSE_MAX_S, figures
    assert continue_s <= CONTINUE_MAX_S, figures
