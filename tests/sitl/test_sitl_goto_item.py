"""QGroundControl's older *Go to location* on real ArduPilot Rover SITL (opt-in:
``HELIXD_SITL_BIN``): ``APMFirmwarePlugin::guidedModeGotoLocation`` sets GUIDED, then
``MissionManager::writeArduPilotGuidedMissionItem`` sends a MISSION_ITEM (float degrees) with
``current`` 2 to the autopilot. ArduPilot takes it as GUIDED's place (``GCS_MAVLINK::
handle_mission_item`` → ``handle_guided_request``), MISSION_ACK ACCEPTED, and publishes it
(POSITION_TARGET_GLOBAL_INT); helixd drives there and holds, as for DO_REPOSITION.

The place is where ArduPilot's conversion of the float32 degrees puts it
(``convert_MISSION_ITEM_to_MISSION_ITEM_INT``, float arithmetic: here a few centimetres from
the click, up to about 0.7 m elsewhere); the end-position error is measured against the
place ArduPilot publishes, as helixd logs it (``goto_start``).
"""

from __future__ import annotations

import math
import re
import time
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from tests.sitl.conftest import (
    AUTOPILOT_COMPID,
    AUTOPILOT_SYSID,
    NEUTRAL_US,
    SitlVehicle,
    outputs_near,
)
from tests.sitl.test_sitl_goto import ARRIVAL_M, CONFIG, FIRST_NE, MODE_GUIDED, START_MAX_S
from tests.sitl.test_sitl_serve import HOME_LATLON, serve_proc
from tests.support import sitl_steps as crew

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(900)]


def test_go_to_location_as_a_guided_mission_item(sitl: SitlVehicle, tmp_path: Path) -> None:
    obs = sitl.obs
    gcs = crew.ground_station(sitl)
    lat, lon = ne_to_latlon(*FIRST_NE, *HOME_LATLON)
    lat32, lon32 = float(np.float32(lat)), float(np.float32(lon))  # what MISSION_ITEM carries

    def guided_item() -> int:
        """writeArduPilotGuidedMissionItem: seq 0, NAV_WAYPOINT, GLOBAL_RELATIVE_ALT,
        current 2, autocontinue 1, x/y degrees, z the relative altitude; the MISSION_ACK."""
        with gcs._cond:
            gcs.mission_acks.clear()
        item = gcs.mav.mission_item_encode(
            AUTOPILOT_SYSID, AUTOPILOT_COMPID, 0, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
            mavlink2.MAV_CMD_NAV_WAYPOINT, 2, 1, 0.0, 0.0, 0.0, 0.0, lat32, lon32, 0.0,
            mavlink2.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip
        gcs.send(item)
        acks = gcs.wait_value(lambda: gcs.mission_acks[:1] or None, crew.STEP_WAIT_S, "MISSION_ACK")
        return int(acks[0])

    def first_servo(t0: float, driven: bool) -> float:
        def found() -> float | None:
            return next(
                (
                    s.wall_s
                    for s in obs.servo
                    if s.wall_s >= t0 and outputs_near(s.pwm_us, NEUTRAL_US) != driven
                ),
                None,
            )

        obs.wait_until(lambda: found() is not None, crew.LEG_WAIT_S, "outputs", abort=d.ended)
        at = found()
        assert at is not None
        return at - t0

    d = serve_proc(tmp_path, sitl, CONFIG)
    try:
        d.wait_line("no mission on the autopilot", crew.STATE_WAIT_S)
        arm = gcs.command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        assert arm == mavlink2.MAV_RESULT_ACCEPTED, f"a normal arm was refused ({arm})"
        obs.wait_until(lambda: bool(obs.armed()), crew.STEP_WAIT_S, "armed")
        # outside GUIDED ArduPilot refuses the item (handle_guided_request)
        assert guided_item() == mavlink2.MAV_MISSION_ERROR
        # setGuidedMode, then the item
        assert gcs.set_mode(MODE_GUIDED) == mavlink2.MAV_RESULT_ACCEPTED
        obs.wait_until(lambda: obs.mode() == MODE_GUIDED, crew.STEP_WAIT_S, "GUIDED")
        t_click = time.monotonic()
        assert guided_item() == mavlink2.MAV_MISSION_ACCEPTED
        click_s = first_servo(t_click, driven=True)
        start = d.wait_line("event=goto_start", crew.STEP_WAIT_S)
        found = re.search(r"lat_deg=(\S+) lon_deg=(\S+)", start)
        assert found is not None, start
        place_ne = latlon_to_ne(float(found[1]), float(found[2]), *HOME_LATLON)
        click_m = math.dist(place_ne, FIRST_NE)
        d.wait_line("event=goto_arrived", crew.LEG_WAIT_S)
        held_from = time.monotonic() + first_servo(time.monotonic(), driven=False)
        obs.wait_until(lambda: time.monotonic() >= held_from + 2.0, 5.0, "2 s held")
        held = [s.pwm_us for s in obs.servo if s.wall_s >= held_from]
        assert held and all(outputs_near(p, NEUTRAL_US) for p in held)
        assert obs.armed() and obs.mode() == MODE_GUIDED
        p = obs.position()
        assert p is not None
        end_m = math.hypot(p.north_m - place_ne[0], p.east_m - place_ne[1])
        mark = d.mark()
        assert gcs.set_mode(0) == mavlink2.MAV_RESULT_ACCEPTED  # MANUAL: helixd lets go
        d.wait_line("event=rc_override_released", crew.STEP_WAIT_S, after=mark)
    finally:
        crew.close_serve(d, gcs, tmp_path)
    print(
        f"goto on SITL: Go to location (MISSION_ITEM current 2) → scrolls driven {click_s:.2f} s;"
        f" held {end_m:.2f} m from the place ArduPilot took ({click_m:.2f} m from the click)"
    )
    assert click_s <= START_MAX_S, click_s
    assert end_m <= ARRIVAL_M, end_m
