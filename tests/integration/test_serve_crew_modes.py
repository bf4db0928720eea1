"""``helixd serve`` obeying the autopilot's mode: the crew's buttons in QGroundControl talk to
the autopilot (system 1), and helixd drives while it is armed in AUTO.

A scripted ground station (system 255, its own UDP link to the simulator) sends what
QGroundControl's source sends for each button; the comment on each step names the QGC
function it copies. Everything is judged on the simulator's truth; the latencies are printed
(run with ``-s``), exactly, on the simulated clock the service and the simulator share: what
the crew would wait, less the computers' own time.
"""

from __future__ import annotations

from pathlib import Path

from helixd.mav.constants import (
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.firmware.modes import MODE_NUMBERS
from helixd.sim.snapshot import SimSnapshot
from tests.support.harness import guard_installed, overrides_released, scrolls_neutral
from tests.support.loop_gcs import (
    CREW_CONFIG,
    armed_in_guided,
    heartbeat_shows,
    set_mode,
    simulated_crew,
    upload,
    uploaded_and_ready,
)
from tests.support.loop_mav import LoopMav
from tests.support.serve import flight_summaries
from tests.support.simulated import Steer, moving

CONFIG = CREW_CONFIG  # the crew uses the ground station (tests.support.loop_gcs)
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
    async def crew(st: Steer, gcs: LoopMav) -> None:
        # QGC's Plan view: Upload (the mission protocol)
        await uploaded_and_ready(st, gcs, lambda: upload(gcs, MISSION))

        # Start Mission: APMFirmwarePlugin::startMission on a disarmed rover —
        # _setFlightModeAndValidate(Guided), _armVehicleAndValidate, then
        # sendMavCommand(defaultComponentId, MAV_CMD_MISSION_START) with params 0
        await armed_in_guided(gcs)
        assert not st.snapshot().overrides_active[0]  # nothing moves before the start
        t_start = st.now_s()
        assert await gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        await st.until(driving, 20.0)
        driven_s = st.now_s() - t_start
        await st.until(moving, 20.0)
        start_s = st.now_s() - t_start
        print(f"\nStart Mission → scrolls driven: {driven_s:.3f} s, moving: {start_s:.3f} s")
        assert start_s <= START_LATENCY_MAX_S, start_s
        snap = st.snapshot()
        assert snap.mode == "AUTO" and snap.armed  # helixd neither set MANUAL nor re-armed
        await st.line("event=auto_start", 5.0)
        # the crew sees AUTO in QGroundControl's toolbar (the 1 Hz HEARTBEAT): a Pause before
        # that meets the README's limit (a flight labelled by the HEARTBEAT's older mode)
        await heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["AUTO"])

        # Pause: APMFirmwarePlugin::pauseVehicle sets the pause flight mode (Rover: Hold)
        t_pause = await set_mode(gcs, "HOLD")
        await st.until(scrolls_neutral, 5.0)
        pause_s = st.now_s() - t_pause
        print(f"Pause (HOLD) → scrolls neutral: {pause_s:.3f} s")
        assert pause_s <= PAUSE_LATENCY_MAX_S, pause_s
        # held at neutral by helixd's overrides for 2 s of simulated time, still armed
        t_hold = st.snapshot().sim_time_s
        held = await st.record_until(lambda s: s.sim_time_s >= t_hold + 2.0, 30.0)
        later = [s for s in held if s.sim_time_s >= t_hold + 0.3]
        assert later and all(overriding_neutral(s) and s.armed for s in later)
        assert all(s.mode == "HOLD" for s in later)

        # Continue: Auto again (startMission on a rover already under way, or the
        # flight-mode menu: _setFlightModeAndValidate(Auto))
        t_continue = await set_mode(gcs, "AUTO")
        await st.until(driving, 10.0)
        continue_s = st.now_s() - t_continue
        print(f"Continue (AUTO) → scrolls driven: {continue_s:.3f} s")
        assert continue_s <= CONTINUE_LATENCY_MAX_S, continue_s
        await st.until(moving, 10.0)
        starts = [ln for ln in st.console.lines if "event=auto_start" in ln]
        assert len(starts) == 1, starts  # the same flight

        # Set current waypoint (Vehicle::setCurrentMissionSequence: DO_SET_MISSION_CURRENT
        # to the autopilot) from item 1 to item 3: helixd goes there
        mark = st.mark()
        t_item = st.now_s()
        assert await gcs.command(MAV_CMD_DO_SET_MISSION_CURRENT, 3) == MAV_RESULT_ACCEPTED
        await st.line("event=auto_start item=3", 10.0, after=mark)
        await st.until(driving, 10.0)
        item_s = st.now_s() - t_item
        print(f"Set current waypoint 3 → new flight driving: {item_s:.3f} s")
        assert item_s <= ITEM_LATENCY_MAX_S, item_s
        assert st.snapshot().mode == "AUTO"  # no HOLD asked between the flights

        # MANUAL from the flight-mode menu: the pilot drives, helixd lets go at once
        t_manual = await set_mode(gcs, "MANUAL")
        await st.until(overrides_released, 5.0)
        manual_s = st.now_s() - t_manual
        print(f"MANUAL → overrides released: {manual_s:.3f} s")
        await st.line("event=serve_state state=paused", 30.0)
        snap = st.snapshot()
        assert snap.mode == "MANUAL" and snap.armed  # no HOLD asked, not disarmed
        assert "event=fallback" not in st.console.text()

        # AUTO again: a new flight from the item the autopilot is on, to the end
        mark = st.mark()
        await set_mode(gcs, "AUTO")
        await st.until(moving, 20.0)
        assert await gcs.wait_text("Mission Complete", 120.0) == "Mission Complete"  # ArduPilot's
        assert (await gcs.wait_text("helixd: completed", 60.0)).endswith("3/3 waypoints")
        await st.line("event=serve_state state=completed", 10.0, after=mark)

    served = simulated_crew(tmp_path, CONFIG, crew, **guard_installed(1.0))
    assert served.code == 0, served.log[-3000:]
    summaries = flight_summaries(tmp_path)
    assert [s["completed"] for s in summaries] == [False, False, True], summaries
    assert summaries[0]["fault"].startswith("item_set: item 3 set"), summaries[0]
    assert summaries[1]["fault"].startswith("released: mode MANUAL"), summaries[1]
