"""QGroundControl's *Go to location* and RTL to a rally point drive ``helixd serve`` on real
ArduPilot Rover SITL (opt-in: ``HELIXD_SITL_BIN``).

The ground station is QGroundControl-like (system 255 on SITL's SERIAL2) and talks only to the
autopilot, as QGroundControl's buttons do; helixd is on SERIAL0 with no start switch and no
mission on the autopilot. helixd learns each place from ArduPilot's own
POSITION_TARGET_GLOBAL_INT. Each step names the QGroundControl function it copies:

* Plan view, Rally Points, Upload: the mission protocol with MAV_MISSION_TYPE_RALLY;
* Arm (``Vehicle::setArmedShowError``): a normal arm in MANUAL;
* Go to location (``APMFirmwarePlugin::guidedModeGotoLocation``): COMMAND_INT
  MAV_CMD_DO_REPOSITION with the change-mode flag → ArduPilot switches to GUIDED and helixd
  drives there; a second click on the way → helixd goes to the new place and holds there;
* Return (``APMFirmwarePlugin::guidedModeRTL``: the RTL mode) → ArduPilot's RTL goes to the
  rally point (nearer than home) and helixd drives there; ArduPilot says "Reached destination";
* MANUAL from the mode menu → helixd releases its overrides at once;
* SmartRTL → ArduPilot returns by its saved path, each point published in turn; helixd drives
  to each, ArduPilot says "Reached destination" at home and helixd holds there.

Latencies (wall clock, SITL at speed-up 1) and end-position errors (LOCAL_POSITION_NED against
the place) are printed.
"""

from __future__ import annotations

import json
import math
import time
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
)
from tests.sitl.test_sitl_serve import HOME_LATLON, mono_of
from tests.support import sitl_steps as crew

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1200)]

MODE_MANUAL, MODE_GUIDED, MODE_RTL, MODE_SMART_RTL = 0, 15, 11, 12
FIRST_NE = (10.0, 4.0)  # the first click, north/east of home (m)
SECOND_NE = (2.0, 12.0)  # the second click, on the way to the first
RALLY_NE = (-3.0, 17.0)  # 6 m from the second place, home 12 m: ArduPilot's RTL goes here
ARRIVAL_M = 0.5  # the last waypoint's rule (control.stop_tolerance_m, 0.1 m) and the noise
SMART_RTL_END_M = 2.5  # ArduPilot pops its last point (home) within WP_RADIUS (2 m)
CONFIG: dict[str, Any] = {
    "mission": {"ground_station_mode": "roll"},
    "startup": {"start_switch_channel": None},
    "serve": {"tick_s": 0.05},
    "link": {"own_id_watch_s": 0.5},
}
START_MAX_S = 1.5  # click → scrolls driven (ArduPilot's HEARTBEAT naming GUIDED is 1 Hz)


def test_go_to_location_and_rtl_to_a_rally_point(sitl: SitlVehicle, tmp_path: Path) -> None:
    obs = sitl.obs

    def error_m(ne: tuple[float, float]) -> float:
        p = obs.position()
        assert p is not None
        return math.hypot(p.north_m - ne[0], p.east_m - ne[1])

    def upload_rally(north_m: float, east_m: float) -> None:
        lat, lon = ne_to_latlon(north_m, east_m, *HOME_LATLON)
        rally = mavlink2.MAV_MISSION_TYPE_RALLY
        with gcs._cond:
            gcs.mission_requests.clear()
            gcs.mission_acks.clear()
        gcs.send(gcs.mav.mission_count_encode(AUTOPILOT_SYSID, AUTOPILOT_COMPID, 1, rally))
        gcs.wait_value(lambda: gcs.mission_requests[:1] or None, crew.STEP_WAIT_S, "rally request")
        item = gcs.mav.mission_item_int_encode(
            AUTOPILOT_SYSID, AUTOPILOT_COMPID, 0, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
            mavlink2.MAV_CMD_NAV_RALLY_POINT, 0, 1, 0.0, 0.0, 0.0, 0.0,
            round(lat * 1e7), round(lon * 1e7), 0.0, rally,
        )  # fmt: skip
        gcs.send(item)
        result = gcs.wait_value(lambda: gcs.mission_acks[:1] or None, crew.STEP_WAIT_S, "rally ack")
        assert result == [mavlink2.MAV_MISSION_ACCEPTED], result

    def held_at(ne: tuple[float, float], mode: int, what: str) -> None:
        """Outputs at trim for 2 s, armed, in ``mode``, within ARRIVAL_M of the place (from
        the first SERVO_OUTPUT_RAW at trim: the arrival's neutral is a report behind)."""
        held_from = time.monotonic() + after(time.monotonic(), crew.at_trim, "trim at the place")
        obs.wait_until(lambda: time.monotonic() >= held_from + 2.0, 5.0, "2 s held")
        held = [s.pwm_us for s in obs.servo if s.wall_s >= held_from]
        assert held and all(outputs_near(p, NEUTRAL_US) for p in held)
        assert obs.armed() and obs.mode() == mode
        note(f"{what}: end-position error", error_m(ne), "m")
        assert error_m(ne) <= ARRIVAL_M, figures

    with crew.serving_crew(sitl, tmp_path, CONFIG, "goto on SITL") as (gcs, steps, d):
        note, after, figures = steps.note, steps.after, steps.figures
        d.wait_line("no mission on the autopilot", crew.STATE_WAIT_S)
        upload_rally(*RALLY_NE)  # Plan view, Rally Points, Upload
        arm = gcs.command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        assert arm == mavlink2.MAV_RESULT_ACCEPTED, f"a normal arm was refused ({arm})"
        obs.wait_until(lambda: bool(obs.armed()), crew.STEP_WAIT_S, "armed")

        # Go to location, then a second click on the way
        t_click = crew.go_to_location(gcs, *FIRST_NE)
        note(
            "Go to location → scrolls driven", after(t_click, crew.driven, "driven after the click")
        )
        assert obs.mode() == MODE_GUIDED
        sitl.wait_driving(d, 3.0, crew.STATE_WAIT_S)
        mark = d.mark()
        t_second = crew.go_to_location(gcs, *SECOND_NE)
        line = d.wait_line("event=serve_flight_start", crew.STEP_WAIT_S, after=mark)
        note("second click → new flight", mono_of(line) - t_second)
        d.wait_line("event=goto_arrived", crew.LEG_WAIT_S, after=mark)
        held_at(SECOND_NE, MODE_GUIDED, "Go to location")

        # Return: ArduPilot's RTL to the rally point
        mark = d.mark()
        t_rtl = time.monotonic()
        assert gcs.set_mode(MODE_RTL) == mavlink2.MAV_RESULT_ACCEPTED
        note("RTL → scrolls driven", after(t_rtl, crew.driven, "driven after RTL"))
        d.wait_line("event=goto_arrived", crew.LEG_WAIT_S, after=mark)
        obs.wait_until(
            lambda: "Reached destination" in obs.statustexts,
            crew.STEP_WAIT_S,
            "Reached destination",
        )
        held_at(RALLY_NE, MODE_RTL, "RTL to the rally point")

        # MANUAL: helixd lets go
        mark = d.mark()
        t_manual = time.monotonic()
        assert gcs.set_mode(MODE_MANUAL) == mavlink2.MAV_RESULT_ACCEPTED
        line = d.wait_line("event=rc_override_released", crew.STEP_WAIT_S, after=mark)
        note("MANUAL → overrides released", mono_of(line) - t_manual)
        assert obs.armed() and obs.mode() == MODE_MANUAL  # no HOLD asked, not disarmed

        # SmartRTL (guidedModeRTL(smartRTL), or the mode menu): back by ArduPilot's saved path
        # (from the arming at home), each point a new flight, until ArduPilot's path is empty
        mark = d.mark()
        reached_before = obs.statustexts.count("Reached destination")
        t_srtl = time.monotonic()
        assert gcs.set_mode(MODE_SMART_RTL) == mavlink2.MAV_RESULT_ACCEPTED
        note("SmartRTL → scrolls driven", after(t_srtl, crew.driven, "driven after SmartRTL"))
        obs.wait_until(
            lambda: obs.statustexts.count("Reached destination") > reached_before,
            crew.LEG_WAIT_S,
            "SmartRTL's Reached destination",
        )
        note("SmartRTL → Reached destination", time.monotonic() - t_srtl)
        held_from = time.monotonic() + after(time.monotonic(), crew.at_trim, "trim at home")
        obs.wait_until(lambda: time.monotonic() >= held_from + 2.0, 5.0, "2 s held")
        held = [s.pwm_us for s in obs.servo if s.wall_s >= held_from]
        assert held and all(outputs_near(p, NEUTRAL_US) for p in held)
        assert obs.armed() and obs.mode() == MODE_SMART_RTL
        legs = sum("event=serve_flight_start" in ln for ln in d.lines[mark:])
        note("SmartRTL: flights (points)", float(legs), "")
        note("SmartRTL: end-position error from home", error_m((0.0, 0.0)), "m")
        assert error_m((0.0, 0.0)) <= SMART_RTL_END_M, figures
        mark = d.mark()
        assert gcs.set_mode(MODE_MANUAL) == mavlink2.MAV_RESULT_ACCEPTED
        d.wait_line("event=rc_override_released", crew.STEP_WAIT_S, after=mark)
        assert "event=fallback" not in d.log_text()
    print("goto on SITL: " + "; ".join(figures))
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert all(not s["completed"] for s in summaries), summaries
    assert summaries[-1]["fault"].startswith("released"), summaries[-1]
