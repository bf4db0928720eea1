"""VehicleState.apply is pure: messages in (built with the real codec), state and changes out."""

from __future__ import annotations

from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.vehicle import Change, VehicleState, mode_name, mode_number


def codec(sysid: int = 1, compid: int = 1) -> Any:
    c = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    return c


def decoded(msg: Any, c: Any) -> Any:
    rx = mavlink.MAVLink(None)
    out = rx.parse_buffer(bytes(msg.pack(c)))
    assert out is not None
    return out[0]


AP = codec()


def hb(custom_mode: int, armed: bool = False, c: Any = AP) -> Any:
    return decoded(c.heartbeat_encode(10, 3, 1 | (128 if armed else 0), custom_mode, 4), c)


def att(t_ms: int, yaw: float) -> Any:
    return decoded(AP.attitude_encode(t_ms, 0, 0, yaw, 0, 0, 0), AP)


def lpn(t_ms: int, north: float, east: float) -> Any:
    return decoded(AP.local_position_ned_encode(t_ms, north, east, 0, 0.5, -0.2, 0.0), AP)


def test_pose_combines_position_with_latest_attitude_yaw() -> None:
    st = VehicleState()
    assert st.apply(lpn(1000, 1.0, 2.0), 10.0) == Change.NONE  # no attitude yet: no pose
    assert st.pose is None
    st.apply(att(1000, 0.7), 10.0)
    changes = st.apply(lpn(1020, 3.0, 4.0), 10.5)
    assert changes & Change.POSE
    assert st.pose is not None
    assert (st.pose.ned.north_m, st.pose.ned.east_m) == (3.0, 4.0)
    assert st.pose.ned.yaw_ned_rad == pytest.approx(0.7)
    assert (st.pose.time_boot_ms, st.pose.rx_monotonic_s) == (1020, 10.5)
    assert st.pose.vn_mps == pytest.approx(0.5) and st.pose.ve_mps == pytest.approx(-0.2)


def test_stale_attitude_gives_no_pose() -> None:
    st = VehicleState(pose_stale_s=0.5)
    st.apply(att(1000, 0.1), 1.0)
    assert st.apply(lpn(1600, 0, 0), 1.6) == Change.NONE  # ATTITUDE 600 ms older
    assert st.pose is None


def test_mode_armed_and_names() -> None:
    st = VehicleState()
    changes = st.apply(hb(16), 1.0)
    assert changes & Change.HEARTBEAT and changes & Change.MODE
    assert st.mode == "INITIALISING" and st.last_heartbeat_s == 1.0
    changes = st.apply(hb(0, armed=True), 2.0)
    assert changes & Change.ARMED and st.armed and st.mode == "MANUAL"
    assert st.apply(hb(0, armed=True), 3.0) == Change.HEARTBEAT
    assert mode_name(15) == "GUIDED" and mode_name(99) == "MODE_99"
    assert mode_number("smart_rtl") == 12
    with pytest.raises(ValueError, match="HOLD"):
        mode_number("LAND")


def test_other_component_heartbeat_is_ignored() -> None:
    st = VehicleState(target_component=1)
    st.apply(hb(4, armed=True, c=codec(1, 154)), 1.0)
    assert st.last_heartbeat_s is None and st.mode == "UNKNOWN"


def test_link_lost_and_regained() -> None:
    st = VehicleState()
    st.apply(hb(0), 10.0)
    assert not st.check_link(10.4, timeout_s=0.5)
    assert st.check_link(10.6, timeout_s=0.5)
    assert st.link_lost and st.link_lost_count == 1
    assert not st.check_link(11.0, timeout_s=0.5)  # counted once
    assert st.apply(hb(0), 11.1) & Change.LINK_REGAINED
    assert not st.link_lost and st.link_lost_count == 1


def test_reboot_from_time_boot_ms_going_back() -> None:
    st = VehicleState(reboot_backstep_ms=1000)
    st.apply(att(60_000, 0.0), 1.0)
    st.apply(lpn(60_010, 1, 1), 1.0)
    assert st.apply(att(59_500, 0.0), 1.1) == Change.ATTITUDE  # small step back: reordering
    changes = st.apply(att(300, 0.0), 2.0)
    assert changes & Change.REBOOT
    assert st.reboot_count == 1 and st.link_lost_count == 1 and st.pose is None


@pytest.mark.parametrize(
    ("flags", "variance", "healthy", "words"),
    [
        (0x1 | 0x2 | 0x8, 0.1, True, "healthy"),
        (0x1 | 0x2, 0.1, False, "no relative horizontal position"),
        (0x1 | 0x2 | 0x8 | 0x400, 0.1, False, "uninitialised"),
        (0x1 | 0x2 | 0x8 | 0x80, 0.1, False, "constant-position"),
        (0x1 | 0x2 | 0x8, 0.9, False, "variance 0.90 > 0.80"),
    ],
)
def test_ekf_health(flags: int, variance: float, healthy: bool, words: str) -> None:
    st = VehicleState(ekf_variance_max=0.8)
    st.apply(decoded(AP.ekf_status_report_encode(flags, variance, 0.1, 0.1, 0.1, 0.0), AP), 1.0)
    assert st.ekf is not None
    assert st.ekf.healthy is healthy
    assert words in st.ekf.describe()


def test_statustext_ring_buffer_and_prefix_lookup() -> None:
    st = VehicleState(statustext_history=3)
    for i, text in enumerate(["a", "PreArm: Throttle below failsafe", "b", "c"]):
        st.apply(decoded(AP.statustext_encode(4, text.encode()), AP), float(i))
    assert [t.text for t in st.statustexts] == ["PreArm: Throttle below failsafe", "b", "c"]
    assert st.latest_statustext("prearm") == "PreArm: Throttle below failsafe"
    assert st.latest_statustext("PreArm", since_s=2.0) is None


def test_rc_servo_origin() -> None:
    st = VehicleState()
    st.apply(decoded(AP.rc_channels_encode(5, 8, *range(1000, 1018), 200), AP), 1.0)
    assert st.rc_inputs_us[:3] == (1000, 1001, 1002) and st.rc_rssi == 200
    st.apply(decoded(AP.servo_output_raw_encode(0, 0, *range(1100, 1116)), AP), 1.0)
    assert st.servo_outputs_us[-1] == 1115
    st.apply(decoded(AP.gps_global_origin_encode(451234567, -731234567, 0), AP), 1.0)
    assert st.gps_origin == pytest.approx((45.1234567, -73.1234567))
