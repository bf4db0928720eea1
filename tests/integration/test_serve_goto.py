"""``helixd serve`` driving to the autopilot's own place: QGroundControl's *Go to location* (the
autopilot in GUIDED) and its RTL button (the autopilot in RTL, to the rally point nearer than
home), each held at its end, and MANUAL releasing.

A scripted ground station (system 255, its own UDP link to the simulator) sends what
QGroundControl's source sends for each button; the comment on each step names the QGC
function it copies. helixd learns the place from the autopilot's POSITION_TARGET_GLOBAL_INT.
Everything is judged on the simulator's truth; the latencies (wall time, what the crew waits)
and the end-position errors are printed (run with ``-s``). The simulator runs at 5×.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_REPOSITION,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_FRAME_GLOBAL,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.modes import MODE_NUMBERS
from helixd.sim.snapshot import SimSnapshot
from tests.integration.test_serve_crew_modes import CONFIG, MISSION, driving, overriding_neutral
from tests.support import serve
from tests.support.gcs import QGC_SYSID, SIM, latlon, upload, upload_typed
from tests.support.harness import (
    MavClient,
    deep_merge,
    guard_installed,
    overrides_released,
    record_until,
    secured,
    time_until,
)

FIRST_NE = (10.0, 4.0)  # the first click (m north/east of the EKF origin; home is there)
SECOND_NE = (2.0, 12.0)  # the second click, while driving to the first
RALLY_NE = (-3.0, 17.0)  # 6 m from the second place; home is 12 m away: RTL goes here
ARRIVAL_M = 0.5  # the last waypoint's rule (control.stop_tolerance_m, 0.1 m) and the noise
GUARDED = guard_installed(serve.SPEEDUP)  # helixd-guard installed, as in the field
START_LATENCY_MAX_S = 1.5  # click → scrolls driven (the GUIDED HEARTBEAT comes at 1 Hz)
RELEASE_LATENCY_MAX_S = 0.5


def go_to_location(gcs: MavClient, north_m: float, east_m: float) -> float:
    """QGroundControl's APMFirmwarePlugin::guidedModeGotoLocation: COMMAND_INT
    MAV_CMD_DO_REPOSITION to the autopilot, MAV_FRAME_GLOBAL, param1 -1 (default speed),
    param2 MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, param4 NaN, x/y the click (degE7), z the
    vehicle's AMSL altitude; returns the monotonic time it was sent."""
    lat, lon = latlon(north_m, east_m)
    gcs.drain()
    sent = time.monotonic()
    gcs.mav.command_int_send(
        1, 1, MAV_FRAME_GLOBAL, MAV_CMD_DO_REPOSITION, 0, 0,
        -1.0, float(MAV_DO_REPOSITION_FLAGS_CHANGE_MODE), 0.0, math.nan,
        round(lat * 1e7), round(lon * 1e7), SIM.origin_alt_m,
    )  # fmt: skip
    ack = gcs.expect("COMMAND_ACK", 10.0, lambda m: int(m.command) == MAV_CMD_DO_REPOSITION)
    assert int(ack.result) == MAV_RESULT_ACCEPTED, ack
    return sent


def go_to_location_older(gcs: MavClient, north_m: float, east_m: float) -> float:
    """QGroundControl's older *Go to location* (APMFirmwarePlugin::guidedModeGotoLocation →
    MissionManager::writeArduPilotGuidedMissionItem, after setting GUIDED): a MISSION_ITEM
    (float degrees) to the autopilot's default component, seq 0, MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT, current 2 (a guided-mode place), autocontinue 1, z the
    vehicle's relative altitude; MISSION_ACK ACCEPTED. Returns when it was sent."""
    lat, lon = latlon(north_m, east_m)
    gcs.drain()
    sent = time.monotonic()
    gcs.mav.mission_item_send(
        1, 1, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT, 2, 1,
        0.0, 0.0, 0.0, 0.0, lat, lon, 0.0, mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip
    ack = gcs.expect("MISSION_ACK", 10.0, lambda m: int(m.target_system) == QGC_SYSID)
    assert int(ack.type) == mavlink.MAV_MISSION_ACCEPTED, ack
    return sent


def upload_rally(gcs: MavClient, north_m: float, east_m: float) -> None:
    """QGC's Plan view, Rally Points, Upload: the mission protocol with
    MAV_MISSION_TYPE_RALLY, one MAV_CMD_NAV_RALLY_POINT."""
    lat, lon = latlon(north_m, east_m)
    rally = mavlink.MAV_MISSION_TYPE_RALLY
    item = mavlink.MAVLink_mission_item_int_message(
        1, 1, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_RALLY_POINT,
        0, 1, 0.0, 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0, rally,
    )  # fmt: skip
    upload_typed(gcs, [item], rally, "rally")


def near(ne: tuple[float, float], within_m: float) -> Any:
    def check(s: SimSnapshot) -> bool:
        return math.hypot(s.north_m - ne[0], s.east_m - ne[1]) <= within_m

    return check


def error_m(s: SimSnapshot, ne: tuple[float, float]) -> float:
    return math.hypot(s.north_m - ne[0], s.east_m - ne[1])


def held_there(server: Any, ne: tuple[float, float], mode: str) -> float:
    """Neutral with helixd's overrides kept for 2 s of simulated time, armed, in ``mode``, at
    the place; the end-position error (m)."""
    t0 = server.snapshot().sim_time_s
    held = record_until(server, lambda s: s.sim_time_s >= t0 + 2.0, 30.0)
    later = [s for _, s in held.samples if s.sim_time_s >= t0 + 0.3]
    assert later and all(overriding_neutral(s) and s.armed and s.mode == mode for s in later)
    errors = [error_m(s, ne) for s in later]
    assert max(errors) <= ARRIVAL_M, errors
    return errors[-1]


def test_go_to_location_and_rtl_to_a_rally_point(tmp_path: Path) -> None:
    with serve.serving_crew(tmp_path, CONFIG, **GUARDED) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)  # no mission needed for these
        upload_rally(gcs, *RALLY_NE)
        # Arm (Vehicle::setArmedShowError: MAV_CMD_COMPONENT_ARM_DISARM) in MANUAL
        assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
        serve.heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        assert not server.snapshot().overrides_active[0]

        # Go to location: the first click
        t_click = go_to_location(gcs, *FIRST_NE)
        driven_s = time_until(server, driving, t_click, 20.0)
        moving_s = time_until(server, serve.moving, t_click, 20.0)
        print(f"\nGo to location → scrolls driven: {driven_s:.3f} s, moving: {moving_s:.3f} s")
        assert driven_s <= START_LATENCY_MAX_S, driven_s
        assert server.snapshot().mode == "GUIDED"  # helixd set no mode
        d.wait_line("event=goto_start mode=GUIDED", 5.0)

        # a second click while driving: helixd goes to the new place
        start = server.snapshot()
        server.wait_for(lambda s: error_m(s, (start.north_m, start.east_m)) >= 3.0, 30.0)
        mark = d.mark()
        t_second = go_to_location(gcs, *SECOND_NE)

        def new_flight() -> bool:
            return any("event=serve_flight_start" in ln for ln in d.lines[mark:])

        trace = record_until(server, lambda s: new_flight() and driving(s), 10.0)
        t_handover = trace.first(lambda s: not driving(s), after_s=t_second)
        redirect_s = trace.first(driving, after_s=t_handover) - t_second
        print(
            f"second click → old flight let go: {t_handover - t_second:.3f} s, "
            f"new flight driving: {redirect_s:.3f} s"
        )
        assert redirect_s <= START_LATENCY_MAX_S, redirect_s
        time_until(server, near(SECOND_NE, ARRIVAL_M), t_second, 90.0)
        d.wait_line("event=goto_arrived", 30.0, after=mark)
        end_s = held_there(server, SECOND_NE, "GUIDED")
        print(f"Go to location: held {end_s:.2f} m from the second click")
        snap = server.snapshot()
        assert error_m(snap, FIRST_NE) > 5.0  # it never went on to the first place

        # RTL (APMFirmwarePlugin::guidedModeRTL: _setFlightModeAndValidate(RTL)): the
        # rally point is nearer than home, so ArduPilot's RTL goes there
        mark = d.mark()
        t_rtl = serve.set_mode(gcs, "RTL")
        rtl_s = time_until(server, driving, t_rtl, 10.0)
        print(f"RTL → scrolls driven: {rtl_s:.3f} s")
        assert rtl_s <= START_LATENCY_MAX_S, rtl_s
        # the rally point may come before the HEARTBEAT naming RTL: the flight there can
        # start labelled with the mode before (GUIDED); the place is RTL's all the same
        d.wait_line("event=goto_start", 5.0, after=mark)
        assert gcs.wait_text("Reached destination", 120.0) == "Reached destination"
        d.wait_line("event=goto_arrived", 30.0, after=mark)
        rally_s = held_there(server, RALLY_NE, "RTL")
        print(f"RTL: held {rally_s:.2f} m from the rally point")

        # MANUAL from the flight-mode menu: the pilot drives, helixd lets go at once
        t_manual = serve.set_mode(gcs, "MANUAL")
        manual_s = time_until(server, overrides_released, t_manual, 5.0)
        print(f"MANUAL → overrides released: {manual_s:.3f} s")
        assert manual_s <= RELEASE_LATENCY_MAX_S, manual_s
        serve.heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["MANUAL"])
        snap = server.snapshot()
        assert snap.mode == "MANUAL" and snap.armed  # no HOLD asked, not disarmed
        assert "event=fallback" not in d.log_text()
        d.terminate_ok()
    summaries = serve.flight_summaries(tmp_path)
    causes = [s["fault"].split(":", 1)[0] for s in summaries]
    assert causes == ["handover", "handover", "released"], summaries


def test_a_fault_on_the_way_to_a_place_ends_in_the_fall_back(tmp_path: Path) -> None:
    # the scrolls dig in on the way (stall watchdog shortened): the flight's own fall-back runs
    # (neutral, every override released, HOLD), and the place is not driven to again by itself
    config = deep_merge(CONFIG, {"safety": {"stall": {"duration_s": 1.0}}})
    with serve.serving_crew(tmp_path, config, **GUARDED) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
        serve.heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        t_click = go_to_location(gcs, *FIRST_NE)
        time_until(server, serve.moving, t_click, 20.0)
        t_fault = time.monotonic()
        server.inject("stall", duration_s=600.0)
        secured_s = time_until(server, secured, t_fault, 20.0)
        print(f"\nstall on the way → secured (HOLD, released, neutral): {secured_s:.3f} s")
        d.wait_line("event=fallback cause=stall", 10.0)
        d.wait_line("event=serve_state state=faulted", 10.0)
        # the autopilot's place is still GUIDED's, but HOLD: nothing starts by itself
        t0 = server.snapshot().sim_time_s
        trace = record_until(server, lambda s: s.sim_time_s >= t0 + 3.0, 30.0)
        assert all(secured(s) for _, s in trace.samples)
        assert sum("event=goto_start" in ln for ln in d.lines) == 1
        d.terminate_ok()


SMART_RTL_END_M = 2.5  # ArduPilot pops its last point (home) within WP_RADIUS (2 m)


def test_smart_rtl_follows_the_breadcrumbs_home(tmp_path: Path) -> None:
    with serve.serving_crew(tmp_path, CONFIG, **GUARDED) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        # Arm: ArduPilot starts SmartRTL's path where the rover is (AP_SmartRTL::set_home)
        assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
        serve.heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        home = server.snapshot()
        home_ne = (home.north_m, home.east_m)
        t_click = go_to_location(gcs, *FIRST_NE)
        time_until(server, near(FIRST_NE, ARRIVAL_M), t_click, 90.0)
        d.wait_line("event=goto_arrived", 30.0)
        held_there(server, FIRST_NE, "GUIDED")

        # SmartRTL (the flight-mode menu, or APMFirmwarePlugin::guidedModeRTL(smartRTL))
        mark = d.mark()
        t_srtl = serve.set_mode(gcs, "SMART_RTL")
        srtl_s = time_until(server, driving, t_srtl, 10.0)
        assert gcs.wait_text("Reached destination", 120.0) == "Reached destination"
        back_s = time.monotonic() - t_srtl
        # no place any more (ArduPilot's StopAtHome): once the last one is stale
        # (serve.target_stale_s) or reached, neutral, overrides kept, armed
        stopped_s = time_until(server, overriding_neutral, t_srtl, 10.0) - back_s
        t0 = server.snapshot().sim_time_s
        held = record_until(server, lambda s: s.sim_time_s >= t0 + 2.0, 30.0)
        later = [s for _, s in held.samples if s.sim_time_s >= t0 + 0.5]
        assert later and all(overriding_neutral(s) and s.armed for s in later)
        assert all(s.mode == "SMART_RTL" for s in later)
        end_m = error_m(later[-1], home_ne)
        legs = sum("event=serve_flight_start" in ln for ln in d.lines[mark:])
        print(
            f'\nSmartRTL → scrolls driven: {srtl_s:.3f} s, home ("Reached destination") '
            f"after {back_s:.1f} s over {legs} legs, neutral {stopped_s:.2f} s later, held "
            f"{end_m:.2f} m from home"
        )
        assert end_m <= SMART_RTL_END_M, end_m
        assert legs >= 3  # breadcrumbs every SRTL_ACCURACY (2 m) on the ~11 m way out

        t_manual = serve.set_mode(gcs, "MANUAL")
        time_until(server, overrides_released, t_manual, 5.0)
        assert "event=fallback" not in d.log_text()
        d.terminate_ok()


def test_go_to_location_during_a_mission_and_back_to_auto(tmp_path: Path) -> None:
    with serve.serving_crew(tmp_path, CONFIG, **GUARDED) as (server, gcs, d):
        # QGC's Plan view: Upload; Start Mission (APMFirmwarePlugin::startMission)
        serve.upload_and_start(server, gcs, d, lambda: upload(gcs, MISSION))

        # Go to location mid-mission: the AUTO flight hands over, helixd goes there
        mark = d.mark()
        t_click = go_to_location(gcs, *SECOND_NE)
        d.wait_line("event=goto_start", 10.0, after=mark)
        handover_s = time_until(server, near(SECOND_NE, ARRIVAL_M), t_click, 90.0)
        d.wait_line("event=goto_arrived", 30.0, after=mark)
        held_there(server, SECOND_NE, "GUIDED")
        print(f"\nGo to location during the mission → there in {handover_s:.1f} s")

        # Auto again (the mode menu, or Start Mission on a rover under way): the mission
        # goes on from the autopilot's item, to the end
        mark = d.mark()
        t_auto = serve.set_mode(gcs, "AUTO")
        auto_s = time_until(server, driving, t_auto, 10.0)
        print(f"AUTO after Go to location → scrolls driven: {auto_s:.3f} s")
        d.wait_line("event=auto_start", 10.0, after=mark)
        assert gcs.wait_text("Mission Complete", 120.0) == "Mission Complete"
        d.wait_line("event=serve_state state=completed", 60.0, after=mark)
        d.terminate_ok()
    summaries = serve.flight_summaries(tmp_path)
    causes = [(s["fault"] or "").split(":", 1)[0] for s in summaries]
    assert causes == ["handover", "handover", ""], summaries
    assert summaries[-1]["completed"], summaries[-1]


def test_go_to_location_the_older_way_a_guided_mission_item(tmp_path: Path) -> None:
    """The same click as QGroundControl's older path sends it: GUIDED, then a MISSION_ITEM
    with current 2. ArduPilot takes it as GUIDED's place (refused outside GUIDED) and
    publishes it; helixd drives there and holds, as for DO_REPOSITION."""
    with serve.serving_crew(tmp_path, CONFIG, **GUARDED) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
        serve.heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        # outside GUIDED the item is refused (handle_guided_request): nothing moves
        lat, lon = latlon(*FIRST_NE)
        gcs.mav.mission_item_send(
            1, 1, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT,
            2, 1, 0.0, 0.0, 0.0, 0.0, lat, lon, 0.0, mavlink.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip
        ack = gcs.expect("MISSION_ACK", 10.0, lambda m: int(m.target_system) == QGC_SYSID)
        assert int(ack.type) == mavlink.MAV_MISSION_ERROR, ack
        # setGuidedMode (Vehicle::setFlightMode → MAV_CMD_DO_SET_MODE), then the item
        serve.set_mode(gcs, "GUIDED")
        serve.heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["GUIDED"])
        assert not serve.moving(server.snapshot())
        t_click = go_to_location_older(gcs, *FIRST_NE)
        click_s = time_until(server, driving, t_click, 10.0)
        time_until(server, near(FIRST_NE, ARRIVAL_M), t_click, 90.0)
        d.wait_line("event=goto_arrived", 30.0)
        end_m = held_there(server, FIRST_NE, "GUIDED")
        print(f"\nGo to location (MISSION_ITEM current 2) → driven {click_s:.3f} s; "
              f"held {end_m:.3f} m from the click")  # fmt: skip
        assert click_s <= START_LATENCY_MAX_S, click_s
        t_manual = serve.set_mode(gcs, "MANUAL")
        time_until(server, overrides_released, t_manual, 5.0)
        d.terminate_ok()
