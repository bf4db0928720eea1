"""VehicleState.apply is pure: messages in (built with the real codec), state and changes out."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.link.vehicle import (
    Change,
    EkfStatus,
    MissionCurrent,
    VehicleState,
    mode_name,
    mode_number,
)
from helixd.mav.constants import (
    MISSION_STATE_MAX,
    MISSION_STATE_NOT_STARTED,
    MISSION_STATE_UNKNOWN,
    UINT16_MAX,
)
from helixd.mav.ekf_report import EkfReport
from tests.support.mavmsgs import AP, att, codec, decoded, hb, lpn


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
    # small step back: a reordered (or hostile) message, rejected, not a reboot
    assert st.apply(att(59_500, 0.0), 1.1) == Change.POSE_REJECTED
    assert st.reboot_count == 0 and st.last_time_boot_ms == 60_010
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


def test_gps_fix_satellites_and_battery() -> None:
    st = VehicleState()
    st.apply(decoded(AP.gps_raw_int_encode(0, 3, 0, 0, 0, 100, 100, 0, 0, 12), AP), 1.0)
    assert (st.gps_fix_type, st.gps_satellites) == (3, 12)
    st.apply(decoded(AP.gps_raw_int_encode(0, 200, 0, 0, 0, 100, 100, 0, 0, 255), AP), 2.0)
    assert (st.gps_fix_type, st.gps_satellites) == (None, None)  # not a fix type; unknown
    st.apply(decoded(AP.sys_status_encode(0, 0, 0, 0, 12400, -1, 80, 0, 0, 0, 0, 0, 0), AP), 3.0)
    assert (st.battery_voltage_v, st.battery_remaining_pct) == (12.4, 80)
    st.apply(decoded(AP.sys_status_encode(0, 0, 0, 0, 65535, -1, -1, 0, 0, 0, 0, 0, 0), AP), 4.0)
    assert (st.battery_voltage_v, st.battery_remaining_pct) == (None, None)


def test_gps_fix_time_counts_from_the_message_that_moved_it() -> None:
    """A receiver that stopped leaves ArduPilot repeating its last fix, time_usec frozen: the
    fix's reception stays at the first message that carried that time."""
    st = VehicleState()
    st.apply(decoded(AP.gps_raw_int_encode(1_000_000, 3, 0, 0, 0, 100, 100, 0, 0, 12), AP), 1.0)
    assert (st.gps_time_us, st.gps_rx_s, st.gps_fix_rx_s) == (1_000_000, 1.0, 1.0)
    st.apply(decoded(AP.gps_raw_int_encode(1_000_000, 3, 0, 0, 0, 100, 100, 0, 0, 12), AP), 1.2)
    assert (st.gps_rx_s, st.gps_fix_rx_s) == (1.2, 1.0)
    st.apply(decoded(AP.gps_raw_int_encode(1_200_000, 3, 0, 0, 0, 100, 100, 0, 0, 12), AP), 1.4)
    assert (st.gps_time_us, st.gps_rx_s, st.gps_fix_rx_s) == (1_200_000, 1.4, 1.4)


@pytest.mark.parametrize("lat_e7, lon_e7", [(900_000_001, 0), (0, -1_800_000_001), (2**31 - 1, 0)])
def test_origin_off_the_earth_is_rejected(lat_e7: int, lon_e7: int) -> None:
    st = VehicleState()
    st.apply(decoded(AP.gps_global_origin_encode(451234567, -731234567, 0), AP), 1.0)
    changed = st.apply(decoded(AP.gps_global_origin_encode(lat_e7, lon_e7, 0), AP), 2.0)
    assert changed == Change.NONE and st.origin_rejected_count == 1
    assert st.gps_origin == pytest.approx((45.1234567, -73.1234567))  # the good one stays


# -- hostile telemetry: rejected at the edge, never stored as the pose ---------------------------


def lpn_v(t_ms: int, north: float, east: float, vx: float = 0.0, vz: float = 0.0) -> Any:
    return decoded(AP.local_position_ned_encode(t_ms, north, east, 0, vx, 0.0, vz), AP)


def valid_state() -> VehicleState:
    st = VehicleState()
    st.apply(att(1000, 0.3), 1.0)
    assert st.apply(lpn(1000, 1.0, 2.0), 1.0) & Change.POSE
    return st


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(
    ("north", "east", "vx", "vz", "needle"),
    [
        (NAN, 0.0, 0.0, 0.0, "x (north) is nan"),
        (0.0, NAN, 0.0, 0.0, "y (east) is nan"),
        (NAN, NAN, 0.0, 0.0, "is nan"),
        (INF, 0.0, 0.0, 0.0, "is inf"),
        (0.0, -INF, 0.0, 0.0, "is -inf"),
        (1e9, 0.0, 0.0, 0.0, "beyond"),
        (0.0, -60_000.0, 0.0, 0.0, "beyond"),
        (0.0, 0.0, NAN, 0.0, "vx is nan"),
        (0.0, 0.0, 0.0, INF, "vz is inf"),
        (0.0, 0.0, 25.0, 0.0, "vx = 25 m/s beyond"),
    ],
)
def test_bad_position_is_rejected_never_stored(
    north: float, east: float, vx: float, vz: float, needle: str
) -> None:
    st = valid_state()
    good = st.pose
    changes = st.apply(lpn_v(1050, north, east, vx, vz), 1.05)
    assert changes == Change.POSE_REJECTED
    assert st.pose is good  # the last valid pose is kept (and ages: it is not fresh)
    assert st.pose_invalid and st.pose_invalid_since_s == 1.05
    assert needle in st.pose_invalid_reason
    assert st.pose_rejected_count == 1
    assert st.pose_rejected_kinds == {"position_invalid": 1}


@pytest.mark.parametrize("yaw", [NAN, INF, -INF, 13.0, -100.0])
def test_bad_yaw_is_rejected_and_forgotten(yaw: float) -> None:
    st = valid_state()
    good = st.pose
    assert st.apply(att(1040, yaw), 1.04) == Change.POSE_REJECTED
    assert st.yaw_ned_rad is None  # no pose may be formed from the older yaw
    # a valid position after a bad attitude gives no pose
    assert not st.apply(lpn(1050, 1.1, 2.0), 1.05) & Change.POSE
    assert st.pose is good and st.pose_invalid
    assert st.pose_rejected_kinds == {"attitude_invalid": 1}


def test_yaw_within_bounds_beyond_pi_is_accepted() -> None:
    st = VehicleState()
    assert st.apply(att(1000, 4.0), 1.0) == Change.ATTITUDE  # unwrapped but sane
    assert st.yaw_ned_rad == pytest.approx(4.0)


def test_burst_lasts_until_a_valid_pose_and_counts_every_rejection() -> None:
    st = valid_state()
    for i in range(5):
        st.apply(lpn_v(1050 + 50 * i, NAN, NAN), 1.05 + 0.05 * i)
    assert st.pose_invalid_since_s == 1.05  # first bad frame of the burst
    assert st.pose_rejected_count == 5
    st.apply(att(1300, 0.3), 1.3)
    assert st.apply(lpn(1300, 1.5, 2.0), 1.3) & Change.POSE
    assert not st.pose_invalid and st.pose_invalid_since_s is None
    assert st.pose is not None and st.pose.ned.north_m == pytest.approx(1.5)
    assert st.pose_rejected_count == 5  # the count stays for diagnostics


def test_invalid_stream_never_refreshes_the_pose() -> None:
    """A stream of invalid poses must not count as fresh: rx time stays at the last valid."""
    st = valid_state()
    for i in range(40):
        st.apply(att(1050 + 50 * i, 0.3), 1.05 + 0.05 * i)
        st.apply(lpn_v(1050 + 50 * i, NAN, 0.0), 1.05 + 0.05 * i)
    assert st.pose is not None and st.pose.rx_monotonic_s == 1.0


def test_small_time_backstep_is_out_of_order_not_reboot() -> None:
    st = valid_state()  # pose at 1000 ms
    st.apply(att(1500, 0.3), 1.5)
    assert st.apply(lpn(1500, 1.2, 2.0), 1.5) & Change.POSE
    assert st.apply(lpn(1100, 9.0, 9.0), 1.55) == Change.POSE_REJECTED
    assert st.apply(att(1200, 2.0), 1.56) == Change.POSE_REJECTED
    assert st.yaw_ned_rad == pytest.approx(0.3)  # an old attitude does not spoil the new one
    assert st.reboot_count == 0 and st.last_time_boot_ms == 1500
    assert st.pose is not None and st.pose.ned.north_m == pytest.approx(1.2)
    assert st.pose_rejected_kinds == {"position_out_of_order": 1, "attitude_out_of_order": 1}
    # time moving on again: accepted
    st.apply(att(1550, 0.3), 1.6)
    assert st.apply(lpn(1550, 1.3, 2.0), 1.6) & Change.POSE
    assert not st.pose_invalid


def test_large_time_backstep_is_still_a_reboot() -> None:
    st = VehicleState(reboot_backstep_ms=1000)
    st.apply(att(60_000, 0.0), 1.0)
    st.apply(lpn(60_000, 1.0, 1.0), 1.0)
    changes = st.apply(lpn(500, 1.0, 1.0), 2.0)
    assert changes & Change.REBOOT and not changes & Change.POSE_REJECTED
    assert st.pose is None and st.reboot_count == 1


def test_no_valid_pose_ever_when_nan_from_the_start() -> None:
    st = VehicleState()
    for i in range(10):
        st.apply(att(1000 + 50 * i, NAN), 1.0 + 0.05 * i)
        st.apply(lpn(1000 + 50 * i, 0.0, 0.0), 1.0 + 0.05 * i)
    assert st.pose is None and st.pose_invalid_since_s == 1.0


def test_bounds_come_from_the_safety_config() -> None:
    from helixd.config.safety import SafetyConfig
    from helixd.link.vehicle import TelemetryBounds

    cfg = SafetyConfig(telemetry_position_max_m=100.0, telemetry_speed_max_mps=2.0)
    st = VehicleState(bounds=TelemetryBounds.from_safety(cfg))
    st.apply(att(1000, 0.0), 1.0)
    assert st.apply(lpn_v(1000, 150.0, 0.0), 1.0) == Change.POSE_REJECTED
    assert st.apply(lpn_v(1010, 50.0, 0.0, vx=3.0), 1.01) == Change.POSE_REJECTED
    assert st.apply(lpn_v(1020, 50.0, 0.0, vx=1.0), 1.02) & Change.POSE
    assert TelemetryBounds.from_safety(SafetyConfig()) == TelemetryBounds()


WIRE_FLOAT = st.floats(allow_nan=True, allow_infinity=True, width=32)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.booleans(),  # ATTITUDE or LOCAL_POSITION_NED
            st.integers(0, 2**32 - 1),  # time_boot_ms
            WIRE_FLOAT,
            WIRE_FLOAT,
            WIRE_FLOAT,
        ),
        max_size=30,
    )
)
def test_fuzz_stored_pose_is_always_finite_and_in_bounds(
    frames: list[tuple[bool, int, float, float, float]],
) -> None:
    """Whatever arrives, in whatever order: the stored pose is finite and within bounds, and a
    pose is stored only from a frame that was not rejected."""
    st_ = VehicleState()
    b = st_.bounds
    for i, (is_att, t_ms, a, b_, c) in enumerate(frames):
        msg = (
            decoded(AP.attitude_encode(t_ms, 0, 0, a, 0, 0, 0), AP)
            if is_att
            else decoded(AP.local_position_ned_encode(t_ms, a, b_, 0, c, 0.0, 0.0), AP)
        )
        changes = st_.apply(msg, float(i))
        assert not (changes & Change.POSE and changes & Change.POSE_REJECTED)
        pose = st_.pose
        if pose is not None:
            ned = pose.ned
            assert all(math.isfinite(v) for v in (ned.north_m, ned.east_m, ned.yaw_ned_rad))
            assert abs(ned.north_m) <= b.position_max_m and abs(ned.east_m) <= b.position_max_m
            assert abs(ned.yaw_ned_rad) <= b.yaw_max_rad
            assert all(math.isfinite(v) and abs(v) <= b.speed_max_mps for v in (pose.vn_mps,))
        if st_.yaw_ned_rad is not None:
            assert math.isfinite(st_.yaw_ned_rad)
        if changes & Change.POSE:
            assert not st_.pose_invalid


def test_home_position_is_checked_at_the_edge() -> None:
    """HOME_POSITION: lat/lon on the Earth or ignored; north/east kept when finite and within
    the telemetry bounds, else unknown (ArduPilot sends NaN before it has an origin)."""

    def home(lat: float, lon: float, x: float, y: float) -> Any:
        q = [math.nan] * 4
        msg = AP.home_position_encode(round(lat * 1e7), round(lon * 1e7), 0, x, y, 0.0, q,
                                      0, 0, 0, 0)  # fmt: skip
        return decoded(msg, AP)

    st = VehicleState()
    assert st.apply(home(53.5, -113.5, 3.0, -2.0), 1.0) & Change.HOME
    assert st.home is not None and (st.home.north_m, st.home.east_m) == (3.0, -2.0)
    st.apply(home(53.5, -113.5, math.nan, 0.0), 2.0)
    assert st.home is not None and st.home.north_m is None and st.home_rx_s == 2.0
    st.apply(home(53.5, -113.5, 1e9, 0.0), 3.0)
    assert st.home is not None and st.home.north_m is None
    assert st.apply(home(95.0, 0.0, 0.0, 0.0), 4.0) == Change.NONE
    assert st.home_rejected_count == 1 and st.home_rx_s == 3.0


@settings(max_examples=200)
@given(
    st.integers(0, 0xFFFF),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=5, max_size=5),
)
def test_ekf_health_is_judged_once_when_the_report_arrives(flags: int, var: list[float]) -> None:
    """EkfStatus.healthy is computed at construction (5 Hz), not per read (every tick): the
    same verdict as its list of problems."""
    ekf = EkfStatus(EkfReport(flags, var[0], var[1], var[2], var[3], var[4]), 1.0, 0.8)
    assert ekf.healthy is (not ekf.problems())


def mission_current(seq: int, total: int, state: int, mode: int = 0) -> Any:
    return decoded(AP.mission_current_encode(seq, total, state, mode), AP)


class FakeMissionCurrent:
    """A MISSION_CURRENT as a hostile or broken decoder might hand it over."""

    def __init__(self, seq: object, total: object, mission_state: object) -> None:
        self.seq, self.total, self.mission_state = seq, total, mission_state

    def get_type(self) -> str:
        return "MISSION_CURRENT"

    def get_srcComponent(self) -> int:
        return 1


def test_mission_current_is_kept_with_its_state_and_cleared_by_a_reboot() -> None:
    st_ = VehicleState()
    assert st_.apply(mission_current(3, 5, MISSION_STATE_NOT_STARTED), 1.0) == (
        Change.MISSION_CURRENT
    )
    assert st_.mission_current == MissionCurrent(3, 5, MISSION_STATE_NOT_STARTED, 1.0, 0)
    # a mission_state this dialect does not define reads as UNKNOWN; seq/total are kept
    st_.apply(mission_current(4, 5, 200), 2.0)
    assert st_.mission_current == MissionCurrent(4, 5, MISSION_STATE_UNKNOWN, 2.0, 0)
    assert not st_.mission_mode_reported  # 0 in every mode: an autopilot may not fill it
    st_.apply(mission_current(4, 5, MISSION_STATE_NOT_STARTED, mode=1), 2.5)
    assert st_.mission_current is not None and st_.mission_current.mission_mode == 1
    assert st_.mission_mode_reported  # seen 1 (AUTO): the field is filled from now on
    assert st_.mission_auto_rx_s == 2.5  # AUTO entered by then
    st_.apply(mission_current(4, 5, MISSION_STATE_NOT_STARTED, mode=0), 2.8)
    assert st_.mission_auto_rx_s == 2.5  # the last report of AUTO is kept
    st_.apply(att(10_000, 0.0), 3.0)
    assert st_.apply(att(100, 0.0), 4.0) & Change.REBOOT
    assert st_.mission_current is None and st_.mission_auto_rx_s is None


@settings(max_examples=200, deadline=None)
@given(st.integers(0, UINT16_MAX), st.integers(0, UINT16_MAX), st.integers(0, 255))
def test_fuzz_mission_current_from_the_wire(seq: int, total: int, state: int) -> None:
    st_ = VehicleState()
    assert st_.apply(mission_current(seq, total, state), 5.0) & Change.MISSION_CURRENT
    mc = st_.mission_current
    assert mc is not None and (mc.seq, mc.total) == (seq, total)
    assert mc.mission_state == (state if state <= MISSION_STATE_MAX else MISSION_STATE_UNKNOWN)


ANY_FIELD = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**40), 2**40),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=3),
)


@settings(max_examples=300, deadline=None)
@given(ANY_FIELD, ANY_FIELD, ANY_FIELD)
def test_fuzz_mission_current_fields_are_checked_at_the_edge(
    seq: object, total: object, state: object
) -> None:
    """Whatever the fields hold: stored only as uint16 ints and a known MISSION_STATE, or
    counted as rejected with the previous value kept."""
    st_ = VehicleState()
    st_.apply(mission_current(1, 2, MISSION_STATE_NOT_STARTED), 1.0)
    before = st_.mission_current
    changes = st_.apply(FakeMissionCurrent(seq, total, state), 2.0)

    def uint16(v: object) -> bool:
        return type(v) is int and 0 <= v <= UINT16_MAX

    if uint16(seq) and uint16(total):
        assert changes == Change.MISSION_CURRENT
        mc = st_.mission_current
        assert mc is not None and (mc.seq, mc.total) == (seq, total)
        assert type(mc.mission_state) is int and 0 <= mc.mission_state <= MISSION_STATE_MAX
        assert st_.mission_current_rejected_count == 0
    else:
        assert changes == Change.NONE
        assert st_.mission_current == before and st_.mission_current_rejected_count == 1


def target(lat_e7: int, lon_e7: int, type_mask: int = 0xFFF8) -> Any:
    zeros = [0.0] * 8
    msg = AP.position_target_global_int_encode(1000, 0, type_mask, lat_e7, lon_e7, 700.0, *zeros)
    return decoded(msg, AP)


def test_position_target_kept_when_a_place_and_mode_since_its_heartbeat() -> None:
    st = VehicleState()
    st.apply(hb(15), 1.0)
    assert st.mode_since_s == 1.0
    st.apply(hb(15), 2.0)
    assert st.mode_since_s == 1.0  # the same mode: since the first HEARTBEAT naming it
    assert st.apply(target(523_000_000, 130_000_000), 2.5) == Change.TARGET
    assert st.position_target is not None and st.position_target.lat_deg == 52.3
    assert st.position_target.rx_monotonic_s == 2.5
    for bad in (target(0, 0), target(910_000_000, 1), target(1, 1, type_mask=0xFFFB)):
        assert st.apply(bad, 3.0) == Change.NONE  # 0/0, off the Earth, lat/lon ignored
    assert st.position_target_rejected_count == 3
