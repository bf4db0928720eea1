"""Safety and getting to the start line (``safety``, ``startup``)."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import AfterValidator, Field

from helixd.config.fields import ConfigSection, RcChannel, distinct_channels, sane_polygon


class StallConfig(ConfigSection):
    commanded_speed_min_mps: float = Field(0.2, gt=0.0, le=3.0)
    """the stall watch is armed while the commanded speed exceeds this (m/s)"""
    measured_speed_max_mps: float = Field(0.05, ge=0.0, le=1.0)
    """a stall: the measured speed stays below this for duration_s while the watch is armed
    (m/s)"""
    commanded_yaw_rate_min_radps: float = Field(0.3, gt=0.0, le=5.0)
    """the turn-stall watch is armed while the commanded yaw rate exceeds this (rad/s)"""
    measured_yaw_rate_max_radps: float = Field(0.03, ge=0.0, le=1.0)
    """a turn stall: the measured yaw rate stays below this for duration_s while that watch is
    armed (rad/s)"""
    duration_s: float = Field(4.0, gt=0.0, le=120.0)
    """how long a stall lasts before it is a fault (s)"""
    crawl_fraction: float = Field(0.1, ge=0.0, lt=1.0)
    """moving, but under this fraction of the commanded speed over the last duration_s (commanded
    above commanded_speed_min_mps) is a stall too: rolling in water delivers about 0.05 (fraction;
    0: off)"""


class TakeoverConfig(ConfigSection):
    on_mode_change: bool = Field(True)
    """a mode change we did not ask for is takeover"""
    switch_channel: int | None = Field(None, ge=1, le=18)
    """RC channel of a takeover switch (None = no switch)"""
    switch_threshold_us: int = Field(1700, ge=800, le=2200)
    """switch PWM at or above this means takeover (µs)"""
    stick_channels: Annotated[tuple[RcChannel, ...], AfterValidator(distinct_channels)] = Field(
        (), max_length=18
    )
    """RC input channels watched for stick deflection (1..18)"""
    stick_deflection_us: int = Field(150, ge=20, le=600)
    """|PWM − 1500| beyond this on a watched stick (µs)"""


# ArduPilot's slowest GPS fix period (GPS_RATE_MS, 50..200 ms): GPS_RAW_INT's time_usec moves
# at least this often while the receiver sends
GPS_FIX_PERIOD_MAX_S = 0.2

GEOFENCE_RADIUS_MAX_M = 10_000.0  # the largest geofence radius, the config's or a mission's


class SafetyConfig(ConfigSection):
    heartbeat_timeout_s: float = Field(2.0, gt=0.1, le=30.0)
    """autopilot HEARTBEAT silence that is link loss (s)"""
    pose_stale_s: float = Field(0.5, gt=0.05, le=10.0)
    """pose age that is stale (s)"""
    ekf_variance_max: float = Field(0.8, gt=0.0, le=10.0)
    """EKF variance above this is unhealthy (FS_EKF_THRESH)"""
    gps_min_fix_type: int = Field(3, ge=2, le=6)
    """lowest GPS_RAW_INT fix_type to drive on (GPS_FIX_TYPE: 3 = 3D, ArduPilot's own arming
    minimum; 5 = RTK float, 6 = RTK fixed for precision work)"""
    gps_min_satellites: int = Field(6, ge=4, le=40)
    """fewest satellites to drive on (6: what ArduPilot's EKF3 asks before it uses a GPS,
    EK3_GPS_CHECK's 'numsats' test)"""
    gps_stale_s: float = Field(0.6, gt=0.05, le=10.0)
    """GPS_RAW_INT silence, or the same fix repeated (time_usec not moving: the receiver stopped),
    this long is a lost GPS (s); more than one GPS_RAW_INT period plus ArduPilot's slowest fix
    period (0.2 s). A frozen fix is seen up to one GPS_RAW_INT period late, so at 5 Hz this stops
    the scrolls within 0.85 s"""
    takeover: TakeoverConfig = Field(default_factory=TakeoverConfig)
    autopilot_failsafe_window_s: float = Field(2.0, gt=0.0, le=10.0)
    """a mode change is ArduPilot's failsafe when its text ("Battery 1 is low …", "Radio Failsafe",
    …) arrived at most this long before the change was seen (s); ArduPilot sends it in the same
    loop as the mode change"""
    stop_on_rc_loss: bool = Field(True)
    """stop when SYS_STATUS says the pilot's RC receiver is unhealthy (ArduPilot's own RC failsafe
    cannot fire while overrides are streamed)"""
    geofence_radius_m: float | None = Field(100.0, gt=0.0, le=GEOFENCE_RADIUS_MAX_M)
    """max distance from the start point (m); None = off"""
    geofence_polygon_ne_m: Annotated[
        tuple[tuple[float, float], ...], AfterValidator(sane_polygon)
    ] = Field((), max_length=1000)
    """optional keep-in polygon, (north_m, east_m) vertices from the EKF origin; >= 3 finite
    vertices, not self-intersecting, area >= 1 m²"""
    mission_time_limit_s: float = Field(1800.0, gt=0.0, le=86_400.0)
    """mission aborted after driving this long (s); time held for the crew (paused in HOLD, at the
    autopilot's place, at a NAV_LOITER_UNLIM) is not counted"""
    stall: StallConfig = Field(default_factory=StallConfig)
    fallback_deadline_s: float = Field(0.5, gt=0.0, le=5.0)
    """neutral+release+HOLD must be sent within (s)"""
    hold_retry_bound_s: float = Field(3.0, gt=0.0, le=30.0)
    """keep asking for HOLD until acked or this long (s)"""
    disarm_on_fault: bool = Field(False)
    """also disarm after a fault's or a pilot takeover's fall-back to HOLD (after a completed
    mission or a stop signal helixd always disarms what it armed)"""
    servo_guard: Literal["required", "warn"] = Field("required")
    """servo backend without helixd-guard running on the autopilot (missing, disabled, another
    version, a scroll output not guarded, or a HEARTBEAT too slow for it): refuse to arm (required,
    exit 3) or only warn; a killed helixd otherwise leaves DO_SET_SERVO outputs driving"""
    # Hostile-telemetry bounds: a LOCAL_POSITION_NED / ATTITUDE value beyond these (or not
    # finite) is rejected at the vehicle-state edge and never becomes the pose.
    telemetry_position_max_m: float = Field(50_000.0, gt=0.0, le=1_000_000.0)
    """|north|, |east| from the EKF origin above this is absurd (m)"""
    telemetry_speed_max_mps: float = Field(20.0, gt=0.0, le=1000.0)
    """|vn|, |ve|, |vd| above this is absurd (m/s)"""
    telemetry_yaw_max_rad: float = Field(4.0 * math.pi, ge=math.pi, le=100.0)
    """|ATTITUDE yaw| above this is absurd (rad; ArduPilot sends ±π)"""


class StartupConfig(ConfigSection):
    """Getting to the start line: the autopilot's first HEARTBEAT, its home, the pilot's start
    switch, and arming (normally, with every PreArm check; force only when configured)."""

    force_arm: bool = Field(False)
    """the explicit exception: force-arm (21196, skips every PreArm check) when a normal arm is
    refused; logged as WARNING arm_forced with the PreArm text it overrides"""
    arm_timeout_s: float = Field(30.0, gt=0.0, le=600.0)
    """keep asking to arm while PreArm checks refuse, at most this long (s)"""
    arm_retry_interval_s: float = Field(2.0, gt=0.0, le=60.0)
    """pause between arming attempts (s)"""
    home_timeout_s: float = Field(30.0, gt=0.0, le=600.0)
    """before arming, wait at most this long for the autopilot's home (HOME_POSITION): ArduPilot
    refuses to arm without one ('PreArm: AHRS: waiting for home') (s)"""
    start_switch_channel: int | None = Field(None, ge=1, le=18)
    """RC channel the pilot flips to start (None = start at once)"""
    start_switch_threshold_us: int = Field(1700, ge=800, le=2200)
    """start switch PWM at or above this starts (µs)"""
    start_gate_timeout_s: float = Field(600.0, gt=0.0, le=86_400.0)
    """give up waiting for the start switch (s)"""
    connect_timeout_s: float = Field(30.0, gt=0.0, le=600.0)
    """wait for the autopilot's first HEARTBEAT (s)"""
