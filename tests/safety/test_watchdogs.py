"""Each safety watchdog fires on its fault and stays quiet on a healthy snapshot."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import pytest

from helixd.base.polygon import point_in_polygon
from helixd.config.safety import SafetyConfig, StallConfig, TakeoverConfig
from helixd.safety.watchdogs import (
    HANDED_CAUSES,
    NEXT_FLIGHT_CAUSES,
    OPERATOR_CAUSES,
    STOP_CAUSES,
    Fault,
    FaultCause,
    SafetyInputs,
    SafetyMonitor,
)
from tests.support.safety_inputs import HEALTHY


def test_healthy_snapshot_passes() -> None:
    assert SafetyMonitor(SafetyConfig()).check(HEALTHY) is None


@pytest.mark.parametrize(
    ("change", "cause", "needle"),
    [
        ({"last_heartbeat_s": 97.9}, FaultCause.LINK_LOST, "2.10 s"),
        ({"last_heartbeat_s": None}, FaultCause.LINK_LOST, "no HEARTBEAT"),
        ({"pose_rx_s": 99.4}, FaultCause.POSE_STALE, "0.60 s old"),
        (
            {"ekf_healthy": False, "ekf_detail": "pos_horiz_variance 1.2"},
            FaultCause.EKF_UNHEALTHY,
            "1.2",
        ),
        ({"mode": "HOLD"}, FaultCause.PILOT_TAKEOVER, "mode changed to HOLD"),
        ({"armed": False}, FaultCause.DISARMED, "disarmed"),
        ({"north_m": 80.0, "east_m": 80.0}, FaultCause.GEOFENCE, "113.1 m from the start"),
        ({"mission_elapsed_s": 1801.0}, FaultCause.MISSION_TIME, "driving 1801 s (limit 1800 s)"),
        (
            {"mission_elapsed_s": 1801.0, "mission_paused_s": 600.0},
            FaultCause.MISSION_TIME,
            "driving 1801 s (limit 1800 s; 600 s paused not counted)",
        ),
    ],
)
def test_each_watchdog_fires(change: dict[str, object], cause: FaultCause, needle: str) -> None:
    fault = SafetyMonitor(SafetyConfig()).check(dataclasses.replace(HEALTHY, **change))  # type: ignore[arg-type]
    assert fault is not None
    assert fault.cause is cause
    assert needle in fault.detail


def test_a_lost_link_is_named_before_what_its_loss_starves() -> None:
    """A pulled cable: the transport's cause at once, before the heartbeat timeout; an
    autopilot silent in every message: the link, not the pose or the GPS it also starves."""
    monitor = SafetyMonitor(SafetyConfig())
    closed = dataclasses.replace(
        HEALTHY, link_lost_cause="closed by the other end", pose_rx_s=99.0, gps_monitored=True
    )
    fault = monitor.check(closed)
    assert fault is not None and fault.cause is FaultCause.LINK_LOST
    assert fault.detail == "closed by the other end"
    silent = dataclasses.replace(HEALTHY, last_rx_s=99.3, pose_rx_s=99.3, gps_rx_s=99.3)
    fault = monitor.check(dataclasses.replace(silent, gps_monitored=True))
    assert fault is not None and fault.cause is FaultCause.LINK_LOST
    assert "no message from the autopilot for 0.70 s" in fault.detail
    # the pose stream alone stopped, other messages flow: the pose, as before
    fault = monitor.check(dataclasses.replace(HEALTHY, last_rx_s=99.99, pose_rx_s=99.3))
    assert fault is not None and fault.cause is FaultCause.POSE_STALE


@pytest.mark.parametrize("phase_s", [0.0, 0.05, 0.1, 0.15, 0.199])
def test_a_silent_link_is_named_whatever_the_gps_and_pose_phase(phase_s: float) -> None:
    """Every message stops at 99.3 s; the last GPS_RAW_INT (5 Hz) came ``phase_s`` before
    that and the last pose 10 ms before. Judged every 10 ms: the first fault is the link's,
    never the GPS overdue 0.4-0.6 s after the silence (it was, when its phase made it due
    before the link's 0.5 s)."""
    monitor = SafetyMonitor(SafetyConfig())
    silence_s = 99.3
    starved = dataclasses.replace(
        HEALTHY,
        last_rx_s=silence_s,
        pose_rx_s=silence_s - 0.01,
        gps_rx_s=silence_s - phase_s,
        gps_fix_rx_s=silence_s - phase_s,
        gps_fix_type=3,
        gps_satellites=12,
        gps_monitored=True,
    )
    for step in range(1, 120):
        now = silence_s + step * 0.01
        fault = monitor.check(dataclasses.replace(starved, now_s=now, last_heartbeat_s=99.0))
        if fault is not None:
            assert fault.cause is FaultCause.LINK_LOST, (now, fault)
            assert now - silence_s <= SafetyConfig().pose_stale_s + 0.011
            return
    raise AssertionError("no fault")


def test_a_gps_stream_that_alone_stopped_is_the_gps() -> None:
    """GPS_RAW_INT stops while the pose and the rest flow: the GPS, one message after it
    became due (not deferred to a link that is fine)."""
    monitor = SafetyMonitor(SafetyConfig())
    limit_s = SafetyConfig().gps_stale_s
    gps_s = 99.0
    alive = dataclasses.replace(
        HEALTHY,
        gps_rx_s=gps_s,
        gps_fix_rx_s=gps_s,
        gps_fix_type=3,
        gps_satellites=12,
        gps_monitored=True,
    )
    due = dataclasses.replace(alive, now_s=gps_s + limit_s + 0.01, last_rx_s=gps_s + limit_s + 0.01)
    fault = monitor.check(dataclasses.replace(due, last_heartbeat_s=due.now_s, pose_rx_s=due.now_s))
    assert fault is not None and fault.cause is FaultCause.GPS_LOST, fault


def test_time_paused_is_not_held_against_the_limit() -> None:
    held = dataclasses.replace(HEALTHY, mission_elapsed_s=1700.0, mission_paused_s=5000.0)
    assert SafetyMonitor(SafetyConfig()).check(held) is None


def test_boundaries_are_inclusive_of_healthy() -> None:
    mon = SafetyMonitor(SafetyConfig())
    assert mon.check(dataclasses.replace(HEALTHY, last_heartbeat_s=98.0)) is None  # exactly 2.0 s
    assert mon.check(dataclasses.replace(HEALTHY, pose_rx_s=99.5)) is None  # exactly 0.5 s


def test_rc_switch_and_stick_takeover() -> None:
    cfg = SafetyConfig(
        takeover=TakeoverConfig(switch_channel=7, stick_channels=(1, 3), stick_deflection_us=150)
    )
    mon = SafetyMonitor(cfg)
    rc = [1500] * 8
    rc[6] = 1900
    fault = mon.check(dataclasses.replace(HEALTHY, rc_inputs_us=tuple(rc)))
    assert fault is not None and "RC7" in fault.detail
    rc = [1500] * 8
    rc[2] = 1660
    fault = mon.check(dataclasses.replace(HEALTHY, rc_inputs_us=tuple(rc)))
    assert fault is not None and "RC3 deflected 160" in fault.detail
    rc[2] = 1640  # inside the deflection threshold
    assert mon.check(dataclasses.replace(HEALTHY, rc_inputs_us=tuple(rc))) is None


def test_polygon_geofence() -> None:
    square = ((0.0, 0.0), (0.0, 20.0), (20.0, 20.0), (20.0, 0.0))
    assert point_in_polygon(5, 5, square)
    assert not point_in_polygon(25, 5, square)
    mon = SafetyMonitor(SafetyConfig(geofence_radius_m=None, geofence_polygon_ne_m=square))
    assert mon.check(HEALTHY) is None
    fault = mon.check(dataclasses.replace(HEALTHY, north_m=-1.0))
    assert fault is not None and fault.cause is FaultCause.GEOFENCE


def test_stall_needs_duration_and_resets_when_moving() -> None:
    # the stopped-rover rule alone (the crawl over the same 4 s is tested below)
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=4.0, crawl_fraction=0.0)))
    stuck = dataclasses.replace(HEALTHY, commanded_speed_mps=0.5, measured_speed_mps=0.01)
    for t in (100.0, 102.0, 103.9):
        assert (
            mon.check(dataclasses.replace(stuck, now_s=t, last_heartbeat_s=t, pose_rx_s=t)) is None
        )
    # moving again resets the timer
    assert (
        mon.check(
            dataclasses.replace(HEALTHY, now_s=104.0, last_heartbeat_s=104.0, pose_rx_s=104.0)
        )
        is None
    )
    assert (
        mon.check(dataclasses.replace(stuck, now_s=107.0, last_heartbeat_s=107.0, pose_rx_s=107.0))
        is None
    )
    fault = mon.check(
        dataclasses.replace(stuck, now_s=111.0, last_heartbeat_s=111.0, pose_rx_s=111.0)
    )
    assert fault is not None and fault.cause is FaultCause.STALL and "4.0 s" in fault.detail


def test_turn_stall_in_sand() -> None:
    mon = SafetyMonitor(SafetyConfig())
    turning = dataclasses.replace(
        HEALTHY,
        commanded_speed_mps=0.0,
        measured_speed_mps=0.0,
        commanded_yaw_rate_radps=1.0,
        measured_yaw_rate_radps=0.01,
    )
    assert mon.check(turning) is None
    later = dataclasses.replace(turning, now_s=104.5, last_heartbeat_s=104.5, pose_rx_s=104.5)
    fault = mon.check(later)
    assert fault is not None and fault.cause is FaultCause.STALL and "turn" in fault.detail


def test_rc_receiver_loss() -> None:
    mon = SafetyMonitor(SafetyConfig())
    assert mon.check(dataclasses.replace(HEALTHY, rc_receiver_healthy=None)) is None  # no RC
    assert mon.check(dataclasses.replace(HEALTHY, rc_receiver_healthy=True)) is None
    fault = mon.check(dataclasses.replace(HEALTHY, rc_receiver_healthy=False))
    assert fault is not None and fault.cause is FaultCause.RC_LOST
    quiet = SafetyMonitor(SafetyConfig(stop_on_rc_loss=False))
    assert quiet.check(dataclasses.replace(HEALTHY, rc_receiver_healthy=False)) is None


# -- hostile telemetry: an invalid pose is a fault, NaN is never "fine" ----------------------------

NAN, INF = float("nan"), float("inf")


def test_pose_invalid_tolerated_up_to_the_stale_limit() -> None:
    mon = SafetyMonitor(SafetyConfig(pose_stale_s=0.5))
    # last valid pose 99.98, rejections since 99.99: 0.02 s old, a glitch, not a fault yet
    glitch = dataclasses.replace(HEALTHY, pose_invalid_since_s=99.99, pose_invalid_detail="x")
    assert mon.check(glitch) is None


def test_pose_invalid_fires_at_the_stale_limit_and_names_the_cause() -> None:
    mon = SafetyMonitor(SafetyConfig(pose_stale_s=0.5))
    s = dataclasses.replace(
        HEALTHY,
        now_s=100.6,
        last_heartbeat_s=100.5,
        pose_rx_s=100.0,  # last valid pose
        pose_invalid_since_s=100.05,
        pose_invalid_detail="LOCAL_POSITION_NED position x (north) is nan",
    )
    fault = mon.check(s)
    assert fault is not None
    # not pose_stale: the stale-pose rule would fire at the same moment, this names the reason
    assert fault.cause is FaultCause.POSE_INVALID
    assert "0.60 s" in fault.detail and "is nan" in fault.detail


def test_pose_invalid_without_any_valid_pose() -> None:
    mon = SafetyMonitor(SafetyConfig(pose_stale_s=0.5))
    s = dataclasses.replace(HEALTHY, pose_rx_s=None, pose_invalid_since_s=99.4)
    fault = mon.check(s)
    assert fault is not None and fault.cause is FaultCause.POSE_INVALID


def test_invalid_stream_does_not_count_as_fresh() -> None:
    """The stale-pose watchdog is not fooled by a stream of rejected poses: rejected poses
    never update pose_rx_s, so the pose ages and the fault fires."""
    mon = SafetyMonitor(SafetyConfig(pose_stale_s=0.5))
    s = dataclasses.replace(HEALTHY, pose_rx_s=99.3, pose_invalid_since_s=99.95)
    fault = mon.check(s)
    assert fault is not None and fault.cause is FaultCause.POSE_INVALID


@pytest.mark.parametrize(
    ("change", "cause"),
    [
        ({"north_m": NAN}, FaultCause.POSE_INVALID),
        ({"east_m": INF}, FaultCause.POSE_INVALID),
        ({"measured_speed_mps": NAN}, FaultCause.POSE_INVALID),
        ({"measured_yaw_rate_radps": -INF}, FaultCause.POSE_INVALID),
        ({"start_north_m": NAN}, FaultCause.POSE_INVALID),
        ({"commanded_speed_mps": NAN}, FaultCause.EXCEPTION),
        ({"commanded_yaw_rate_radps": INF}, FaultCause.EXCEPTION),
        ({"now_s": NAN}, FaultCause.EXCEPTION),
        ({"pose_rx_s": NAN}, FaultCause.EXCEPTION),
        ({"mission_elapsed_s": INF}, FaultCause.EXCEPTION),
    ],
)
def test_non_finite_inputs_are_faults(change: dict[str, object], cause: FaultCause) -> None:
    fault = SafetyMonitor(SafetyConfig()).check(dataclasses.replace(HEALTHY, **change))  # type: ignore[arg-type]
    assert fault is not None and fault.cause is cause


def test_each_rule_treats_nan_as_fault_worthy() -> None:
    """Rule by rule (bypassing the finiteness gate): NaN must not read as 'fine'."""
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=0.5)))
    assert mon._geofence(dataclasses.replace(HEALTHY, north_m=NAN)) is not None
    assert mon._pose(dataclasses.replace(HEALTHY, now_s=NAN)) is not None
    assert mon._link(dataclasses.replace(HEALTHY, now_s=NAN)) is not None
    assert mon._time(dataclasses.replace(HEALTHY, mission_elapsed_s=NAN)) is not None
    assert (
        mon._pose_invalid(dataclasses.replace(HEALTHY, pose_invalid_since_s=99.9, now_s=NAN))
        is not None
    )
    turning = dataclasses.replace(HEALTHY, commanded_speed_mps=0.0, measured_speed_mps=0.0)
    for bad in (
        dataclasses.replace(HEALTHY, measured_speed_mps=NAN),
        dataclasses.replace(HEALTHY, commanded_speed_mps=NAN, measured_speed_mps=0.0),
        dataclasses.replace(turning, commanded_yaw_rate_radps=NAN),
        dataclasses.replace(turning, commanded_yaw_rate_radps=1.0, measured_yaw_rate_radps=NAN),
    ):
        mon.reset()
        assert mon._stall(bad) is None  # the stall timer starts...
        fault = mon._stall(dataclasses.replace(bad, now_s=bad.now_s + 1.0))
        assert fault is not None and fault.cause is FaultCause.STALL  # ...and fires


def test_stall_duration_counts_autopilot_time() -> None:
    """A 5x simulator speed-up: 1 s of wall clock is 5 s of the rover's motion."""
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=4.0)))
    stuck = dataclasses.replace(HEALTHY, commanded_speed_mps=0.5, measured_speed_mps=0.0)

    def at(wall_s: float, boot_s: float) -> SafetyInputs:
        return dataclasses.replace(
            stuck, now_s=wall_s, last_heartbeat_s=wall_s, pose_rx_s=wall_s, vehicle_time_s=boot_s
        )

    assert mon.check(at(100.0, 500.0)) is None
    assert mon.check(at(100.7, 503.5)) is None  # 3.5 s of vehicle time
    fault = mon.check(at(100.9, 504.5))  # 0.9 s of wall clock, 4.5 s of vehicle time
    assert fault is not None and fault.cause is FaultCause.STALL and "4.5 s" in fault.detail


def test_stall_timer_restarts_when_the_autopilot_clock_runs_backwards() -> None:
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=4.0)))
    stuck = dataclasses.replace(HEALTHY, commanded_speed_mps=0.5, measured_speed_mps=0.0)
    assert mon._stall(dataclasses.replace(stuck, vehicle_time_s=500.0)) is None
    assert mon._stall(dataclasses.replace(stuck, vehicle_time_s=2.0)) is None  # reboot
    assert mon._stall(dataclasses.replace(stuck, vehicle_time_s=5.9)) is None  # 3.9 s since
    fault = mon._stall(dataclasses.replace(stuck, vehicle_time_s=6.1))
    assert fault is not None and fault.cause is FaultCause.STALL


def test_stall_timer_never_mixes_clocks() -> None:
    """Wall time 100 s then autopilot time 500 s is not 400 s of stall."""
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=4.0)))
    stuck = dataclasses.replace(HEALTHY, commanded_speed_mps=0.5, measured_speed_mps=0.0)
    assert mon._stall(stuck) is None  # no autopilot clock: wall clock 100 s
    assert mon._stall(dataclasses.replace(stuck, vehicle_time_s=500.0)) is None


def test_stall_ignores_the_wall_clock_when_the_autopilot_clock_is_known() -> None:
    """Reception gaps are pose_stale's business: a stall needs vehicle time to pass."""
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=4.0)))
    stuck = dataclasses.replace(
        HEALTHY, commanded_speed_mps=0.5, measured_speed_mps=0.0, vehicle_time_s=500.0
    )
    assert mon._stall(stuck) is None
    assert mon._stall(dataclasses.replace(stuck, now_s=200.0)) is None


def test_non_finite_autopilot_clock_is_a_fault() -> None:
    fault = SafetyMonitor(SafetyConfig()).check(
        dataclasses.replace(HEALTHY, vehicle_time_s=float("nan"))
    )
    assert fault is not None and fault.cause is FaultCause.EXCEPTION


GPS_OK = dataclasses.replace(
    HEALTHY, gps_monitored=True, gps_rx_s=99.9, gps_fix_type=3, gps_satellites=10
)


def test_gps_good_enough_passes_and_unmonitored_is_not_judged() -> None:
    monitor = SafetyMonitor(SafetyConfig())
    assert monitor.check(GPS_OK) is None
    assert monitor.check(dataclasses.replace(GPS_OK, gps_satellites=6)) is None  # inclusive
    assert monitor.check(dataclasses.replace(GPS_OK, gps_rx_s=99.41)) is None  # within the limit
    assert monitor.check(dataclasses.replace(HEALTHY, gps_fix_type=0)) is None


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        ({"gps_fix_type": 1, "gps_satellites": 0}, "no fix (fix_type 1), below the minimum 3D"),
        ({"gps_fix_type": 0}, "no GPS (fix_type 0)"),
        ({"gps_fix_type": 2}, "2D fix"),
        ({"gps_fix_type": None}, "unknown"),
        ({"gps_satellites": 5}, "5 satellites (minimum 6)"),
        ({"gps_satellites": None}, "unknown number of satellites"),
        ({"gps_rx_s": 99.2}, "GPS_RAW_INT stopped: the latest is 0.80 s old (limit 0.6 s)"),
        (
            {"gps_fix_rx_s": 99.2},
            "the GPS receiver stopped: GPS_RAW_INT repeats a fix 0.80 s old",
        ),
        ({"gps_rx_s": None}, "no GPS_RAW_INT received"),
    ],
)
def test_gps_lost_fires(change: dict[str, object], needle: str) -> None:
    fault = SafetyMonitor(SafetyConfig()).check(dataclasses.replace(GPS_OK, **change))  # type: ignore[arg-type]
    assert fault is not None and fault.cause is FaultCause.GPS_LOST
    assert needle in fault.detail


def test_gps_minimum_fix_is_configurable_for_precision_work() -> None:
    rtk = SafetyMonitor(SafetyConfig(gps_min_fix_type=6))
    fault = rtk.check(dataclasses.replace(GPS_OK, gps_fix_type=5))
    assert fault is not None and "RTK float (fix_type 5), below the minimum RTK fixed" in (
        fault.detail
    )
    assert rtk.check(dataclasses.replace(GPS_OK, gps_fix_type=6)) is None


@pytest.mark.parametrize("field", ["gps_rx_s", "gps_fix_rx_s"])
def test_gps_non_finite_reception_clock_is_a_fault(field: str) -> None:
    fault = SafetyMonitor(SafetyConfig()).check(dataclasses.replace(GPS_OK, **{field: math.nan}))  # type: ignore[arg-type]
    assert fault is not None and fault.cause is FaultCause.EXCEPTION


def test_gps_fix_time_within_the_limit_passes_and_a_lost_fix_is_named_first() -> None:
    monitor = SafetyMonitor(SafetyConfig())
    assert monitor.check(dataclasses.replace(GPS_OK, gps_fix_rx_s=99.41)) is None
    # no fix and a frozen fix time: the fix is what the operator needs to hear
    fault = monitor.check(dataclasses.replace(GPS_OK, gps_fix_rx_s=90.0, gps_fix_type=1))
    assert fault is not None and "no fix (fix_type 1)" in fault.detail


def drive(
    mon: SafetyMonitor,
    seconds: float,
    commanded_mps: float,
    measured: Callable[[float], float],
    t0: float = 100.0,
    hz: float = 50.0,
) -> tuple[float, Fault | None]:
    """Step the monitor at ``hz`` on the vehicle clock for ``seconds``; ``measured(t)``: the
    speed over ground. (time of the first fault, the fault) or (end, None)."""
    for k in range(round(seconds * hz)):
        t = t0 + k / hz
        speed = measured(t - t0)
        s = dataclasses.replace(
            HEALTHY, now_s=t, last_heartbeat_s=t, pose_rx_s=t, vehicle_time_s=t,
            commanded_speed_mps=commanded_mps, measured_speed_mps=speed,
        )  # fmt: skip
        fault = mon.check(s)
        if fault is not None:
            return t - t0, fault
    return seconds, None


def test_a_rover_crawling_at_a_few_cm_per_s_is_a_stall_within_seconds() -> None:
    """Rolling in water: 0.02-0.07 m/s of 0.6 commanded, now and then above the stopped
    rover's 0.05 m/s (which restarts that rule's timer): stuck, said after duration_s."""
    mon = SafetyMonitor(SafetyConfig())
    t, fault = drive(mon, 200.0, 0.6, lambda t: 0.045 + 0.025 * math.sin(2.0 * t))
    assert fault is not None and fault.cause is FaultCause.STALL, fault
    assert "stall.crawl_fraction" in fault.detail and "stuck" in fault.detail
    assert 4.0 <= t < 4.2


def test_slip_in_mud_is_not_a_crawl() -> None:
    mon = SafetyMonitor(SafetyConfig())
    _, fault = drive(mon, 120.0, 0.6, lambda t: 0.6 * 0.3)  # ROLL in mud: 0.3 delivered
    assert fault is None
    _, fault = drive(mon, 120.0, 0.6, lambda t: 0.6 * 0.12, t0=300.0)  # above a tenth
    assert fault is None


def test_a_crawl_needs_the_whole_window_commanded() -> None:
    """A stop or a turn in place (commanded below commanded_speed_min_mps) starts it afresh:
    accelerating from a stop is not a crawl."""
    mon = SafetyMonitor(SafetyConfig())
    for start in range(100, 160, 3):  # every 3 s a stop; crawling in between
        _, fault = drive(mon, 2.9, 0.6, lambda t: 0.03, t0=float(start))
        assert fault is None
        _, fault = drive(mon, 0.1, 0.0, lambda t: 0.0, t0=start + 2.9)
        assert fault is None


def test_crawl_fraction_zero_turns_the_crawl_watch_off() -> None:
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(crawl_fraction=0.0)))
    _, fault = drive(mon, 60.0, 0.6, lambda t: 0.045 + 0.025 * math.sin(2.0 * t))
    assert fault is None


def test_the_crawl_watch_is_for_rolling_scrolling_slowly_is_not_stuck() -> None:
    """SCROLL on hard ground or sand delivers 0.12 of its command (docs/physics.md), which the
    start transient and the turns bring to a tenth: the crawl watch judges ROLL only; the
    stopped-rover watch still ends a SCROLL that does not move."""
    scrolling = SafetyMonitor(SafetyConfig())
    base = HEALTHY
    for k in range(round(30.0 * 50.0)):
        t = 100.0 + k / 50.0
        s = dataclasses.replace(
            base, now_s=t, last_heartbeat_s=t, pose_rx_s=t, vehicle_time_s=t,
            commanded_speed_mps=0.6, measured_speed_mps=0.06, crawl_watch=False,
        )  # fmt: skip
        assert scrolling.check(s) is None, t
    rolling = SafetyMonitor(SafetyConfig())
    _, fault = drive(rolling, 30.0, 0.6, lambda t: 0.06)  # the same crawl, rolling
    assert fault is not None and "stall.crawl_fraction" in fault.detail


def test_the_crews_causes_are_one_set_each() -> None:
    """A hand-over (the pilot, or the next flight, drives) and a stop (pause, signal) are the
    operator's, never a fault; the next flight's are hand-overs; none is in two kinds."""
    assert {FaultCause.ITEM_SET, FaultCause.HANDOVER} == NEXT_FLIGHT_CAUSES
    assert {FaultCause.RELEASED, *NEXT_FLIGHT_CAUSES} == HANDED_CAUSES
    assert {FaultCause.PAUSED, FaultCause.SIGNAL} == STOP_CAUSES
    assert HANDED_CAUSES | STOP_CAUSES | {FaultCause.PILOT_TAKEOVER} == OPERATOR_CAUSES
    assert not HANDED_CAUSES & STOP_CAUSES
