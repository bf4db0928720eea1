"""The crew drives ``helixd serve`` with QGroundControl's buttons, on real ArduPilot Rover SITL
(opt-in: ``HELIXD_SITL_BIN``).

The ground station is QGroundControl-like (system 255 on SITL's SERIAL2, HEARTBEAT 1 Hz) and
talks only to the autopilot (system 1, component 1), as QGroundControl's buttons do; helixd is
on SERIAL0 with no start switch. Each step sends what QGroundControl's source sends and names
the function it copies:

* Plan view, Upload: the mission protocol, home + three waypoints → ``state=ready``;
* Start Mission (``APMFirmwarePlugin::startMission`` on a disarmed rover): mode GUIDED, a
  normal arm (no force: the Helix setup passes every PreArm check), MAV_CMD_MISSION_START →
  ArduPilot switches to AUTO and helixd drives the autopilot's mission from its current item;
* Pause (``APMFirmwarePlugin::pauseVehicle``: the Hold mode) → outputs at trim within 0.5 s,
  still armed; Continue (the mode menu, Auto) → driving again within 1 s, the same flight;
* set current waypoint (``Vehicle::setCurrentMissionSequence``: DO_SET_MISSION_CURRENT 3) →
  helixd flies to item 3;
* MANUAL from the mode menu → helixd releases its overrides at once (no HOLD, left armed);
* Auto again → to the end: ArduPilot's own "Mission Complete" and helixd's completed flight.

Every step's latency is printed (wall clock, SITL at speed-up 1: what the crew waits).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.sitl.conftest import (
    NEUTRAL_US,
    SitlVehicle,
    outputs_near,
)
from tests.sitl.test_sitl_serve import mono_of
from tests.support import sitl_steps as crew

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

MODE_MANUAL, MODE_HOLD, MODE_AUTO = 0, 4, 10
WAYPOINTS_NE_M = [(10.0, 0.0), (10.0, 8.0), (0.0, 8.0)]  # from home (m)
CONFIG: dict[str, Any] = {
    "mission": {"ground_station_mode": "roll"},
    "startup": {"start_switch_channel": None},  # the crew uses the ground station only
    "serve": {"mission_poll_s": 1.0, "tick_s": 0.05},
    # the service has been up for minutes when a crew presses Start; here seconds
    "link": {"own_id_watch_s": 0.5},
}
START_MAX_S = 1.0
PAUSE_MAX_S = 0.5
CONTINUE_MAX_S = 1.0
MISSION_WAIT_S = 300.0


def test_the_crew_drives_with_qgroundcontrols_buttons(sitl: SitlVehicle, tmp_path: Path) -> None:
    obs = sitl.obs

    with crew.serving_crew(sitl, tmp_path, CONFIG, "QGC on SITL") as (gcs, steps, d):
        note, figures = steps.note, steps.figures
        crew.upload_when_asked(d, lambda: gcs.upload(WAYPOINTS_NE_M, 30.0))  # Plan view: Upload
        assert not obs.armed()

        # Start Mission: APMFirmwarePlugin::startMission — Guided, arm, MISSION_START
        start_s = crew.start_to_driven(sitl, gcs, steps)
        note("Start Mission → scrolls driven", start_s)
        assert obs.mode() == MODE_AUTO
        sitl.wait_driving(d, 1.0, crew.STATE_WAIT_S)

        # Pause: APMFirmwarePlugin::pauseVehicle → Hold
        pause_s = crew.mode_to_outputs(gcs, steps, MODE_HOLD, crew.at_trim, "trim after Pause")
        note("Pause (HOLD) → outputs at trim", pause_s)
        held_from = time.monotonic()
        obs.wait_until(lambda: time.monotonic() >= held_from + 2.0, 5.0, "2 s held")  # watched
        held = [s.pwm_us for s in obs.servo if s.wall_s >= held_from]
        assert held and all(outputs_near(p, NEUTRAL_US) for p in held)
        assert obs.armed() and obs.mode() == MODE_HOLD

        # Continue: the mode menu's Auto
        continue_s = crew.mode_to_outputs(
            gcs, steps, MODE_AUTO, crew.driven, "scrolls driven after Continue"
        )
        note("Continue (AUTO) → scrolls driven", continue_s)
        assert d.log_text().count("event=auto_start") == 1  # the same flight went on

        # set current waypoint: Vehicle::setCurrentMissionSequence → DO_SET_MISSION_CURRENT
        mark = d.mark()
        t_item = time.monotonic()
        item = gcs.command_long(mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT, (3.0,))
        assert item == mavlink2.MAV_RESULT_ACCEPTED, item
        line = d.wait_line("event=auto_start item=3", crew.STEP_WAIT_S, after=mark)
        note("set current waypoint 3 → new flight from item 3", mono_of(line) - t_item)

        # MANUAL from the mode menu: helixd lets go
        mark = d.mark()
        t_manual = crew.set_mode(gcs, MODE_MANUAL)
        line = d.wait_line("event=rc_override_released", crew.STEP_WAIT_S, after=mark)
        note("MANUAL → overrides released", mono_of(line) - t_manual)
        d.wait_line("event=serve_state state=paused", crew.STATE_WAIT_S, after=mark)
        assert obs.armed() and obs.mode() == MODE_MANUAL  # no HOLD asked, not disarmed

        # Auto again, to the end
        mark = d.mark()
        crew.set_mode(gcs, MODE_AUTO)
        d.wait_line("event=serve_state state=completed", MISSION_WAIT_S, after=mark)
    print("QGC on SITL: " + "; ".join(figures))
    assert start_s <= START_MAX_S, figures
    assert pause_s <= PAUSE_MAX_S, figures
    assert continue_s <= CONTINUE_MAX_S, figures
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [False, False, True], summaries
    assert summaries[0]["fault"].startswith("item_set"), summaries[0]
    assert summaries[1]["fault"].startswith("released"), summaries[1]
