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

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.sitl.conftest import SitlVehicle, start_test_sitl
from tests.sitl.test_sitl_serve import mono_of
from tests.support import sitl_steps as crew
from tests.support.daemon import DaemonProc

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1500)]

MODE_MANUAL, MODE_HOLD, MODE_AUTO, MODE_RTL = 0, 4, 10, 11
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


def logged_after(d: DaemonProc, needle: str, since_s: float, mark: int) -> float:
    """Wall seconds from ``since_s`` to the daemon's line containing ``needle``."""
    return mono_of(d.wait_line(needle, crew.STEP_WAIT_S, after=mark)) - since_s


def test_qgc_day(day_sitl: SitlVehicle, tmp_path: Path) -> None:
    sitl = day_sitl
    obs = sitl.obs

    with crew.serving_crew(sitl, tmp_path, CONFIG, "QGC day") as (gcs, steps, d):
        note, figures = steps.note, steps.figures
        t_up = time.monotonic()
        crew.upload_when_asked(d, lambda: gcs.upload(PLAN_A, 30.0))  # Plan view: Upload
        note("upload → ready", time.monotonic() - t_up)
        gcs.upload(PLAN_B, 30.0)  # a waypoint moved, uploaded again: the same count

        # Start Mission: Guided, arm, MISSION_START; the new plan is read, checked and flown
        mark = d.mark()
        start_s = crew.start_to_driven(sitl, gcs, steps)
        note("Start Mission (re-uploaded plan) → scrolls driven", start_s)
        flying = d.wait_line("event=serve_state state=flying", crew.STEP_WAIT_S, after=mark)
        assert "the new plan" in flying, flying
        sitl.wait_driving(d, 1.0, crew.STATE_WAIT_S)

        # Pause (Hold) and Continue (Auto)
        pause_s = crew.mode_to_outputs(gcs, steps, MODE_HOLD, crew.at_trim, "trim after Pause")
        note("Pause (HOLD) → outputs at trim", pause_s)
        continue_s = crew.mode_to_outputs(
            gcs, steps, MODE_AUTO, crew.driven, "scrolls driven after Continue"
        )
        note("Continue (AUTO) → scrolls driven", continue_s)

        # set current waypoint 3 (DO_SET_MISSION_CURRENT to the autopilot)
        mark = d.mark()
        t_item = time.monotonic()
        item = gcs.command_long(mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT, (3.0,))
        assert item == mavlink2.MAV_RESULT_ACCEPTED, item
        note("set current 3 → new flight", logged_after(d, "event=auto_start item=3", t_item, mark))

        # Go to location: DO_REPOSITION → GUIDED; helixd drives there
        mark = d.mark()
        t_goto = crew.go_to_location(gcs, *GOTO_NE_M)
        note("Go to location → flight there", logged_after(d, "event=goto_start", t_goto, mark))

        # RTL: the crew's return; helixd drives home
        mark = d.mark()
        t_rtl = crew.set_mode(gcs, MODE_RTL)
        note("RTL → flight home", logged_after(d, "event=goto_start mode=RTL", t_rtl, mark))

        # MANUAL: helixd lets go at once
        mark = d.mark()
        t_manual = crew.set_mode(gcs, MODE_MANUAL)
        note("MANUAL → overrides released", logged_after(d, "rc_override_released", t_manual, mark))
        assert obs.armed() and obs.mode() == MODE_MANUAL
    print("QGC day on SITL: " + "; ".join(figures))
    assert start_s <= START_MAX_S, figures
    assert pause_s <= PAUSE_MAX_S, figures
    assert continue_s <= CONTINUE_MAX_S, figures
