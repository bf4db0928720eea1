"""helixd.mission.placed: a start/local_ned mission in lat/lon through the EKF origin."""

from __future__ import annotations

import math

import pytest

from helixd.base.frames import NedPose, latlon_to_ne
from helixd.mission.model import Mission
from helixd.mission.placed import PlacementError, parse_latlon, placed_globally, placed_with

ORIGIN = (53.52325, -113.52632)


def start_mission() -> Mission:
    return Mission.model_validate(
        {
            "name": "s",
            "mode": "roll",
            "frame": "start",
            "waypoints": [{"x": 10.0, "y": 0.0}, {"x": 10.0, "y": 5.0, "heading_deg": 90.0}],
            "geofence_polygon": [[-1, -1], [-1, 11], [11, 11], [11, -1]],
        }
    )


def test_local_ned_goes_through_the_origin_and_keeps_compass_headings() -> None:
    msn = Mission.model_validate(
        {
            "name": "n",
            "mode": "roll",
            "frame": "local_ned",
            "waypoints": [{"north": 6.0, "east": 2.0, "heading_deg": 45.0, "via": True}],
            "keep_out_polygons": [[[1, 1], [1, 3], [3, 3]]],
        }
    )
    out = placed_globally(msn, ORIGIN)
    assert out.frame.value == "global"
    assert latlon_to_ne(*out.points()[0], *ORIGIN) == pytest.approx((6.0, 2.0), abs=1e-6)
    assert out.waypoints[0].heading_deg == 45.0 and out.waypoints[0].via is True
    ring = [latlon_to_ne(a, b, *ORIGIN) for a, b in out.keep_out_polygons[0]]
    assert ring == [pytest.approx(p, abs=1e-6) for p in [(1, 1), (1, 3), (3, 3)]]


def test_a_start_mission_is_placed_at_the_start_pose() -> None:
    pose = NedPose(north_m=3.0, east_m=-2.0, yaw_ned_rad=math.pi / 2)  # facing East
    out = placed_globally(start_mission(), ORIGIN, pose)
    ne = [latlon_to_ne(a, b, *ORIGIN) for a, b in out.points()]
    assert ne == [pytest.approx((3.0, 8.0), abs=1e-6), pytest.approx((8.0, 8.0), abs=1e-6)]
    assert out.waypoints[1].heading_deg == pytest.approx(0.0)  # 90° left of East: North
    assert len(out.geofence_polygon) == 4


def test_what_is_missing_is_said() -> None:
    with pytest.raises(PlacementError, match="needs the start pose"):
        placed_globally(start_mission(), ORIGIN)
    with pytest.raises(PlacementError, match="--origin LAT,LON"):
        placed_with(start_mission(), None, None)
    with pytest.raises(PlacementError, match="--start-heading-deg"):
        placed_with(start_mission(), ORIGIN, None)
    assert parse_latlon(" 53.5 , -113.5 ") == (53.5, -113.5)
    for bad in ("53.5", "a,b", "95,0", "nan,0"):
        with pytest.raises(ValueError):
            parse_latlon(bad)
