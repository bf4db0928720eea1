"""NED ⇄ mission-frame conversions, done once at the edge."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne, ne_to_latlon

coord = st.floats(-500, 500, allow_nan=False)
angle = st.floats(-math.pi, math.pi, allow_nan=False)


def test_enu_frame_axes() -> None:
    frame = MissionFrame.enu()
    # facing North (NED yaw 0) is +90° CCW from East
    p = frame.to_mission(NedPose(north_m=3.0, east_m=4.0, yaw_ned_rad=0.0))
    assert (p.x_m, p.y_m) == (4.0, 3.0)
    assert p.yaw_rad == pytest.approx(math.pi / 2)
    # facing East (NED yaw +90° clockwise) is yaw 0
    assert frame.to_mission(NedPose(0, 0, math.pi / 2)).yaw_rad == pytest.approx(0.0)


def test_start_frame_forward_and_left() -> None:
    start = NedPose(north_m=10.0, east_m=-5.0, yaw_ned_rad=math.pi / 2)  # facing East
    frame = MissionFrame.start_at(start)
    # 2 m East of the start is 2 m forward; 1 m North is 1 m to the left
    p = frame.to_mission(NedPose(north_m=11.0, east_m=-3.0, yaw_ned_rad=0.0))
    assert p.x_m == pytest.approx(2.0)
    assert p.y_m == pytest.approx(1.0)
    # turning to face North from East is a left (CCW) turn of +90°
    assert p.yaw_rad == pytest.approx(math.pi / 2)


@given(coord, coord, angle, coord, coord)
def test_start_frame_round_trip(n0: float, e0: float, yaw0: float, x: float, y: float) -> None:
    frame = MissionFrame.start_at(NedPose(n0, e0, yaw0))
    n, e = frame.to_ned(x, y)
    back = frame.to_mission(NedPose(n, e, frame.yaw_to_ned(0.3)))
    assert back.x_m == pytest.approx(x, abs=1e-6)
    assert back.y_m == pytest.approx(y, abs=1e-6)
    assert back.yaw_rad == pytest.approx(0.3, abs=1e-9)


@given(st.floats(-60, 60), st.floats(-170, 170), coord, coord)
def test_latlon_round_trip(lat0: float, lon0: float, n: float, e: float) -> None:
    lat, lon = ne_to_latlon(n, e, lat0, lon0)
    n2, e2 = latlon_to_ne(lat, lon, lat0, lon0)
    assert n2 == pytest.approx(n, abs=1e-6)
    assert e2 == pytest.approx(e, abs=1e-6)
