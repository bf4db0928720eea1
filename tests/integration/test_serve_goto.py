"""``helixd serve`` driving to the autopilot's own place: QGroundControl's *Go to location* (the
autopilot in GUIDED) and its RTL button (the autopilot in RTL, to the rally point nearer than
home), each held at its end, and MANUAL releasing.

A scripted ground station (system 255, on the simulator's second link) sends what
QGroundControl's source sends for each button; the comment on each step names the QGC
function it copies. helixd learns the place from the autopilot's POSITION_TARGET_GLOBAL_INT.
Everything is judged on the simulator's truth; the latencies (what the crew waits, exactly, on
the simulated clock the service and the simulator share) and the end-position errors are
printed (run with ``-s``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_REPOSITION,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_FRAME_GLOBAL,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.firmware.modes import MODE_NUMBERS
from helixd.sim.snapshot import SimSnapshot
from tests.integration.test_serve_crew_modes import CONFIG, MISSION, driving, overriding_neutral
from tests.support.gcs import QGC_SYSID, SIM, latlon
from tests.support.harness import deep_merge, guard_installed, overrides_released, secured
from tests.support.loop_gcs import (
    booted,
    heartbeat_shows,
    set_mode,
    simulated_crew,
    upload,
    upload_and_start,
    upload_typed,
)
from tests.support.loop_mav import LoopMav
from tests.support.serve import flight_summaries
from tests.support.simulated import Steer, moving

FIRST_NE = (10.0, 4.0)  # the first click (m north/east of the EKF origin; home is there)
SECOND_NE = (2.0, 12.0)  # the second click, while driving to the first
RALLY_NE = (-3.0, 17.0)  # 6 m from the second place; home is 12 m away: RTL goes here
ARRIVAL_M = 0.5  # the last waypoint's rule (control.stop_tolerance_m, 0.1 m) and the noise
GUARDED = guard_installed(1.0)  # helixd-guard installed, as in the field
START_LATENCY_MAX_S = 1.5  # click → scrolls driven (the GUIDED HEARTBEAT comes at 1 Hz)
# MANUAL from GUIDED/RTL shows only in the autopilot's 1 Hz HEARTBEAT (MISSION_CURRENT's mode
# flag tells only AUTO's end): released within one period plus a control tick. The wall clock's
# 0.5 s held by phase (real SITL: 0.11-0.65 s); the simulated clock's phase is exact (0.97 s)
HEARTBEAT_PERIOD_S = 1.0
RELEASE_LATENCY_MAX_S = HEARTBEAT_PERIOD_S + 0.2


async def go_to_location(gcs: LoopMav, north_m: float, east_m: float) -> float:
    """QGroundControl's APMFirmwarePlugin::guidedModeGotoLocation: COMMAND_INT
    MAV_CMD_DO_REPOSITION to the autopilot, MAV_FRAME_GLOBAL, param1 -1 (default speed),
    param2 MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, param4 NaN, x/y the click (degE7), z the
    vehicle's AMSL altitude; returns the (simulated) time it was sent."""
    lat, lon = latlon(north_m, east_m)
    gcs.drain()
    sent = now_s()
    gcs.mav.command_int_send(
        1, 1, MAV_FRAME_GLOBAL, MAV_CMD_DO_REPOSITION, 0, 0,
        -1.0, float(MAV_DO_REPOSITION_FLAGS_CHANGE_MODE), 0.0, math.nan,
        round(lat * 1e7), round(lon * 1e7), SIM.origin_alt_m,
    )  # fmt: skip
    ack = await gcs.expect("COMMAND_ACK", 10.0, lambda m: int(m.command) == MAV_CMD_DO_REPOSITION)
    assert int(ack.result) == MAV_RESULT_ACCEPTED, ack
    return sent


def guided_item(north_m: float, east_m: float) -> Any:
    """QGroundControl's older *Go to location* item (MissionManager::
    writeArduPilotGuidedMissionItem): a MISSION_ITEM (float degrees) to the autopilot's
    default component, seq 0, MAV_CMD_NAV_WAYPOINT, MAV_FRAME_GLOBAL_RELATIVE_ALT, current 2
    (a guided-mode place), autocontinue 1, z the vehicle's relative altitude."""
    lat, lon = latlon(north_m, east_m)
    return mavlink.MAVLink_mission_item_message(
        1, 1, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT, 2, 1,
        0.0, 0.0, 0.0, 0.0, lat, lon, 0.0, mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip


async def send_guided_item(gcs: LoopMav, north_m: float, east_m: float) -> tuple[int, float]:
    """The older *Go to location* (after setting GUIDED): the item, and the MISSION_ACK's
    type; returns (type, when it was sent)."""
    gcs.drain()
    sent = now_s()
    gcs.mav.send(guided_item(north_m, east_m))
    ack = await gcs.expect("MISSION_ACK", 10.0, lambda m: int(m.target_system) == QGC_SYSID)
    return int(ack.type), sent


async def upload_rally(gcs: LoopMav, north_m: float, east_m: float) -> None:
    """QGC's Plan view, Rally Points, Upload: the mission protocol with
    MAV_MISSION_TYPE_RALLY, one MAV_CMD_NAV_RALLY_POINT."""
    lat, lon = latlon(north_m, east_m)
    rally = mavlink.MAV_MISSION_TYPE_RALLY
    item = mavlink.MAVLink_mission_item_int_message(
        1, 1, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_RALLY_POINT,
        0, 1, 0.0, 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0, rally,
    )  # fmt: skip
    await upload_typed(gcs, [item], rally, "rally")


def near(ne: tuple[float, float], within_m: float) -> Any:
    def check(s: SimSnapshot) -> bool:
        return math.hypot(s.north_m - ne[0], s.east_m - ne[1]) <= within_m

    return check


def error_m(s: SimSnapshot, ne: tuple[float, float]) -> float:
    return math.hypot(s.north_m - ne[0], s.east_m - ne[1])


async def since(st: Steer, predicate: Any, t0_s: float, timeout_s: float) -> float:
    """Simulated seconds from ``t0_s`` until ``predicate`` holds in the simulator."""
    await st.until(predicate, timeout_s)
    return st.now_s() - t0_s


async def held_there(st: Steer, ne: tuple[float, float], mode: str) -> float:
    """Neutral with helixd's overrides kept for 2 s of simulated time, armed, in ``mode``, at
    the place; the end-position error (m)."""
    t0 = st.snapshot().sim_time_s
    held = await st.record_until(lambda s: s.sim_time_s >= t0 + 2.0, 30.0)
    later = [s for s in held if s.sim_time_s >= t0 + 0.3]
    assert later and all(overriding_neutral(s) and s.armed and s.mode == mode for s in later)
    errors = [error_m(s, ne) for s in later]
    assert max(errors) <= ARRIVAL_M, errors
    return errors[-1]


async def armed_in_manual(st: Steer, gcs: LoopMav) -> None:
    """No mission needed: the service idle, the rover armed (Vehicle::setArmedShowError:
    MAV_CMD_COMPONENT_ARM_DISARM) in MANUAL, once the autopilot is ready to arm."""
    await st.line("no mission on the autopilot", 60.0)
    await booted(st, gcs)
    assert await gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    await heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)


async def manual_releases(st: Steer, gcs: LoopMav) -> float:
    """MANUAL from the flight-mode menu: the pilot drives, helixd lets go; how soon (s)."""
    t_manual = await set_mode(gcs, "MANUAL")
    return await since(st, overrides_released, t_manual, 5.0)


def test_go_to_location_and_rtl_to_a_rally_point(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        await st.line("no mission on the autopilot", 60.0)
        await upload_rally(gcs, *RALLY_NE)
        await armed_in_manual(st, gcs)
        assert not st.snapshot().overrides_active[0]

        # Go to location: the first click
        t_click = await go_to_location(gcs, *FIRST_NE)
        driven_s = await since(st, driving, t_click, 20.0)
        moving_s = await since(st, moving, t_click, 20.0)
        print(f"\nGo to location → scrolls driven: {driven_s:.3f} s, moving: {moving_s:.3f} s")
        assert driven_s <= START_LATENCY_MAX_S, driven_s
        assert st.snapshot().mode == "GUIDED"  # helixd set no mode
        await st.line("event=goto_start mode=GUIDED", 5.0)

        # a second click while driving: helixd goes to the new place
        start = st.snapshot()
        await st.until(lambda s: error_m(s, (start.north_m, start.east_m)) >= 3.0, 30.0)
        mark = st.mark()
        t_second = await go_to_location(gcs, *SECOND_NE)
        sim_second = st.snapshot().sim_time_s

        def new_flight() -> bool:
            return any("event=serve_flight_start" in ln for ln in st.console.lines[mark:])

        trace = await st.record_until(lambda s: new_flight() and driving(s), 10.0)
        handover = next(s.sim_time_s for s in trace if not driving(s))
        redirect = next(s.sim_time_s for s in trace if s.sim_time_s >= handover and driving(s))
        print(
            f"second click → old flight let go: {handover - sim_second:.3f} s, "
            f"new flight driving: {redirect - sim_second:.3f} s"
        )
        assert redirect - sim_second <= START_LATENCY_MAX_S, redirect - sim_second
        await since(st, near(SECOND_NE, ARRIVAL_M), t_second, 90.0)
        await st.line("event=goto_arrived", 30.0, after=mark)
        end_s = await held_there(st, SECOND_NE, "GUIDED")
        print(f"Go to location: held {end_s:.2f} m from the second click")
        assert error_m(st.snapshot(), FIRST_NE) > 5.0  # it never went on to the first place

        # RTL (APMFirmwarePlugin::guidedModeRTL: _setFlightModeAndValidate(RTL)): the
        # rally point is nearer than home, so ArduPilot's RTL goes there
        mark = st.mark()
        t_rtl = await set_mode(gcs, "RTL")
        rtl_s = await since(st, driving, t_rtl, 10.0)
        print(f"RTL → scrolls driven: {rtl_s:.3f} s")
        assert rtl_s <= START_LATENCY_MAX_S, rtl_s
        # the rally point may come before the HEARTBEAT naming RTL: the flight there can
        # start labelled with the mode before (GUIDED); the place is RTL's all the same
        await st.line("event=goto_start", 5.0, after=mark)
        assert await gcs.wait_text("Reached destination", 120.0) == "Reached destination"
        await st.line("event=goto_arrived", 30.0, after=mark)
        rally_s = await held_there(st, RALLY_NE, "RTL")
        print(f"RTL: held {rally_s:.2f} m from the rally point")

        manual_s = await manual_releases(st, gcs)
        print(f"MANUAL → overrides released: {manual_s:.3f} s")
        assert manual_s <= RELEASE_LATENCY_MAX_S, manual_s
        await heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["MANUAL"])
        snap = st.snapshot()
        assert snap.mode == "MANUAL" and snap.armed  # no HOLD asked, not disarmed
        assert "event=fallback" not in st.console.text()

    served = simulated_crew(tmp_path, CONFIG, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]
    summaries = flight_summaries(tmp_path)
    causes = [s["fault"].split(":", 1)[0] for s in summaries]
    assert causes == ["handover", "handover", "released"], summaries


def test_a_fault_on_the_way_to_a_place_ends_in_the_fall_back(tmp_path: Path) -> None:
    # the scrolls dig in on the way (stall watchdog shortened): the flight's own fall-back runs
    # (neutral, every override released, HOLD), and the place is not driven to again by itself
    config = deep_merge(CONFIG, {"safety": {"stall": {"duration_s": 1.0}}})

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await armed_in_manual(st, gcs)
        t_click = await go_to_location(gcs, *FIRST_NE)
        await since(st, moving, t_click, 20.0)
        t_fault = st.now_s()
        st.inject("stall", duration_s=600.0)
        secured_s = await since(st, secured, t_fault, 20.0)
        print(f"\nstall on the way → secured (HOLD, released, neutral): {secured_s:.3f} s")
        await st.line("event=fallback cause=stall", 10.0)
        await st.line("event=serve_state state=faulted", 10.0)
        # the autopilot's place is still GUIDED's, but HOLD: nothing starts by itself
        t0 = st.snapshot().sim_time_s
        trace = await st.record_until(lambda s: s.sim_time_s >= t0 + 3.0, 30.0)
        assert all(secured(s) for s in trace)
        assert sum("event=goto_start" in ln for ln in st.console.lines) == 1

    served = simulated_crew(tmp_path, config, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]


SMART_RTL_END_M = 2.5  # ArduPilot pops its last point (home) within WP_RADIUS (2 m)


def test_smart_rtl_follows_the_breadcrumbs_home(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        # Arm: ArduPilot starts SmartRTL's path where the rover is (AP_SmartRTL::set_home)
        await armed_in_manual(st, gcs)
        home = st.snapshot()
        home_ne = (home.north_m, home.east_m)
        t_click = await go_to_location(gcs, *FIRST_NE)
        await since(st, near(FIRST_NE, ARRIVAL_M), t_click, 90.0)
        await st.line("event=goto_arrived", 30.0)
        await held_there(st, FIRST_NE, "GUIDED")

        # SmartRTL (the flight-mode menu, or APMFirmwarePlugin::guidedModeRTL(smartRTL))
        mark = st.mark()
        t_srtl = await set_mode(gcs, "SMART_RTL")
        srtl_s = await since(st, driving, t_srtl, 10.0)
        assert await gcs.wait_text("Reached destination", 120.0) == "Reached destination"
        back_s = st.now_s() - t_srtl
        # no place any more (ArduPilot's StopAtHome): once the last one is stale
        # (serve.target_stale_s) or reached, neutral, overrides kept, armed
        stopped_s = await since(st, overriding_neutral, t_srtl, 10.0) - back_s
        t0 = st.snapshot().sim_time_s
        held = await st.record_until(lambda s: s.sim_time_s >= t0 + 2.0, 30.0)
        later = [s for s in held if s.sim_time_s >= t0 + 0.5]
        assert later and all(overriding_neutral(s) and s.armed for s in later)
        assert all(s.mode == "SMART_RTL" for s in later)
        end_m = error_m(later[-1], home_ne)
        legs = sum("event=serve_flight_start" in ln for ln in st.console.lines[mark:])
        print(
            f'\nSmartRTL → scrolls driven: {srtl_s:.3f} s, home ("Reached destination") '
            f"after {back_s:.1f} s over {legs} legs, neutral {stopped_s:.2f} s later, held "
            f"{end_m:.2f} m from home"
        )
        assert end_m <= SMART_RTL_END_M, end_m
        assert legs >= 3  # breadcrumbs every SRTL_ACCURACY (2 m) on the ~11 m way out
        await manual_releases(st, gcs)
        assert "event=fallback" not in st.console.text()

    served = simulated_crew(tmp_path, CONFIG, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]


def test_go_to_location_during_a_mission_and_back_to_auto(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        # QGC's Plan view: Upload; Start Mission (APMFirmwarePlugin::startMission)
        await upload_and_start(st, gcs, lambda: upload(gcs, MISSION))

        # Go to location mid-mission: the AUTO flight hands over, helixd goes there
        mark = st.mark()
        t_click = await go_to_location(gcs, *SECOND_NE)
        await st.line("event=goto_start", 10.0, after=mark)
        handover_s = await since(st, near(SECOND_NE, ARRIVAL_M), t_click, 90.0)
        await st.line("event=goto_arrived", 30.0, after=mark)
        await held_there(st, SECOND_NE, "GUIDED")
        print(f"\nGo to location during the mission → there in {handover_s:.1f} s")

        # Auto again (the mode menu, or Start Mission on a rover under way): the mission
        # goes on from the autopilot's item, to the end
        mark = st.mark()
        t_auto = await set_mode(gcs, "AUTO")
        auto_s = await since(st, driving, t_auto, 10.0)
        print(f"AUTO after Go to location → scrolls driven: {auto_s:.3f} s")
        await st.line("event=auto_start", 10.0, after=mark)
        assert await gcs.wait_text("Mission Complete", 120.0) == "Mission Complete"
        await st.line("event=serve_state state=completed", 60.0, after=mark)

    served = simulated_crew(tmp_path, CONFIG, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]
    summaries = flight_summaries(tmp_path)
    causes = [(s["fault"] or "").split(":", 1)[0] for s in summaries]
    assert causes == ["handover", "handover", ""], summaries
    assert summaries[-1]["completed"], summaries[-1]


def test_go_to_location_the_older_way_a_guided_mission_item(tmp_path: Path) -> None:
    """The same click as QGroundControl's older path sends it: GUIDED, then a MISSION_ITEM
    with current 2. ArduPilot takes it as GUIDED's place (refused outside GUIDED) and
    publishes it; helixd drives there and holds, as for DO_REPOSITION."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await armed_in_manual(st, gcs)
        # outside GUIDED the item is refused (handle_guided_request): nothing moves
        refused, _ = await send_guided_item(gcs, *FIRST_NE)
        assert refused == mavlink.MAV_MISSION_ERROR
        # setGuidedMode (Vehicle::setFlightMode → MAV_CMD_DO_SET_MODE), then the item
        await set_mode(gcs, "GUIDED")
        await heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["GUIDED"])
        assert not moving(st.snapshot())
        accepted, t_click = await send_guided_item(gcs, *FIRST_NE)
        assert accepted == mavlink.MAV_MISSION_ACCEPTED
        click_s = await since(st, driving, t_click, 10.0)
        await since(st, near(FIRST_NE, ARRIVAL_M), t_click, 90.0)
        await st.line("event=goto_arrived", 30.0)
        end_m = await held_there(st, FIRST_NE, "GUIDED")
        print(f"\nGo to location (MISSION_ITEM current 2) → driven {click_s:.3f} s; "
              f"held {end_m:.3f} m from the click")  # fmt: skip
        assert click_s <= START_LATENCY_MAX_S, click_s
        await manual_releases(st, gcs)

    served = simulated_crew(tmp_path, CONFIG, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]
