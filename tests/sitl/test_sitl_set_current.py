"""QGroundControl's *set current waypoint* in a mission with commands, on real ArduPilot Rover
SITL (opt-in: ``HELIXD_SITL_BIN``).

The mission loops once (DO_JUMP), with a DO_CHANGE_SPEED in the loop: ArduPilot walks it
1, 3, 4, 3, 4. The crew starts it as QGroundControl does (``APMFirmwarePlugin::startMission``:
GUIDED, a normal arm, MISSION_START to the autopilot) and helixd drives the autopilot's AUTO.
The autopilot's item moves back by itself at the jump (4 → 3): helixd follows it along its walk
and goes on. On the second lap the crew sets item 1 (``Vehicle::setCurrentMissionSequence``:
MAV_CMD_DO_SET_MISSION_CURRENT to the autopilot): a move the walk does not make, so helixd ends
the flight without HOLD and the next flight drives from item 1 with the jump counters
ArduPilot kept (``AP_Mission::set_current_cmd``): one lap, 1 3 4, and both complete.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.sitl.conftest import (
    SitlVehicle,
)
from tests.sitl.test_sitl_qgc import CONFIG, MODE_AUTO
from tests.sitl.test_sitl_serve import mono_of, serve_proc
from tests.support import sitl_steps as crew

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

SPEED_MPS = 0.5  # the DO_CHANGE_SPEED in the loop
ITEMS: list[tuple[float, float] | tuple[int, tuple[float, ...]]] = [
    (6.0, 0.0),  # 1
    (mavlink2.MAV_CMD_DO_CHANGE_SPEED, (1.0, SPEED_MPS, -1.0)),  # 2
    (6.0, 6.0),  # 3
    (0.0, 6.0),  # 4
    (mavlink2.MAV_CMD_DO_JUMP, (2.0, 1.0)),  # 5: back to item 2, once
]
LAP_WAIT_S = 180.0
MISSION_WAIT_S = 300.0
ITEM_MAX_S = 1.0  # the crew's command to the next flight's start


def test_set_current_waypoint_in_a_commands_mission(sitl: SitlVehicle, tmp_path: Path) -> None:
    obs = sitl.obs
    gcs = crew.ground_station(sitl)
    d = serve_proc(tmp_path, sitl, CONFIG)
    try:
        crew.upload_when_asked(d, lambda: gcs.upload_items(ITEMS, 30.0))  # Plan view: Upload

        # Start Mission: APMFirmwarePlugin::startMission — Guided, arm, MISSION_START
        result = crew.start_mission(sitl, gcs)
        assert result == mavlink2.MAV_RESULT_ACCEPTED, result
        d.wait_line("event=auto_start", crew.STEP_WAIT_S)

        # the autopilot's own walk: 1, 3, 4, then back to 3 through the jump (lap 2)
        def items_seen() -> list[int]:
            return [seq for _, seq in gcs.mission_current if seq > 0]

        def on_lap_2() -> bool:
            seen = items_seen()
            return any(seen[i : i + 3] == [3, 4, 3] for i in range(len(seen)))

        obs.wait_until(on_lap_2, LAP_WAIT_S, "the autopilot on lap 2", abort=d.ended)
        assert obs.mode() == MODE_AUTO
        # helixd has seen lap 2 too (its own MISSION_CURRENT stream: a click within one period
        # of the jump would beat its report, and the counters it holds would be lap 1's)
        d.wait_line("event=autopilot_step item=3 step=4", crew.STEP_WAIT_S)
        assert "event=autopilot_item_set" not in d.log_text()  # the jump back is the walk's

        # set current waypoint 1: Vehicle::setCurrentMissionSequence → DO_SET_MISSION_CURRENT
        mark = d.mark()
        t_item = time.monotonic()
        item = gcs.command_long(mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT, (1.0,))
        assert item == mavlink2.MAV_RESULT_ACCEPTED, item
        d.wait_line("event=autopilot_item_set item=1", crew.STEP_WAIT_S, after=mark)
        line = d.wait_line("event=serve_flight_start request=auto", crew.STEP_WAIT_S, after=mark)
        item_s = mono_of(line) - t_item
        print(f"set current waypoint 1 on lap 2 → new flight from item 1: {item_s:.2f} s")
        d.wait_line("event=serve_state state=completed", MISSION_WAIT_S, after=mark)
    finally:
        crew.close_serve(d, gcs, tmp_path)
    assert item_s <= ITEM_MAX_S, item_s
    log = d.log_text()
    assert log.count("event=autopilot_item_set") == 1, log
    assert "event=auto_walk_held first_item=1 step=4 exact=true" in log
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [False, True], summaries
    assert summaries[0]["fault"].startswith("item_set: item 1 set"), summaries[0]
    # one lap from item 1: the jump ArduPilot took once of once is not taken again
    assert [a["number"] for a in summaries[1]["arrivals"]] == [1, 3, 4], summaries[1]
    print(f"arrivals after the set: {[a['number'] for a in summaries[1]['arrivals']]}")
