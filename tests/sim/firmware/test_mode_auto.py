"""The simulator's AUTO against ArduPilot Rover: MAV_CMD_MISSION_START (Rover's command handler:
first/last item DENIED, else AUTO), ModeAuto::_enter (no mission: refused), the mission run
on the EKF's position (AR_WPNav: within WP_RADIUS or past the finish line; "Reached waypoint
#N", MISSION_ITEM_REACHED, "Mission: N WP"), ModeAuto::exit_mission ("Mission Complete", AUTO
kept, MISSION_CURRENT COMPLETE), and leaving AUTO stopping the mission."""

from __future__ import annotations

import os
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.frames import ne_to_latlon
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_WAYPOINT,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_COMPLETE,
)
from helixd.plant.state import PhysicsState
from helixd.sim.core import SimCore
from helixd.sim.firmware import modes
from helixd.sim.firmware.mode_auto import passed_finish_line
from tests.support.simcore import command, incoming, make_core, of_type, run

GCS_SYSID = 255
_mav = mavlink.MAVLink(None)
WAYPOINTS_NE = ((10.0, 0.0), (10.0, 10.0), (0.0, 10.0))


def upload(core: SimCore, points_ne: tuple[tuple[float, float], ...]) -> None:
    cfg = core.config
    rows = [(0.0, 0.0), *points_ne]  # row 0: home (ArduPilot keeps its own)
    core.handle(0, incoming(_mav.mission_count_encode(1, 1, len(rows), 0), GCS_SYSID))
    for seq, (n, e) in enumerate(rows):
        lat, lon = ne_to_latlon(n, e, cfg.origin_lat_deg, cfg.origin_lon_deg)
        item = _mav.mission_item_int_encode(
            1, 1, seq, 3, MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0,
            round(lat * 1e7), round(lon * 1e7), 0.0, 0,
        )  # fmt: skip
        core.handle(0, incoming(item, GCS_SYSID))
    core.drain_outbox()


def ready_core() -> SimCore:
    core = make_core(home_delay_s=0.5, prearm_delay_s=0.5)
    run(core, 4.0)
    return core


def texts(out: list[tuple[int | None, Any]]) -> list[str]:
    return [str(m.text) for m in of_type(out, "STATUSTEXT", 0)]


def teleport(core: SimCore, north_m: float, east_m: float) -> None:
    core.phys = PhysicsState(north_m=north_m, east_m=east_m)


def test_mission_start_needs_a_mission_and_no_first_or_last_item() -> None:
    core = ready_core()
    start = incoming(
        _mav.command_long_encode(1, 1, MAV_CMD_MISSION_START, 0, 0, 0, 0, 0, 0, 0, 0), GCS_SYSID
    )
    core.handle(0, start)
    out = core.drain_outbox()
    assert [int(m.result) for m in of_type(out, "COMMAND_ACK", 0)] == [MAV_RESULT_FAILED]
    assert "No Mission. Can't set AUTO." in texts(out)
    upload(core, WAYPOINTS_NE)
    assert command(core, 0, MAV_CMD_MISSION_START, 1, 0, sysid=GCS_SYSID) == MAV_RESULT_DENIED
    assert command(core, 0, MAV_CMD_MISSION_START, 0, 3, sysid=GCS_SYSID) == MAV_RESULT_DENIED
    # disarmed: accepted all the same (Rover asks only for a mission)
    assert command(core, 0, MAV_CMD_MISSION_START, 0, 0, sysid=GCS_SYSID) == MAV_RESULT_ACCEPTED
    assert core.ap.mode == modes.AUTO and not core.ap.armed


def test_auto_runs_the_mission_on_the_position_and_completes_in_auto() -> None:
    core = ready_core()
    upload(core, WAYPOINTS_NE)
    # QGroundControl's Start Mission on a disarmed Rover: GUIDED, arm, MISSION_START
    assert command(core, 0, MAV_CMD_DO_SET_MODE, 1, modes.GUIDED, sysid=GCS_SYSID) == 0
    assert command(core, 0, MAV_CMD_COMPONENT_ARM_DISARM, 1, sysid=GCS_SYSID) == 0
    assert command(core, 0, MAV_CMD_MISSION_START, 0, 0, sysid=GCS_SYSID) == MAV_RESULT_ACCEPTED
    out = run(core, 2.0)  # MISSION_CURRENT streams at the EXTENDED_STATUS rate
    assert "Mission: 1 WP" in texts(out)
    current = of_type(out, "MISSION_CURRENT", 0)[-1]
    assert (current.seq, current.mission_state, current.mission_mode) == (
        1,
        MISSION_STATE_ACTIVE,
        1,
    )
    teleport(core, 8.5, 0.0)  # within WP_RADIUS (2 m) of waypoint 1
    out = run(core, 0.5)
    assert texts(out)[:2] == ["Reached waypoint #1", "Mission: 2 WP"]
    assert [m.seq for m in of_type(out, "MISSION_ITEM_REACHED", 0)] == [1]
    teleport(core, 13.0, 12.0)  # far from waypoint 2, but past its finish line
    out = run(core, 0.5)
    assert "Reached waypoint #2" in texts(out)
    teleport(core, 0.5, 10.0)
    out = run(core, 2.0)
    said = texts(out)
    assert said.index("Reached waypoint #3") < said.index("Mission Complete")
    assert core.ap.mode == modes.AUTO  # MIS_DONE_BEHAVE 0: AUTO's stop submode, not HOLD
    assert of_type(out, "MISSION_CURRENT", 0)[-1].mission_state == MISSION_STATE_COMPLETE


def auto_started() -> SimCore:
    """A ready core with WAYPOINTS_NE uploaded, armed and MISSION_START accepted, 0.3 s on."""
    core = ready_core()
    upload(core, WAYPOINTS_NE)
    assert command(core, 0, MAV_CMD_COMPONENT_ARM_DISARM, 1, sysid=GCS_SYSID) == 0
    assert command(core, 0, MAV_CMD_MISSION_START, 0, 0, sysid=GCS_SYSID) == 0
    run(core, 0.3)
    return core


def test_leaving_auto_stops_the_mission_and_auto_again_resumes_the_item() -> None:
    core = auto_started()
    teleport(core, 10.0, 0.0)
    run(core, 0.3)
    assert core.mission.current_seq == 2
    assert command(core, 0, MAV_CMD_DO_SET_MODE, 1, modes.HOLD, sysid=GCS_SYSID) == 0
    run(core, 0.3)
    assert core.mission.nav_item() is None  # stopped
    teleport(core, 10.0, 10.0)
    out = run(core, 0.3)
    assert "Reached waypoint #2" not in texts(out)
    assert command(core, 0, MAV_CMD_DO_SET_MODE, 1, modes.AUTO, sysid=GCS_SYSID) == 0
    out = run(core, 0.3)
    assert texts(out)[:2] == ["Mission: 2 WP", "Reached waypoint #2"]


def test_finish_line() -> None:
    assert passed_finish_line((0.0, 0.0), (10.0, 0.0), (10.0, 5.0))
    assert not passed_finish_line((0.0, 0.0), (10.0, 0.0), (9.9, -5.0))
    assert passed_finish_line((1.0, 1.0), (1.0, 1.0), (50.0, 50.0))  # no leg: passed


def test_set_current_in_auto_starts_that_item_at_once() -> None:
    core = auto_started()
    assert core.mission.current_seq == 1
    # the crew's "set current waypoint" (MISSION_SET_CURRENT) while the mission runs
    core.handle(0, incoming(_mav.mission_set_current_encode(1, 1, 3), GCS_SYSID))
    out = core.drain_outbox()
    assert "Mission: 3 WP" in texts(out)
    assert [m.seq for m in of_type(out, "MISSION_CURRENT", 0)] == [3]
    teleport(core, 0.0, 10.0)  # at waypoint 3: reached, the mission completes
    out = run(core, 0.3)
    assert texts(out)[:2] == ["Reached waypoint #3", "Mission Complete"]


def test_change_speed_is_taken_by_a_navigating_mode_and_reported_by_nothing() -> None:
    core = ready_core()
    upload(core, WAYPOINTS_NE)
    # MANUAL: no navigation, FAILED; a climb speed is DENIED in any mode
    speed = MAV_CMD_DO_CHANGE_SPEED
    assert command(core, 0, speed, 1, 0.5, sysid=GCS_SYSID) == MAV_RESULT_FAILED
    assert command(core, 0, speed, 2, 0.5, sysid=GCS_SYSID) == MAV_RESULT_DENIED
    assert command(core, 0, MAV_CMD_MISSION_START, 0, 0, sysid=GCS_SYSID) == 0
    assert command(core, 0, speed, 1, 0.01, sysid=GCS_SYSID) == MAV_RESULT_FAILED
    assert command(core, 0, speed, 1, 0.5, sysid=GCS_SYSID) == MAV_RESULT_ACCEPTED


def test_auto_after_a_shorter_upload_starts_the_new_mission_from_its_first_item() -> None:
    # AP_Mission::resume: a current command the new mission no longer has (read_cmd_from_
    # storage fails) is not resumed: the mission starts again. Found by the soak (a 2-hour
    # day, tools/soak.py --seed 101 --days 1 --day-hours 2): the simulator raised IndexError.
    core = auto_started()
    teleport(core, 10.0, 0.0)
    run(core, 0.3)
    teleport(core, 10.0, 10.0)
    run(core, 0.3)
    assert core.mission.current_seq == 3
    assert command(core, 0, MAV_CMD_DO_SET_MODE, 1, modes.HOLD, sysid=GCS_SYSID) == 0
    run(core, 0.3)
    upload(core, ((5.0, 0.0),))
    assert command(core, 0, MAV_CMD_DO_SET_MODE, 1, modes.AUTO, sysid=GCS_SYSID) == 0
    out = run(core, 0.3)
    assert texts(out)[:1] == ["Mission: 1 WP"]
    assert core.mission.current_seq == 1
