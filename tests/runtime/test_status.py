"""helixd.runtime.status: the lines `helixd status` prints (pure)."""

from __future__ import annotations

from helixd.base.frames import NedPose
from helixd.link.vehicle import PoseSample, VehicleState
from helixd.runtime.status import format_status


def test_gps_battery_and_lat_lon_are_shown() -> None:
    st = VehicleState()
    assert "gps       : no GPS_RAW_INT" in format_status(st, 0.0)
    assert "battery   : not reported" in format_status(st, 0.0)
    st.gps_fix_type, st.gps_satellites = 6, 17
    st.battery_voltage_v, st.battery_remaining_pct = 24.0, 63
    st.gps_origin = (53.52325, -113.52632)
    st.pose = PoseSample(NedPose(0.0, 0.0, 0.0), 1000, 1.0, 0.0, 0.0, 0.0)
    lines = format_status(st, 1.0)
    assert "gps       : RTK fixed, 17 satellites" in lines
    assert "battery   : 24.00 V, 63 %" in lines
    assert "position  : 53.5232500°, -113.5263200° (the EKF pose through its origin)" in lines
    st.gps_origin = None
    assert "origin    : none reported (no GPS_GLOBAL_ORIGIN: no GPS fix yet?)" in format_status(
        st, 1.0
    )
