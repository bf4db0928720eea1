"""``helixd serve`` obeying the autopilot's mode: the crew's buttons in QGroundControl talk to
the autopilot (system 1), and helixd drives while it is armed in AUTO.

A scripted ground station (system 255, its own UDP link to the simulator) sends what
QGroundControl's source sends for each button; the comment on each step names the QGC
function it copies. Everything is judged on the simulator's truth; the latencies are printed
(run with ``-s``). The simulator runs at 5× (its 1 Hz HEARTBEAT is 0.2 s of wall time); the
latencies are wall time, what the crew waits.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_MISSION_START,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.modes import MODE_NUMBERS
from helixd.sim.snapshot import SimSnapshot
from tests.support.gcs import upload
from tests.support.harness import (
    guard_installed,
    overrides_released,
    record_until,
    scrolls_neutral,
    time_until,
)
from tests.support.serve import (
    SPEEDUP,
    flight_summaries,
    heartbeat_shows,
    moving,
    serving_crew,
    set_mode,
)

# No start switch: the crew uses the ground station. In the field the service has been up for
# minutes when the crew presses Start; here seconds: the preflight's listening window for
# another sender on helixd's id (link.own_id_watch_s, from helixd's first message) is shortened
# so that it is over by then, as it is in the field.
CONFIG: dict[str, Any] = {
    "startup": {"start_switch_channel": None},
    "link": {"own_id_watch_s": 0.5},
}
MISSION = [(10.0, 0.0), (10.0, -8.0), (0.0, -8.0)]  # north/east from the EKF origin (m)
START_LATENCY_MAX_S = 1.0
PAUSE_LATENCY_MAX_S = 0.5
CONTINUE_LATENCY_MAX_S = 1.0
ITEM_LATENCY_MAX_S = 1.0


def driving(s: SimSnapshot) -> bool:
    return s.armed and not scrolls_neutral(s)


def overriding_neutral(s: SimSnapshot) -> bool:
    """helixd's overrides still held, at neutral."""
    return any(s.overrides_active[:4]) and scrolls_neutral(s)


def test_the_crew_drives_helixd_with_qgroundcontrols_buttons(tmp_path: Path) -> None:
    # as in the field: helixd-guard installed (README), so the preflight finds every parameter
    with serving_crew(tmp_path, CONFIG, **guard_installed(SPEEDUP)) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        upload(gcs, MISSION)  # QGC's Plan view: Upload (the mission protocol)
        d.wait_line("event=serve_state state=ready", 30.0)

        # Start Mission: APMFirmwarePlugin::startMission on a disarmed rover —
        # _setFlightModeAndValidate(Guided), _armVehicleAndValidate, then
        # sendMavCommand(defaultComponentId, MAV_CMD_MISSION_START) with params 0
        set_mode(gcs, "GUIDED")
        heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["GUIDED"])
        assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
        heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        assert not server.snapshot().overrides_active[0]  # nothing moves before the start
        t_start = time.monotonic()
        assert gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        driven_s = time_until(server, driving, t_start, 20.0)
        start_s = time_until(server, moving, t_start, 20.0)
        print(f"\nStart Mission → scrolls driven: {driven_s:.3f} s, moving: {start_s:.3f} s")
        assert start_s <= START_LATENCY_MAX_S, start_s
        snap = server.snapshot()
        assert snap.mode == "AUTO" and snap.armed  # helixd neither set MANUAL nor re-armed
        d.wait_line("event=auto_start", 5.0)

        # Pause: APMFirmwarePlugin::pauseVehicle sets the pause flight mode (Rover: Hold)
        t_pause = set_mode(gcs, "HOLD")
        pause_s = time_until(server, scrolls_neutral, t_pause, 5.0)
        print(f"Pause (HOLD) → scrolls neutral: {pause_s:.3f} s")
        assert pause_s <= PAUSE_LATENCY_MAX_S, pause_s
        # held at neutral by helixd's overrides for 2 s of simulated time, still armed
        t_hold = server.snapshot().sim_time_s
        held = record_until(server, lambda s: s.sim_time_s >= t_hold + 2.0, 30.0)
        later = [s for _, s in held.samples if s.sim_time_s >= t_hold + 0.3]
        assert later and all(overriding_neutral(s) and s.armed for s in later)
        assert all(s.mode == "HOLD" for s in later)

        # Continue: Auto again (startMission on a rover already under way, or the
        # flight-mode menu: _setFlightModeAndValidate(Auto))
        t_continue = set_mode(gcs, "AUTO")
        continue_s = time_until(server, driving, t_continue, 10.0)
        print(f"Continue (AUTO) → scrolls driven: {continue_s:.3f} s")
        assert continue_s <= CONTINUE_LATENCY_MAX_S, continue_s
        server.wait_for(moving, 10.0)
        assert sum("event=auto_start" in ln for ln in d.lines) == 1  # the same flight

        # Set current waypoint (Vehicle::setCurrentMissionSequence: DO_SET_MISSION_CURRENT
        # to the autopilot) from item 1 to item 3: helixd goes there
        mark = d.mark()
        t_item = time.monotonic()
        assert gcs.command(MAV_CMD_DO_SET_MISSION_CURRENT, 3) == MAV_RESULT_ACCEPTED
        d.wait_line("event=auto_start item=3", 10.0, after=mark)
        item_s = time_until(server, driving, t_item, 10.0)
        print(f"Set current waypoint 3 → new flight driving: {item_s:.3f} s")
        assert item_s <= ITEM_LATENCY_MAX_S, item_s
        assert server.snapshot().mode == "AUTO"  # no HOLD asked between the flights

        # MANUAL from the flight-mode menu: the pilot drives, helixd lets go at once
        t_manual = set_mode(gcs, "MANUAL")
        manual_s = time_until(server, overrides_released, t_manual, 5.0)
        print(f"MANUAL → overrides released: {manual_s:.3f} s")
        d.wait_line("event=serve_state state=paused", 30.0)
        snap = server.snapshot()
        assert snap.mode == "MANUAL" and snap.armed  # no HOLD asked, not disarmed
        assert "event=fallback" not in d.log_text()

        # AUTO again: a new flight from the item the autopilot is on, to the end
        mark = d.mark()
        set_mode(gcs, "AUTO")
        server.wait_for(moving, 20.0)
        # read on: a ground station's socket left unread overflows and drops the newest
        assert gcs.wait_text("Mission Complete", 120.0) == "Mission Complete"  # ArduPilot's
        assert gcs.wait_text("helixd: completed", 60.0).endswith("3/3 waypoints")
        d.wait_line("event=serve_state state=completed", 10.0, after=mark)
        d.terminate_ok()
    summaries = flight_summaries(tmp_path)
    assert [s["completed"] for s in summaries] == [False, False, True], summaries
    assert summaries[0]["fault"].startswith("item_set: item 3 set"), summaries[0]
    assert summaries[1]["fault"].startswith("released: mode MANUAL"), summaries[1]
