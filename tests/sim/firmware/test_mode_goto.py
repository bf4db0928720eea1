"""The simulator's GUIDED and RTL against ArduPilot Rover: MAV_CMD_DO_REPOSITION
(``handle_command_int_do_reposition``: DENIED outside GUIDED without the change-mode flag, for
0/0, off the Earth, for a frame it cannot read; GUIDED set on the way), GUIDED entered with
nothing to go to (``ModeGuided::_enter``: Stop), RTL to the nearest of home and the rally points
(``calc_best_rally_or_home_location``), "Reached destination", MISSION_ITEM_REACHED 0, and
POSITION_TARGET_GLOBAL_INT streamed only while the mode has a place (EXTENDED_STATUS)."""

from __future__ import annotations

import math
import os
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.frames import ne_to_latlon
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MODE,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_FRAME_GLOBAL,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
)
from helixd.sim.core import SimCore
from helixd.sim.firmware import modes
from helixd.sim.firmware.mode_goto import Place, reposition_refusal, rtl_destination
from tests.sim.firmware.test_mode_auto import GCS_SYSID, ready_core, teleport, texts
from tests.support.simcore import command, incoming, make_core, of_type, run

_mav = mavlink.MAVLink(None)
MAV_FRAME_LOCAL_NED = int(mavlink.MAV_FRAME_LOCAL_NED)  # no place on Earth


def latlon_e7(core: SimCore, north_m: float, east_m: float) -> tuple[int, int]:
    cfg = core.config
    lat, lon = ne_to_latlon(north_m, east_m, cfg.origin_lat_deg, cfg.origin_lon_deg)
    return round(lat * 1e7), round(lon * 1e7)


def reposition(
    core: SimCore, north_m: float, east_m: float, flags: int, frame: int = MAV_FRAME_GLOBAL
) -> int:
    """QGroundControl's APMFirmwarePlugin::guidedModeGotoLocation: COMMAND_INT DO_REPOSITION,
    MAV_FRAME_GLOBAL, param1 -1 (default speed), param2 the flags, x/y degE7, z AMSL."""
    lat, lon = latlon_e7(core, north_m, east_m)
    msg = _mav.command_int_encode(
        1, 1, frame, MAV_CMD_DO_REPOSITION, 0, 0, -1.0, float(flags), 0.0, math.nan,
        lat, lon, core.config.origin_alt_m,
    )  # fmt: skip
    core.handle(0, incoming(msg, GCS_SYSID))
    acks = of_type(core.drain_outbox(), "COMMAND_ACK", 0)
    return int(acks[-1].result)


def set_mode(core: SimCore, mode: int) -> int:
    return command(core, 0, MAV_CMD_DO_SET_MODE, 1, mode, sysid=GCS_SYSID)


def targets(out: list[tuple[int | None, Any]]) -> list[tuple[int, int]]:
    return [(m.lat_int, m.lon_int) for m in of_type(out, "POSITION_TARGET_GLOBAL_INT", 0)]


def upload_rally(core: SimCore, north_m: float, east_m: float) -> None:
    lat, lon = latlon_e7(core, north_m, east_m)
    rally = 2  # MAV_MISSION_TYPE_RALLY
    core.handle(0, incoming(_mav.mission_count_encode(1, 1, 1, rally), GCS_SYSID))
    item = _mav.mission_item_int_encode(
        1, 1, 0, 3, 5100, 0, 1, 0, 0, 0, 0, lat, lon, 0.0, rally
    )  # fmt: skip
    core.handle(0, incoming(item, GCS_SYSID))
    core.drain_outbox()


def test_reposition_refusals_as_ardupilot() -> None:
    assert reposition_refusal(False, 0, 1, 1, MAV_FRAME_GLOBAL, 0.0) == MAV_RESULT_DENIED
    assert reposition_refusal(False, 1, 1, 1, MAV_FRAME_GLOBAL, 0.0) is None
    assert reposition_refusal(True, 0, 1, 1, MAV_FRAME_GLOBAL, 0.0) is None
    assert reposition_refusal(True, 1, 0, 0, MAV_FRAME_GLOBAL, 0.0) == MAV_RESULT_DENIED
    assert reposition_refusal(True, 1, 91 * 10**7, 1, MAV_FRAME_GLOBAL, 0.0) == MAV_RESULT_DENIED
    assert reposition_refusal(True, 1, 1, 1, MAV_FRAME_LOCAL_NED, 0.0) == MAV_RESULT_DENIED
    assert reposition_refusal(True, 1, 1, 1, MAV_FRAME_GLOBAL, math.nan) == MAV_RESULT_DENIED


def test_rtl_goes_to_the_nearest_of_home_and_rally_points_within_the_limit() -> None:
    home = Place((0.0, 0.0), 1, 1, 0.0)
    near = Place((20.0, 0.0), 2, 2, 0.0)
    far = Place((900.0, 0.0), 3, 3, 0.0)
    assert rtl_destination((25.0, 0.0), home, []) is home
    assert rtl_destination((25.0, 0.0), home, [near, far]) is near
    assert rtl_destination((5.0, 0.0), home, [near]) is home  # home is closer
    assert rtl_destination((880.0, 0.0), home, [far]) is far
    assert rtl_destination((300.0, 0.0), home, [far]) is home  # beyond RALLY_LIMIT_KM


def test_go_to_location_switches_to_guided_streams_the_place_and_reports_it_reached() -> None:
    core = ready_core()
    assert reposition(core, 10.0, 5.0, 0) == MAV_RESULT_DENIED  # MANUAL, no change-mode flag
    assert core.ap.mode == modes.MANUAL
    out = run(core, 2.0)
    assert targets(out) == []  # MANUAL has no place to go
    flag = MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
    assert reposition(core, 0.0, 0.0, flag, frame=MAV_FRAME_LOCAL_NED) == MAV_RESULT_DENIED
    assert reposition(core, 10.0, 5.0, flag) == MAV_RESULT_ACCEPTED
    assert core.ap.mode == modes.GUIDED
    out = run(core, 2.0)
    assert set(targets(out)) == {latlon_e7(core, 10.0, 5.0)}
    target = of_type(out, "POSITION_TARGET_GLOBAL_INT", 0)[-1]
    assert target.coordinate_frame == MAV_FRAME_GLOBAL and target.type_mask & 0xFF8 == 0xFF8
    # a new click while in GUIDED needs no flag
    assert reposition(core, -4.0, 6.0, 0) == MAV_RESULT_ACCEPTED
    out = run(core, 1.0)
    assert targets(out)[-1] == latlon_e7(core, -4.0, 6.0)
    teleport(core, -3.0, 6.0)  # within WP_RADIUS
    out = run(core, 0.5)
    assert [m.seq for m in of_type(out, "MISSION_ITEM_REACHED", 0)] == [0]
    out = run(core, 1.0)
    assert targets(out)[-1] == latlon_e7(core, -4.0, 6.0)  # still published once reached


def test_guided_from_the_mode_menu_has_no_place_and_rtl_drives_to_the_rally_point() -> None:
    core = ready_core()
    upload_rally(core, 15.0, 0.0)
    assert core.ap.home is not None
    assert set_mode(core, modes.GUIDED) == MAV_RESULT_ACCEPTED
    assert targets(run(core, 2.0)) == []  # Stop submode: nothing published
    teleport(core, 25.0, 0.0)  # home 25 m away, the rally point 10 m
    assert command(core, 0, MAV_CMD_COMPONENT_ARM_DISARM, 1, sysid=GCS_SYSID) == 0
    assert set_mode(core, modes.RTL) == MAV_RESULT_ACCEPTED
    out = run(core, 2.0)
    assert set(targets(out)) == {latlon_e7(core, 15.0, 0.0)}
    teleport(core, 16.0, 0.0)
    out = run(core, 1.0)
    assert texts(out).count("Reached destination") == 1
    assert targets(out)[-1] == latlon_e7(core, 15.0, 0.0)  # RTL keeps its place
    assert set_mode(core, modes.HOLD) == MAV_RESULT_ACCEPTED
    run(core, 0.5)
    assert targets(run(core, 2.0)) == []


def test_smart_rtl_is_refused_without_a_saved_path() -> None:
    core = make_core(ekf_origin_delay_s=60.0)
    run(core, core.config.boot_duration_s + 1.0)
    assert set_mode(core, modes.SMART_RTL) != MAV_RESULT_ACCEPTED  # no position: no path
    assert core.ap.mode == modes.MANUAL


def test_smart_rtl_returns_by_the_saved_points_and_stops_publishing_at_home() -> None:
    core = ready_core()
    assert command(core, 0, MAV_CMD_COMPONENT_ARM_DISARM, 1, sysid=GCS_SYSID) == 0
    run(core, 0.1)  # the arming restarts the path where the rover is
    for n, e in ((1.0, 0.0), (3.0, 0.0), (6.0, 0.0), (6.0, 3.0), (6.0, 4.0)):
        teleport(core, n, e)
        run(core, 0.2)
    assert [p.ne for p in core.srtl.points] == [
        pytest.approx(p, abs=0.05) for p in ((0.0, 0.0), (3.0, 0.0), (6.0, 0.0), (6.0, 3.0))
    ]
    assert set_mode(core, modes.SMART_RTL) == MAV_RESULT_ACCEPTED
    out = run(core, 1.0)  # (6, 3) is within WP_RADIUS: on to (6, 0)
    assert targets(out)[-1] == latlon_e7(core, 6.0, 0.0)
    teleport(core, 6.0, 0.5)
    out = run(core, 1.0)
    assert targets(out)[-1] == latlon_e7(core, 3.0, 0.0)
    teleport(core, 0.5, 0.0)  # past (3, 0), within WP_RADIUS of the first point
    out = run(core, 1.0)
    assert texts(out).count("Reached destination") == 1
    assert targets(run(core, 1.0)) == []  # StopAtHome: nothing published
    # the path is used up; out of SmartRTL the next point is saved where the rover is
    assert set_mode(core, modes.MANUAL) == MAV_RESULT_ACCEPTED
    run(core, 0.2)
    assert [p.ne for p in core.srtl.points] == [pytest.approx((0.5, 0.0), abs=0.05)]


def guided_item(core: SimCore, north_m: float, east_m: float, current: int = 2) -> int:
    """QGroundControl's MissionManager::writeArduPilotGuidedMissionItem: a MISSION_ITEM
    (float degrees), seq 0, NAV_WAYPOINT, GLOBAL_RELATIVE_ALT, current 2; the MISSION_ACK."""
    lat, lon = (v / 1e7 for v in latlon_e7(core, north_m, east_m))
    msg = _mav.mission_item_encode(
        1, 1, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT, current,
        1, 0.0, 0.0, 0.0, 0.0, lat, lon, 0.0, mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip
    core.handle(0, incoming(msg, GCS_SYSID))
    acks = of_type(core.drain_outbox(), "MISSION_ACK", 0)
    return int(acks[-1].type)


def test_a_guided_mission_item_is_guideds_place_only_in_guided() -> None:
    core = ready_core()
    assert guided_item(core, 10.0, 5.0) == mavlink.MAV_MISSION_ERROR  # MANUAL
    assert targets(run(core, 1.0)) == []
    assert set_mode(core, modes.GUIDED) == MAV_RESULT_ACCEPTED
    run(core, 0.5)  # GUIDED entered (its Stop submode), as the crew's click comes later
    assert guided_item(core, 10.0, 5.0) == mavlink.MAV_MISSION_ACCEPTED
    (place,) = set(targets(run(core, 1.0)))
    # MISSION_ITEM carries degrees as float32: about 4e-6° (0.4 m) at 53° N
    assert all(abs(a - b) <= 50 for a, b in zip(place, latlon_e7(core, 10.0, 5.0), strict=True))
    assert guided_item(core, -4.0, 6.0, current=3) == mavlink.MAV_MISSION_ACCEPTED  # altitude
    assert set(targets(run(core, 2.0))) == {place}  # the place stays
