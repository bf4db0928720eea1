"""helixd configuration (``config/helixd.yaml``), validated by pydantic.

Every tunable lives here with its unit (in the name or the description), its bounds and a
default taken from the Helix-25 thesis (docs/physics.md). Unknown keys are errors. Loading a bad
file raises :class:`ConfigFileError` carrying one message per problem, each naming the file,
the dotted field path, the bad value and what is allowed (the machinery: helixd.files.models).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import (
    AfterValidator,
    BaseModel,
    Field,
    model_validator,
)

from helixd.base.polygon import polygon_problems
from helixd.files.models import ConfigFileError, InputModel, load_yaml_model
from helixd.mav.signing_key import SigningKeyError, parse_signing_key
from helixd.mav.url import LinkError, parse_link_url

# ---------------------------------------------------------------------------------------------
# Vehicle


class ScrollCalibration(InputModel):
    """Per-scroll fraction calibration, the mecanum report's v = a·ω + b idea.

    applied = gain·f + sign(f)·offset for |f| ≥ deadband, 0 below it; negated when reversed.
    """

    gain: float = Field(1.0, ge=0.5, le=2.0, description="slope a (dimensionless)")
    offset: float = Field(
        0.0, ge=0.0, le=0.3, description="fraction of max RPM added in the direction of motion"
    )
    deadband: float = Field(
        0.0, ge=0.0, le=0.3, description="commands with |fraction| below this are sent as 0"
    )
    reversed: bool = Field(False, description="scroll motor wired backwards")


class VehicleConfig(InputModel):
    scroll_radius_m: float = Field(0.175, gt=0.01, le=1.0, description="scroll radius r (m)")
    lx_m: float = Field(0.565, gt=0.05, le=3.0, description="front-back scroll distance l_x (m)")
    ly_m: float = Field(0.508, gt=0.05, le=3.0, description="left-right scroll distance l_y (m)")
    max_rpm: float = Field(195.0, gt=1.0, le=2000.0, description="scroll no-load max speed (RPM)")
    output_clamp: float = Field(
        0.9, gt=0.0, le=1.0, description="max |scroll command| as a fraction of max_rpm"
    )
    scrolls: tuple[ScrollCalibration, ScrollCalibration, ScrollCalibration, ScrollCalibration] = (
        Field(
            default_factory=lambda: (
                ScrollCalibration(),
                ScrollCalibration(),
                ScrollCalibration(),
                ScrollCalibration(),
            ),
            description="calibration of scrolls 1..4 (thesis Fig. 2 numbering)",
        )
    )


# ---------------------------------------------------------------------------------------------
# Control


class PidGains(InputModel):
    kp: float = Field(ge=0.0, le=100.0, description="proportional gain")
    ki: float = Field(ge=0.0, le=100.0, description="integral gain (1/s)")
    kd: float = Field(ge=0.0, le=100.0, description="derivative gain (s)")
    integral_limit: float = Field(
        description="anti-windup clamp on |ki·∫e dt| (output units)", ge=0.0, le=100.0
    )


GROUND_FRACTION_FIELDS = ("ground_roll_fraction", "ground_scroll_fraction", "ground_yaw_fraction")


class SlipConfig(InputModel):
    """Online slip estimate and its feed-forward (:mod:`helixd.control.slip`).

    Per motion mode, the fraction of the commanded (no-slip) translation and yaw rate the
    ground delivers is learnt from the pose telemetry; the navigator's command is divided by it
    so tracking holds on grass, mud and sand without retuning. The estimate is computed and
    logged (``slip_v_frac``, ``slip_w_frac`` in flight.csv) whether or not it is fed forward.

    ``ground_*_fraction`` declare the ground the operator expects (1 = no slip, the thesis's
    eq. 1): the estimate starts from it instead of from no slip, and the time estimate of
    ``check``, ``run`` and ``mission survey`` counts it (an axis that gets a fraction f of its
    command is delivered min(1, f · max_gain) of it with the feed-forward, f without). The
    built-in simulator's grounds: ``sim.terrains`` (hard ground: roll 0.95, scroll 0.12,
    yaw 0.85; docs/physics.md gives their sources).
    """

    enabled: bool = Field(
        True, description="feed the estimate forward (the command is divided by it)"
    )
    time_constant_s: float = Field(
        5.0,
        ge=0.5,
        le=600.0,
        description="memory of the estimate: older evidence fades with this time constant, "
        "counted in autopilot time while learning (s)",
    )
    prior_weight_s: float = Field(
        1.0,
        ge=0.01,
        le=60.0,
        description="weight of the no-slip prior (fraction 1), as seconds of evidence at the "
        "learning threshold (s)",
    )
    min_speed_mps: float = Field(
        0.15,
        gt=0.0,
        le=2.0,
        description="translation is learnt only while the commanded (no-slip) speed exceeds "
        "this (m/s); frozen below it and while turning in place",
    )
    min_yaw_rate_radps: float = Field(
        0.2,
        gt=0.0,
        le=5.0,
        description="yaw is learnt only while the commanded yaw rate exceeds this (rad/s)",
    )
    command_lag_s: float = Field(
        0.3,
        ge=0.0,
        le=5.0,
        description="scroll response lag: the command is low-passed by this before it is "
        "compared with the measured motion (s)",
    )
    max_gap_s: float = Field(
        0.5,
        gt=0.0,
        le=5.0,
        description="poses farther apart than this (autopilot time) teach nothing (s)",
    )
    steady_tolerance: float = Field(
        0.2,
        gt=0.0,
        le=1.0,
        description="a channel teaches only while its command is steady: the command differs "
        "from its lagged value by at most this fraction of it (1)",
    )
    max_gain: float = Field(
        2.0,
        ge=1.0,
        le=5.0,
        description="the feed-forward never amplifies a command by more than this factor (1)",
    )
    stuck_fraction: float = Field(
        0.15,
        gt=0.0,
        lt=1.0,
        description="a delivered fraction below this is a stall, not slip: no amplification, "
        "the stall watchdog judges it (1)",
    )
    max_fraction: float = Field(
        1.2,
        ge=1.0,
        le=3.0,
        description="upper bound of the estimate (more motion than commanded: noise, slope) (1)",
    )
    skew_share: float = Field(
        0.2,
        gt=0.0,
        le=0.5,
        description="OMNI: the translation axis that delivers more is slowed to the other's "
        "fraction, so the rover moves in the direction commanded; ramped in while the other "
        "axis carries less than this share of the command (1)",
    )
    ground_roll_fraction: float = Field(
        1.0,
        gt=0.0,
        le=1.0,
        description="the ground the operator expects: fraction of the no-slip (eq. 1) velocity "
        "along the roll axis it delivers. The estimate starts from it and the time estimate "
        "counts it; 1 = no slip (1)",
    )
    ground_scroll_fraction: float = Field(
        1.0,
        gt=0.0,
        le=1.0,
        description="the same along the scroll axis (1)",
    )
    ground_yaw_fraction: float = Field(
        1.0,
        gt=0.0,
        le=1.0,
        description="the same for the yaw rate (1)",
    )

    @model_validator(mode="after")
    def _ground_is_not_a_stall(self) -> SlipConfig:
        for name in GROUND_FRACTION_FIELDS:
            value = getattr(self, name)
            if value < self.stuck_fraction:
                raise ValueError(
                    f"{name} = {value:g} is below stuck_fraction = {self.stuck_fraction:g}: a "
                    "ground that delivers that little is a stall, and the stall watchdog would "
                    f"stop the run (allowed range {self.stuck_fraction:g} .. 1)"
                )
        return self


class ControlConfig(InputModel):
    distance_pid: PidGains = Field(
        default_factory=lambda: PidGains(kp=1.2, ki=0.0002, kd=0.05, integral_limit=0.2),
        description="distance error (m) → forward speed (m/s); thesis field-test gains",
    )
    yaw_pid: PidGains = Field(
        default_factory=lambda: PidGains(kp=8.0, ki=0.0, kd=0.05, integral_limit=0.3),
        description="heading error (rad) → yaw rate (rad/s); thesis gains",
    )
    heading_threshold_rad: float = Field(
        0.2, gt=0.0, le=1.5, description="turn in place while |heading error| exceeds this (rad)"
    )
    waypoint_tolerance_m: float = Field(
        1.0, gt=0.05, le=20.0, description="waypoint reached inside this radius (m)"
    )
    max_speed_mps: float = Field(0.6, gt=0.0, le=3.0, description="translation speed cap (m/s)")
    max_yaw_rate_radps: float = Field(1.0, gt=0.0, le=5.0, description="yaw rate cap (rad/s)")
    slowdown_radius_m: float = Field(
        2.0, ge=0.0, le=50.0, description="speed ramps down linearly inside this radius (m)"
    )
    corner_slowdown_rad: float = Field(
        0.5,
        ge=0.0,
        le=math.pi,
        description="waypoints where the path turns more than this are approached with the "
        "slow-down ramp; gentler ones are flown through at speed (rad)",
    )
    min_speed_mps: float = Field(
        0.1,
        ge=0.0,
        le=1.0,
        description="speed floor while outside tolerance, avoids creeping (m/s)",
    )
    final_heading_tolerance_rad: float = Field(
        0.1, gt=0.0, le=1.0, description="final-heading turn ends inside this (rad)"
    )
    guidance: Literal["line", "thesis"] = Field(
        "line",
        description="'line': track the leg previous waypoint → waypoint (lookahead law, "
        "perpendicular-line switching, pivot/gentle corners, acceleration limits); "
        "'thesis': turn to the waypoint and drive at it (thesis eq. 3-6)",
    )
    lookahead_m: float = Field(
        1.0,
        gt=0.05,
        le=20.0,
        description="line guidance: the course aims at the leg this far ahead, "
        "course = leg − atan(cross-track / lookahead) (m)",
    )
    stop_tolerance_m: float = Field(
        0.1,
        gt=0.01,
        le=5.0,
        description="line guidance: the final waypoint, waypoints with a final heading and "
        "pivot corners are reached inside this radius (or by crossing the line through them "
        "perpendicular to the leg) (m)",
    )
    pivot_angle_rad: float = Field(
        0.785,
        ge=0.0,
        le=math.pi,
        description="line guidance: corners turning more than this are stopped at and pivoted "
        "in place (ROLL/SCROLL; OMNI stops), and TRACK re-aligns in place beyond this heading "
        "error (like ArduPilot WP_PIVOT_ANGLE) (rad)",
    )
    corner_error_m: float = Field(
        0.25,
        ge=0.0,
        le=2.0,
        description="line guidance: a corner that is not a stop is flown as an arc tangent to "
        "both legs passing at most this far from the waypoint (never farther than the "
        "waypoint's tolerance), at the speed the radius and max_lateral_accel_mps2 allow; a "
        "corner whose arc would be slower than min_speed_mps is a pivot stop. 0: no arcs, "
        "corners sharper than pivot_angle_rad are pivots (the behaviour before arcs). "
        "Default 0.25 m, the value measured against AUTO (the time estimate follows the "
        "arcs): a 90° survey turn gets R = 0.60 m at 0.43 m/s instead of a "
        "stop and a pivot (≈ 0.8 s lost instead of ≈ 8 s); the arc passes 0.18 m from the "
        "legs, under half of ArduPilot AUTO's 0.45 m largest cross-track on SITL; "
        "0.15–0.2 m would not beat AUTO's time (m)",
    )
    max_accel_mps2: float = Field(
        0.3,
        gt=0.0,
        le=5.0,
        description="line guidance: translation command changes at most this fast, and the "
        "rover brakes for waypoints with it (m/s²)",
    )
    max_lateral_accel_mps2: float = Field(
        0.3,
        gt=0.0,
        le=5.0,
        description="line guidance: gentle corners are flown at most at sqrt(a_lat · R), "
        "R = lookahead / tan(turn / 2) (m/s²)",
    )
    max_yaw_accel_radps2: float = Field(
        2.0,
        gt=0.0,
        le=50.0,
        description="line guidance: yaw-rate command changes at most this fast, and turns "
        "brake with it (rad/s²)",
    )
    braking_accel_mps2: float = Field(
        0.15,
        gt=0.0,
        le=5.0,
        description="line guidance: the speed profile plans to slow down for stops and corners "
        "at this deceleration, at most max_accel_mps2, so a plant whose speed lags the "
        "command still arrives slowly (m/s²)",
    )

    @model_validator(mode="after")
    def _braking_within_accel(self) -> ControlConfig:
        if self.braking_accel_mps2 > self.max_accel_mps2:
            raise ValueError(
                f"control.braking_accel_mps2 = {self.braking_accel_mps2} exceeds "
                f"control.max_accel_mps2 = {self.max_accel_mps2}: the commands could not "
                "follow the planned braking"
            )
        return self

    max_dt_s: float = Field(
        0.5, gt=0.0, le=5.0, description="larger control steps are treated as a restart (s)"
    )
    control_rate_max_hz: float = Field(
        50.0, ge=1.0, le=200.0, description="ceiling on control steps per second (Hz)"
    )
    slip: SlipConfig = Field(
        default_factory=SlipConfig,
        description="online slip estimate (delivered fraction of the command) and feed-forward",
    )


# ---------------------------------------------------------------------------------------------
# Missions


class MissionLimits(InputModel):
    max_range_m: float = Field(
        500.0,
        gt=0.0,
        le=10_000.0,
        description="waypoints farther than this from origin refused (m)",
    )
    max_start_distance_m: float = Field(
        100.0,
        gt=0.0,
        le=10_000.0,
        description="first waypoint farther than this from the rover is refused at preflight (m)",
    )
    ground_station_mode: Literal["roll", "scroll", "omni"] | None = Field(
        None,
        description="motion mode for .plan/.waypoints missions (they carry none); None = the "
        "--mode option is required",
    )


# ---------------------------------------------------------------------------------------------
# Media: the mode follows the medium

ModeName = Literal["roll", "scroll", "omni"]


class MediaModesConfig(InputModel):
    """The motion mode each medium is flown in (docs/physics.md, the ground table): ROLL
    where rolling delivers most (hard 0.95, grass 0.9, sand 0.6 of v_x against 0.12, 0.25,
    0.12 scrolling), SCROLL where rolling delivers little and scrolling more (mud 0.3 vs 0.85,
    water 0.05 vs 0.62)."""

    hard: ModeName = Field("roll", description="mode on hard ground (roll 0.95, scroll 0.12)")
    grass: ModeName = Field("roll", description="mode on grass (roll 0.9, scroll 0.25)")
    sand: ModeName = Field("roll", description="mode in sand (roll 0.6, scroll 0.12)")
    mud: ModeName = Field("scroll", description="mode in mud (roll 0.3, scroll 0.85)")
    water: ModeName = Field("scroll", description="mode in water (roll 0.05, scroll 0.62)")


class MediaConfig(InputModel):
    """A media map and the mode that follows the medium (helixd.planning.media_modes)."""

    media_map: Path | None = Field(
        None,
        description="media map (GeoJSON/KML, helixd.files.media) of where the rover goes; a "
        "mission's own media_map replaces it. None: the mission's one mode everywhere",
    )
    modes: MediaModesConfig | Literal["learned"] = Field(
        default_factory=MediaModesConfig,
        description="the mode per medium; 'learned': per medium the mode the ground profile "
        "finds fastest (ground.objective), the defaults where it knows too little",
    )
    transition_margin_m: float = Field(
        1.0,
        ge=0.0,
        le=10.0,
        description="where the mode changes at a boundary, the rover stops and turns in place "
        "this far on the firm side of it (the ROLL medium's), so all four scrolls bear on "
        "ground while it turns (m; the Helix-25 is about 1 m long)",
    )
    min_stretch_m: float = Field(
        5.0,
        ge=0.5,
        le=100.0,
        description="a stretch shorter than this is flown in its neighbours' mode (never "
        "ROLL): two stops and turns in place cost more than rolling a few metres saves (m)",
    )
    detect: bool = Field(
        True,
        description="notice ground the map does not show from the slip estimate and switch "
        "to the mode that works there (helixd.control.ground_check)",
    )
    detect_window_m: float = Field(
        1.5,
        gt=0.0,
        le=2.0,
        description="distance commanded over which the delivered fraction is judged (m)",
    )
    detect_roll_fraction: float = Field(
        0.6,
        gt=0.0,
        lt=1.0,
        description="in ROLL, delivered below this fraction of the commanded speed over the "
        "window: the ground is softer than the map says (hard 0.95, grass 0.9, mud 0.3)",
    )
    detect_scroll_fraction: float = Field(
        0.55,
        gt=0.0,
        lt=1.0,
        description="scrolling because of the check, delivered below this fraction over the "
        "window: firm ground again, back to the planned mode (hard 0.12, mud 0.85)",
    )
    detect_hysteresis: float = Field(
        0.05,
        ge=0.0,
        le=0.3,
        description='"firm again" needs the delivered fraction this far below '
        "detect_scroll_fraction (scrolling in water delivers about 0.6: no flip back in the "
        "water) (fraction)",
    )
    detect_min_change_m: float = Field(
        5.0,
        ge=0.0,
        le=50.0,
        description="after the ground check changed the mode, the rover travels at least this "
        "far before it changes it again; where the media map has water or mud here or this "
        "far ahead it never goes back to roll (m)",
    )


# ---------------------------------------------------------------------------------------------
# Link


def _valid_link_url(url: str) -> str:
    try:
        parse_link_url(url, 115200)  # form only; the baud is checked with link.baud at open
    except LinkError as exc:
        raise ValueError(str(exc)) from None
    return url


class LinkConfig(InputModel):
    url: Annotated[str, AfterValidator(_valid_link_url)] = Field(
        "udpin:0.0.0.0:14550",
        min_length=1,
        description="MAVProxy-style connection: /dev/ttyACM0[:baud], udpin:, udpout:, tcp:",
    )
    baud: int = Field(115200, ge=1200, le=3_000_000, description="serial baud when url has none")
    source_system: int = Field(
        247,
        ge=1,
        le=255,
        description="our MAVLink sysid; the autopilot's MAV_GCS_SYSID must equal it. 247, not "
        "255 (QGC/Mission Planner/MAVProxy), 245 (MAVSDK ground station) or 1 (vehicles, "
        "MAVROS): a ground station sharing our id would hide a dead helixd from the GCS "
        "failsafe and fight its overrides",
    )
    observer_system: int = Field(
        248,
        ge=1,
        le=255,
        description="the sysid of every command that does not fly (status, mission "
        "upload/download, the download before `run --mission autopilot`): never the GCS id "
        "(source_system), and they send no HEARTBEAT, RC override or MANUAL_CONTROL, so the "
        "autopilot never takes them for its GCS and its GCS failsafe never sees them",
    )
    source_component: int = Field(191, ge=1, le=255, description="our compid (191 = onboard)")
    event_loop: Literal["asyncio", "uvloop"] = Field(
        "asyncio",
        description="the daemon's event loop: 'asyncio' (the standard loop) or 'uvloop' (pip "
        "install 'helixd[fast]'; falls back to the standard loop, with a warning, when it is "
        "not installed). Default asyncio: on the whole daemon uvloop measured within noise of "
        "it (tools/bench_control_loop.py runs both; helixd/runtime/eventloop.py)",
    )
    target_system: int = Field(1, ge=1, le=255, description="autopilot sysid")
    target_component: int = Field(1, ge=0, le=255, description="autopilot compid")
    heartbeat_rate_hz: float = Field(
        5.0,
        ge=0.2,
        le=10.0,
        description="our HEARTBEAT rate (Hz); helixd-guard stops the rover after HXG_TIMEOUT "
        "(0.5 s) without one, so keep it >= 2.5 / HXG_TIMEOUT: one lost HEARTBEAT then does "
        "not trip the guard (preflight checks it)",
    )
    pose_rate_hz: float = Field(
        50.0, ge=1.0, le=100.0, description="LOCAL_POSITION_NED/ATTITUDE rate to ask for (Hz)"
    )
    telemetry_rate_hz: float = Field(
        5.0, ge=0.5, le=50.0, description="EKF/SYS_STATUS/RC/SERVO/MISSION_CURRENT stream rate (Hz)"
    )
    payload_rate_hz: float = Field(
        5.0,
        ge=0.0,
        le=50.0,
        description="DISTANCE_SENSOR, RANGEFINDER and WATER_DEPTH (the payload's readings, "
        "payload.csv) asked for at this rate, once each, never counted as slow (an autopilot "
        "without the sensor sends none); 0: not asked (Hz)",
    )
    autopilot_heartbeat_rate_hz: float = Field(
        5.0,
        ge=1.0,
        le=10.0,
        description="the autopilot's HEARTBEAT rate to ask for on helixd's link (Hz; ArduPilot "
        "sends 1 Hz unless asked, and one at once on a mode change): the arm and the mode "
        "are in it, so an arm or a disarm is seen within 1 / this rate, not within a second",
    )
    command_timeout_s: float = Field(
        1.0, gt=0.0, le=30.0, description="wait for COMMAND_ACK/PARAM_VALUE per try (s)"
    )
    command_retries: int = Field(3, ge=0, le=10, description="re-sends after the first try")
    reconnect_interval_s: float = Field(
        1.0, gt=0.0, le=60.0, description="pause between reopen attempts of a lost link (s)"
    )
    signing_key_file: Path | None = Field(
        None, description="MAVLink2 signing key (32 bytes raw or 64 hex chars); None = unsigned"
    )
    heartbeat_liveness_s: float = Field(
        1.5,
        gt=0.0,
        le=30.0,
        description="our HEARTBEAT stops when feed() was not called for this long (s)",
    )
    heartbeat_type: Literal["gcs", "onboard_controller"] = Field(
        "gcs", description="MAV_TYPE of our HEARTBEAT (ArduPilot's GCS failsafe keys on sysid)"
    )
    vehicle_component: bool = Field(
        True,
        description="also a component (source_component) of the autopilot's system "
        "(target_system): a second HEARTBEAT (MAV_TYPE_ONBOARD_CONTROLLER) from those ids makes "
        "ArduPilot route the commands a ground station addresses to that component of the "
        "vehicle (QGroundControl's MAVLink Actions) to helixd, answered from those ids",
    )
    pose_rate_min_hz: float = Field(
        5.0, ge=0.5, le=100.0, description="stop stepping the pose rate down below this (Hz)"
    )
    stream_step_factor: float = Field(
        1.25, gt=1.0, le=4.0, description="interval multiplier after a DENIED message interval"
    )
    stream_check_window_s: float = Field(
        2.0, ge=0.2, le=60.0, description="observed stream rates are checked once per window (s)"
    )
    stream_slow_fraction: float = Field(
        0.5,
        gt=0.0,
        lt=1.0,
        description="a stream observed below this fraction of its granted rate is re-requested",
    )
    reboot_backstep_s: float = Field(
        1.0,
        gt=0.0,
        le=60.0,
        description="autopilot time_boot_ms going back by more than this is a reboot (s)",
    )
    statustext_history: int = Field(
        50, ge=1, le=1000, description="STATUSTEXT messages kept in the vehicle state"
    )
    statustext_grace_s: float = Field(
        0.3,
        ge=0.0,
        le=5.0,
        description="after an ARM refusal, wait this long for its 'PreArm:' STATUSTEXT (s)",
    )
    tcp_connect_timeout_s: float = Field(
        5.0, gt=0.0, le=60.0, description="give up a tcp: connection attempt after (s)"
    )
    command_settle_s: float = Field(
        0.02,
        ge=0.0,
        le=1.0,
        description="quiet gap before re-using a command id; a duplicated ack in it is dropped (s)",
    )
    statustext_timeout_s: float = Field(
        2.0,
        ge=0.1,
        le=30.0,
        description="a chunked STATUSTEXT whose last chunk has not come after this long is "
        "logged as it is, marked incomplete (s); ArduPilot prunes its queue after 5 s",
    )
    own_id_watch_s: float = Field(
        2.2,
        ge=0.0,
        le=30.0,
        description="preflight listens this long after our first message for another sender "
        "on our system id (s); ground stations send HEARTBEAT at 1 Hz",
    )
    mission_item_timeout_s: float = Field(
        1.5,
        gt=0.0,
        le=30.0,
        description="mission upload/download: re-send after this long without progress (s); "
        "above ArduPilot's own 1 s re-request",
    )
    mission_retries: int = Field(
        5, ge=0, le=50, description="mission upload/download: re-sends in a row before failing"
    )
    tlog_enabled: bool = Field(True, description="write the link's .tlog in the run directory")
    tlog_max_bytes: int = Field(
        512 * 1024 * 1024,
        ge=1024 * 1024,
        le=64 * 1024**3,
        description="stop writing the .tlog when it reaches this size (bytes)",
    )

    @model_validator(mode="after")
    def _not_the_autopilot(self) -> LinkConfig:
        if self.source_system == self.target_system:
            raise ValueError(
                f"link.source_system = {self.source_system} is the autopilot's system id "
                "(link.target_system): helixd needs an id of its own (default 247)"
            )
        if self.observer_system in (self.source_system, self.target_system):
            raise ValueError(
                f"link.observer_system = {self.observer_system} is also "
                + (
                    "link.source_system, the GCS id"
                    if self.observer_system == self.source_system
                    else "the autopilot's system id (link.target_system)"
                )
                + ": the commands that do not fly need an id of their own (default 248)"
            )
        return self


# ---------------------------------------------------------------------------------------------
# Actuation


class ActuationBackend(StrEnum):
    RC_OVERRIDE = "rc_override"
    SERVO = "servo"
    DRY_RUN = "dry_run"


class ChannelConfig(InputModel):
    channel: int = Field(ge=1, le=18, description="RC/servo channel number (1..18)")
    pwm_min_us: int = Field(1000, ge=800, le=2200, description="PWM at full reverse (µs)")
    pwm_trim_us: int = Field(1500, ge=800, le=2200, description="PWM at neutral (µs)")
    pwm_max_us: int = Field(2000, ge=800, le=2200, description="PWM at full forward (µs)")
    reversed: bool = Field(False, description="swap min and max on this channel")
    deadband_us: int = Field(0, ge=0, le=200, description="|PWM − trim| below this sent as trim")

    @model_validator(mode="after")
    def _ordered(self) -> ChannelConfig:
        if not self.pwm_min_us < self.pwm_trim_us < self.pwm_max_us:
            raise ValueError(
                f"need pwm_min_us < pwm_trim_us < pwm_max_us, got "
                f"{self.pwm_min_us} / {self.pwm_trim_us} / {self.pwm_max_us}"
            )
        return self


def _default_channels() -> tuple[ChannelConfig, ChannelConfig, ChannelConfig, ChannelConfig]:
    return (
        ChannelConfig(channel=1),
        ChannelConfig(channel=2),
        ChannelConfig(channel=3),
        ChannelConfig(channel=4),
    )


class ActuationConfig(InputModel):
    backend: ActuationBackend = Field(ActuationBackend.RC_OVERRIDE, description="command sink")
    channels: tuple[ChannelConfig, ChannelConfig, ChannelConfig, ChannelConfig] = Field(
        default_factory=_default_channels, description="scrolls 1..4 → channel and PWM range"
    )
    repeat_rate_hz: float = Field(
        20.0, ge=10.0, le=100.0, description="RC override re-send rate while healthy (Hz)"
    )
    release_repeats: int = Field(
        3, ge=1, le=20, description="times the release message is sent (UDP may drop one)"
    )
    release_spacing_s: float = Field(
        0.02, ge=0.0, le=0.1, description="pause between the repeated release messages (s)"
    )
    neutral_hold_s: float = Field(
        0.05,
        ge=0.0,
        le=0.2,
        description="stop(): neutral is held this long before overrides are released (s)",
    )
    stop_timeout_s: float = Field(
        0.4,
        gt=0.0,
        le=5.0,
        description="stop() gives up (and logs) after this long; keep < safety.fallback_deadline_s",
    )
    servo_refresh_s: float = Field(
        1.0,
        ge=0.1,
        le=10.0,
        description="servo backend: each channel's DO_SET_SERVO is sent again after this long "
        "even when unchanged (s); an ACK is no proof: a value sent while helixd-guard holds the "
        "output is accepted and dropped",
    )

    @model_validator(mode="after")
    def _distinct(self) -> ActuationConfig:
        numbers = [c.channel for c in self.channels]
        if len(set(numbers)) != len(numbers):
            raise ValueError(f"each scroll needs its own channel, got {numbers}")
        return self


# ---------------------------------------------------------------------------------------------
# Safety


class StallConfig(InputModel):
    commanded_speed_min_mps: float = Field(
        0.2, gt=0.0, le=3.0, description="stall watch armed when commanded speed exceeds (m/s)"
    )
    measured_speed_max_mps: float = Field(
        0.05, ge=0.0, le=1.0, description="...while measured speed stays below (m/s)"
    )
    commanded_yaw_rate_min_radps: float = Field(
        0.3, gt=0.0, le=5.0, description="turn-stall watch armed above this commanded rate (rad/s)"
    )
    measured_yaw_rate_max_radps: float = Field(
        0.03, ge=0.0, le=1.0, description="...while the measured yaw rate stays below (rad/s)"
    )
    duration_s: float = Field(4.0, gt=0.0, le=120.0, description="...for this long (s)")
    crawl_fraction: float = Field(
        0.1,
        ge=0.0,
        lt=1.0,
        description="moving, but under this fraction of the commanded speed over the last "
        "duration_s (commanded above commanded_speed_min_mps) is a stall too: rolling in "
        "water delivers about 0.05 (fraction; 0: off)",
    )


RcChannel = Annotated[int, Field(ge=1, le=18)]


def _distinct_channels(channels: tuple[int, ...]) -> tuple[int, ...]:
    if len(set(channels)) != len(channels):
        raise ValueError(f"each channel may be listed once, got {list(channels)}")
    return channels


def _sane_polygon(poly: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
    if not poly:
        return poly
    problems = polygon_problems(poly)
    if problems:
        raise ValueError(
            "\n".join(
                f"{p} (allowed: [] for no polygon, or >= 3 vertices enclosing an area)"
                for p in problems
            )
        )
    return poly


class TakeoverConfig(InputModel):
    on_mode_change: bool = Field(True, description="a mode change we did not ask for is takeover")
    switch_channel: int | None = Field(
        None, ge=1, le=18, description="RC channel of a takeover switch (None = no switch)"
    )
    switch_threshold_us: int = Field(
        1700, ge=800, le=2200, description="switch PWM at or above this means takeover (µs)"
    )
    stick_channels: Annotated[tuple[RcChannel, ...], AfterValidator(_distinct_channels)] = Field(
        (), max_length=18, description="RC input channels watched for stick deflection (1..18)"
    )
    stick_deflection_us: int = Field(
        150, ge=20, le=600, description="|PWM − 1500| beyond this on a watched stick (µs)"
    )


# ArduPilot's slowest GPS fix period (GPS_RATE_MS, 50..200 ms): GPS_RAW_INT's time_usec moves
# at least this often while the receiver sends
GPS_FIX_PERIOD_MAX_S = 0.2

GEOFENCE_RADIUS_MAX_M = 10_000.0  # the largest geofence radius, the config's or a mission's


class SafetyConfig(InputModel):
    heartbeat_timeout_s: float = Field(
        2.0, gt=0.1, le=30.0, description="autopilot HEARTBEAT silence that is link loss (s)"
    )
    pose_stale_s: float = Field(0.5, gt=0.05, le=10.0, description="pose age that is stale (s)")
    ekf_variance_max: float = Field(
        0.8, gt=0.0, le=10.0, description="EKF variance above this is unhealthy (FS_EKF_THRESH)"
    )
    gps_min_fix_type: int = Field(
        3,
        ge=2,
        le=6,
        description="lowest GPS_RAW_INT fix_type to drive on (GPS_FIX_TYPE: 3 = 3D, ArduPilot's "
        "own arming minimum; 5 = RTK float, 6 = RTK fixed for precision work)",
    )
    gps_min_satellites: int = Field(
        6,
        ge=4,
        le=40,
        description="fewest satellites to drive on (6: what ArduPilot's EKF3 asks before it "
        "uses a GPS, EK3_GPS_CHECK's 'numsats' test)",
    )
    gps_stale_s: float = Field(
        0.6,
        gt=0.05,
        le=10.0,
        description="GPS_RAW_INT silence, or the same fix repeated (time_usec not moving: the "
        "receiver stopped), this long is a lost GPS (s); more than one GPS_RAW_INT period "
        "plus ArduPilot's slowest fix period (0.2 s). A frozen fix is seen up to one "
        "GPS_RAW_INT period late, so at 5 Hz this stops the scrolls within 0.85 s",
    )
    takeover: TakeoverConfig = Field(default_factory=TakeoverConfig)
    autopilot_failsafe_window_s: float = Field(
        2.0,
        gt=0.0,
        le=10.0,
        description='a mode change is ArduPilot\'s failsafe when its text ("Battery 1 is low …", '
        '"Radio Failsafe", …) arrived at most this long before the change was seen (s); '
        "ArduPilot sends it in the same loop as the mode change",
    )
    stop_on_rc_loss: bool = Field(
        True,
        description="stop when SYS_STATUS says the pilot's RC receiver is unhealthy (ArduPilot's "
        "own RC failsafe cannot fire while overrides are streamed)",
    )
    geofence_radius_m: float | None = Field(
        100.0,
        gt=0.0,
        le=GEOFENCE_RADIUS_MAX_M,
        description="max distance from the start point (m); None = off",
    )
    geofence_polygon_ne_m: Annotated[
        tuple[tuple[float, float], ...], AfterValidator(_sane_polygon)
    ] = Field(
        (),
        max_length=1000,
        description="optional keep-in polygon, (north_m, east_m) vertices from the EKF origin; "
        ">= 3 finite vertices, not self-intersecting, area >= 1 m²",
    )
    mission_time_limit_s: float = Field(
        1800.0,
        gt=0.0,
        le=86_400.0,
        description="mission aborted after driving this long (s); time held for the crew "
        "(paused in HOLD, at the autopilot's place, at a NAV_LOITER_UNLIM) is not counted",
    )
    stall: StallConfig = Field(default_factory=StallConfig)
    fallback_deadline_s: float = Field(
        0.5, gt=0.0, le=5.0, description="neutral+release+HOLD must be sent within (s)"
    )
    hold_retry_bound_s: float = Field(
        3.0, gt=0.0, le=30.0, description="keep asking for HOLD until acked or this long (s)"
    )
    disarm_on_fault: bool = Field(
        False,
        description="also disarm after a fault's or a pilot takeover's fall-back to HOLD (after "
        "a completed mission or a stop signal helixd always disarms what it armed)",
    )
    servo_guard: Literal["required", "warn"] = Field(
        "required",
        description="servo backend without helixd-guard running on the autopilot (missing, "
        "disabled, another version, a scroll output not guarded, or a HEARTBEAT too slow for "
        "it): refuse to arm (required, exit 3) or only warn; a killed helixd otherwise leaves "
        "DO_SET_SERVO outputs driving",
    )
    # Hostile-telemetry bounds: a LOCAL_POSITION_NED / ATTITUDE value beyond these (or not
    # finite) is rejected at the vehicle-state edge and never becomes the pose.
    telemetry_position_max_m: float = Field(
        50_000.0,
        gt=0.0,
        le=1_000_000.0,
        description="|north|, |east| from the EKF origin above this is absurd (m)",
    )
    telemetry_speed_max_mps: float = Field(
        20.0, gt=0.0, le=1000.0, description="|vn|, |ve|, |vd| above this is absurd (m/s)"
    )
    telemetry_yaw_max_rad: float = Field(
        4.0 * math.pi,
        ge=math.pi,
        le=100.0,
        description="|ATTITUDE yaw| above this is absurd (rad; ArduPilot sends ±π)",
    )


class StartupConfig(InputModel):
    """Getting to the start line: the autopilot's first HEARTBEAT, its home, the pilot's start
    switch, and arming (normally, with every PreArm check; force only when configured)."""

    force_arm: bool = Field(
        False,
        description="the explicit exception: force-arm (21196, skips every PreArm check) when a "
        "normal arm is refused; logged as WARNING arm_forced with the PreArm text it overrides",
    )
    arm_timeout_s: float = Field(
        30.0,
        gt=0.0,
        le=600.0,
        description="keep asking to arm while PreArm checks refuse, at most this long (s)",
    )
    arm_retry_interval_s: float = Field(
        2.0, gt=0.0, le=60.0, description="pause between arming attempts (s)"
    )
    home_timeout_s: float = Field(
        30.0,
        gt=0.0,
        le=600.0,
        description="before arming, wait at most this long for the autopilot's home "
        "(HOME_POSITION): ArduPilot refuses to arm without one ('PreArm: AHRS: waiting for "
        "home') (s)",
    )
    start_switch_channel: int | None = Field(
        None, ge=1, le=18, description="RC channel the pilot flips to start (None = start at once)"
    )
    start_switch_threshold_us: int = Field(
        1700, ge=800, le=2200, description="start switch PWM at or above this starts (µs)"
    )
    start_gate_timeout_s: float = Field(
        600.0, gt=0.0, le=86_400.0, description="give up waiting for the start switch (s)"
    )
    connect_timeout_s: float = Field(
        30.0, gt=0.0, le=600.0, description="wait for the autopilot's first HEARTBEAT (s)"
    )


# ---------------------------------------------------------------------------------------------
# Recorder


class RecorderConfig(InputModel):
    run_root: Path = Field(Path("runs"), description="run directories are created under this")
    on_write_error: Literal["continue", "refuse"] = Field(
        "continue", description="disk full / unwritable: keep flying (continue) or refuse to start"
    )
    flush_interval_s: float = Field(
        0.5, gt=0.0, le=1.0, description="flight.csv flushed at least this often (s)"
    )
    batch_interval_s: float = Field(
        0.25,
        gt=0.0,
        le=1.0,
        description="flight.csv rows built in batches this often, off the control path (s)",
    )
    keep_runs: int = Field(
        200,
        ge=1,
        le=100_000,
        description="run directories kept under run_root; the oldest are pruned at the start "
        "of a run (count)",
    )
    keep_bytes: int | None = Field(
        None,
        ge=10_000_000,
        le=10**15,
        description="run directories under run_root kept within this total size; the oldest "
        "are pruned at the start of a run; None: no size limit (bytes)",
    )


# ---------------------------------------------------------------------------------------------
# Planning (helixd.planning): paths around what is in the way


def _finite_ne_point(value: tuple[float, float]) -> tuple[float, float]:
    if not all(math.isfinite(v) and abs(v) <= 100_000.0 for v in value):
        raise ValueError("allowed: two finite numbers within ±100000 m")
    return value


class KeepOutCircleConfig(InputModel):
    north_m: float = Field(ge=-1e5, le=1e5, description="centre, north of EKF origin (m)")
    east_m: float = Field(ge=-1e5, le=1e5, description="centre, east of EKF origin (m)")
    radius_m: float = Field(gt=0.0, le=10_000.0, description="radius (m)")


class PlanningConfig(InputModel):
    """Grid path planning between consecutive waypoints (local_ned missions).

    Obstacles (a map_server map given with ``--map``, the keep-out shapes below, and everything
    outside ``safety.geofence_polygon_ne_m``) are inflated by the rover's half-width
    (``vehicle.ly_m / 2 + vehicle.scroll_radius_m``) plus ``margin_m``.
    """

    enabled: bool = Field(True, description="plan around obstacles when any are given")
    margin_m: float = Field(
        0.5, ge=0.0, le=20.0, description="clearance added to the rover's half-width (m)"
    )
    resolution_m: float = Field(
        0.1, ge=0.02, le=5.0, description="grid cell size when no map gives one (m)"
    )
    pad_m: float = Field(
        20.0, ge=0.0, le=1000.0, description="grid extends this far beyond waypoints/shapes (m)"
    )
    max_cells: int = Field(
        16_000_000, ge=10_000, le=100_000_000, description="largest grid (or map) accepted (cells)"
    )
    via_tolerance_m: float = Field(
        0.3, gt=0.05, le=5.0, description="arrival radius of inserted intermediate waypoints (m)"
    )
    start_ne_m: Annotated[tuple[float, float], AfterValidator(_finite_ne_point)] = Field(
        (0.0, 0.0), description="where the first leg is planned from, (north_m, east_m)"
    )
    keep_out_polygons_ne_m: tuple[
        Annotated[tuple[tuple[float, float], ...], AfterValidator(_sane_polygon)], ...
    ] = Field(
        (),
        max_length=1000,
        description="keep-out polygons, (north_m, east_m) vertices from the EKF origin",
    )
    keep_out_circles: tuple[KeepOutCircleConfig, ...] = Field(
        (), max_length=10_000, description="keep-out circles (north_m, east_m, radius_m)"
    )


# ---------------------------------------------------------------------------------------------
# Ground-station report (STATUSTEXT / NAMED_VALUE_FLOAT, helixd.runtime.gcs_report)


class GcsReportConfig(InputModel):
    enabled: bool = Field(True, description="send STATUSTEXT and NAMED_VALUE_FLOAT to the GCS")
    rate_hz: float = Field(
        2.0, gt=0.0, le=20.0, description="STATUSTEXTs per second, long run average (Hz)"
    )
    burst: int = Field(
        5, ge=1, le=50, description="STATUSTEXTs that may go out back to back before rate_hz"
    )
    queue_max: int = Field(
        20, ge=1, le=500, description="texts waiting for the rate limit; faults go first"
    )
    max_text_chars: int = Field(
        150,
        ge=50,
        le=500,
        description=(
            "texts go out as lines of up to 50 chars split between words; at most this "
            "many chars, a longer text ends in '...'"
        ),
    )
    repeat_window_s: float = Field(
        3.0,
        ge=0.0,
        le=600.0,
        description="a text the same as one queued this recently is not sent again (s; 0: "
        "every text is sent): the message pane shows each event once",
    )
    named_value_rate_hz: float = Field(
        2.0, gt=0.0, le=50.0, description="NAMED_VALUE_FLOAT xtrack_m / wp_index rate (Hz)"
    )
    tick_hz: float = Field(
        10.0, ge=1.0, le=50.0, description="how often the daemon's report task sends (Hz)"
    )
    final_flush_s: float = Field(
        1.0,
        ge=0.0,
        le=5.0,
        description="at the end of a run, at most this long (s) to send the last texts",
    )


# ---------------------------------------------------------------------------------------------
# helixd serve: the all-day service (helixd.serve.service)


class ServeConfig(InputModel):
    gcs_system_ids: list[Annotated[int, Field(ge=1, le=255)]] = Field(
        default_factory=lambda: [255],
        min_length=1,
        max_length=16,
        description="system ids whose MISSION_START / DO_PAUSE_CONTINUE helixd obeys; any "
        "other sender is DENIED. 255: QGroundControl and Mission Planner",
    )
    reconnect_initial_s: float = Field(
        1.0, gt=0.0, le=60.0, description="first wait before re-opening a link that failed (s)"
    )
    reconnect_max_s: float = Field(
        30.0,
        gt=0.0,
        le=600.0,
        description="the wait doubles after each failed attempt up to this (s)",
    )
    mission_poll_s: float = Field(
        10.0,
        gt=0.0,
        le=3600.0,
        description="while idle, the autopilot's mission is also re-read this often (s): "
        "ArduPilot tells only the uploading link 'Flight plan received' and MISSION_CURRENT "
        "carries no mission id, so a same-size upload from the ground station is noticed by "
        "this read (or a change of MISSION_CURRENT's item count); every start re-reads it "
        "anyway and flies the plan it finds if it passes the checks",
    )
    state_rate_hz: float = Field(
        1.0,
        gt=0.0,
        le=10.0,
        description="NAMED_VALUE_INT hx_state is sent on every change and this often (Hz)",
    )
    idle_pose_rate_hz: float = Field(
        5.0,
        ge=0.0,
        le=100.0,
        description="between flights the pose streams (LOCAL_POSITION_NED, ATTITUDE) are asked "
        "at this rate, and at link.pose_rate_hz's again before each flight starts (Hz; "
        "never faster than negotiated); 0: the flight's rate all day",
    )
    tick_s: float = Field(
        0.1,
        gt=0.0,
        le=1.0,
        description="the service's idle tick: start switch read, heartbeat fed, timers (s)",
    )
    switch_stale_s: float = Field(
        1.5,
        gt=0.0,
        le=10.0,
        description="the start switch is read only from a live radio: RC_CHANNELS older than "
        "this, or ArduPilot's radio failsafe, is no reading and vetoes a start (s)",
    )
    state_file: Path | None = Field(
        None,
        description="where the service records which mission was interrupted where (a JSON "
        "file); None: serve-state.json under recorder.run_root",
    )
    target_stale_s: float = Field(
        1.5,
        gt=0.0,
        le=10.0,
        description="the autopilot's place to go (POSITION_TARGET_GLOBAL_INT, asked at "
        "link.telemetry_rate_hz) not renewed for this long is no place: in GUIDED, RTL and "
        "SMART_RTL helixd then holds (s)",
    )
    disarm_when_complete: bool = Field(
        True,
        description="a flight that completes its mission ends disarmed (ArduPilot's AUTO "
        "stays armed in HOLD); false: it stays armed in HOLD, so Go to location or the next "
        "Start Mission needs no new arm. Disarmed is the default: between flights nobody "
        "drives the rover, and an armed one is a mode switch away from moving",
    )
    same_place_m: float = Field(
        0.5,
        ge=0.0,
        le=10.0,
        description="a place the autopilot publishes that moved less than this is the same "
        "place; farther, it is a new one, driven to on a new leg (m)",
    )
    mission_file: Path | None = Field(
        None,
        description="for crews without a ground station: fly this mission file (as `helixd "
        "run --mission` reads it; re-read while idle) instead of the autopilot's mission; "
        "None: the autopilot's",
    )

    @model_validator(mode="after")
    def _backoff_order(self) -> ServeConfig:
        if self.reconnect_max_s < self.reconnect_initial_s:
            raise ValueError(
                f"serve.reconnect_max_s = {self.reconnect_max_s} is below "
                f"serve.reconnect_initial_s = {self.reconnect_initial_s}"
            )
        return self


# ---------------------------------------------------------------------------------------------
# Top level


# ---------------------------------------------------------------------------------------------
# Payload: the sensors' readings recorded where they were taken (payload.csv)



class PayloadSource(InputModel):
    """One message (or one named value) that counts as one quantity in ``payload.csv``."""

    message: Literal["DISTANCE_SENSOR", "RANGEFINDER", "WATER_DEPTH", "NAMED_VALUE_FLOAT"] = Field(
        description="the MAVLink message the reading comes in"
    )
    quantity: str = Field(
        pattern=r"^[a-z][a-z0-9_]{0,31}$",
        description="the quantity's name in payload.csv, its unit in it (e.g. depth_m)",
    )
    name: str | None = Field(
        None,
        pattern=r"^[\x21-\x7e]{1,10}$",
        description="NAMED_VALUE_FLOAT only: the value's name (at most 10 printable characters)",
    )
    sensor_id: int | None = Field(
        None, ge=0, le=255, description="DISTANCE_SENSOR / WATER_DEPTH: this instance only"
    )
    downward_only: bool = Field(
        True,
        description="DISTANCE_SENSOR: only orientation PITCH_270 (facing down), as ArduPilot "
        "takes a depth only from a down-facing rangefinder",
    )
    offset_m: float = Field(
        0.0,
        ge=-10.0,
        le=10.0,
        description="added to the reading: for a sonar, its transducer's depth below the "
        "waterline, so the quantity is the depth from the surface (m)",
    )
    scale: float = Field(1.0, ge=-1e6, le=1e6, description="the reading × this, then + offset_m")
    min_value: float = Field(
        -1e9, ge=-1e9, le=1e9, description="readings below this are dropped (quantity's unit)"
    )
    max_value: float = Field(
        1e9, ge=-1e9, le=1e9, description="readings above this are dropped (quantity's unit)"
    )

    @model_validator(mode="after")
    def _named(self) -> PayloadSource:
        if (self.message == "NAMED_VALUE_FLOAT") != (self.name is not None):
            raise ValueError("name is given for NAMED_VALUE_FLOAT sources, and only for them")
        if self.min_value >= self.max_value:
            raise ValueError(f"min_value {self.min_value} must be < max_value {self.max_value}")
        return self


def _default_payload_sources() -> list[PayloadSource]:
    return [PayloadSource(message="DISTANCE_SENSOR", quantity="depth_m")]


class PayloadConfig(InputModel):
    """Which of the autopilot's messages are sensor readings, and how they are recorded."""

    enabled: bool = Field(
        True, description="write payload.csv (readings where they were taken) in the run"
    )
    sources: list[PayloadSource] = Field(
        default_factory=_default_payload_sources,
        max_length=32,
        description="each message (or named value) recorded and the quantity it counts as",
    )
    record_other_named_values: bool = Field(
        True,
        description="NAMED_VALUE_FLOATs no source names are recorded under their own name "
        "(quantity nv_<name>)",
    )
    min_signal_quality_pct: int = Field(
        0,
        ge=0,
        le=100,
        description="DISTANCE_SENSOR readings with a known signal quality below this are "
        "dropped (1 = invalid is always dropped; 0 = unknown is kept) (%)",
    )
    pose_max_gap_s: float = Field(
        1.0,
        gt=0.0,
        le=10.0,
        description="a reading is placed by interpolating the EKF poses either side of it; "
        "poses further apart than this (autopilot time) place nothing (s)",
    )


class GroundConfig(InputModel):
    """The rover learns its ground (docs/physics.md, "Learning the ground"): after each run
    with a media map, what each medium delivered in each mode is fitted from flight.csv and
    merged into the ground profile, which ``media.modes: learned`` plans with."""

    learn: bool = Field(True, description="merge each run with a media map into the profile")
    profile_file: Path | None = Field(
        None,
        description="the ground profile (YAML); None: ground-profile.yaml under recorder.run_root",
    )
    fade: float = Field(
        0.7,
        ge=0.0,
        le=1.0,
        description="how much the profile's older evidence counts after one more run (1)",
    )
    min_taught_s: float = Field(
        5.0,
        gt=0.0,
        le=3600.0,
        description="an axis taught for less than this in a medium and mode has no learned "
        "fraction: the defaults stand (s)",
    )
    objective: Literal["time", "energy"] = Field(
        "time",
        description="media.modes learned picks per medium the mode that is fastest (time) or "
        "spends the least energy per metre (energy)",
    )


class HelixdConfig(InputModel):
    vehicle: VehicleConfig = Field(default_factory=VehicleConfig)
    control: ControlConfig = Field(default_factory=ControlConfig)
    mission: MissionLimits = Field(default_factory=MissionLimits)
    link: LinkConfig = Field(default_factory=LinkConfig)
    actuation: ActuationConfig = Field(default_factory=ActuationConfig)
    safety: SafetyConfig = Field(default_factory=SafetyConfig)
    startup: StartupConfig = Field(default_factory=StartupConfig)
    recorder: RecorderConfig = Field(default_factory=RecorderConfig)
    planning: PlanningConfig = Field(default_factory=PlanningConfig)
    gcs_report: GcsReportConfig = Field(default_factory=GcsReportConfig)
    serve: ServeConfig = Field(default_factory=ServeConfig)
    media: MediaConfig = Field(default_factory=MediaConfig)
    payload: PayloadConfig = Field(default_factory=PayloadConfig)
    ground: GroundConfig = Field(default_factory=GroundConfig)

    @model_validator(mode="after")
    def _consistent(self) -> HelixdConfig:
        problems = config_consistency_problems(self)
        if problems:
            raise ValueError("\n".join(problems))
        return self


def config_consistency_problems(cfg: HelixdConfig) -> list[str]:
    """Rules that relate fields of different sections; one line per problem, naming both."""
    problems: list[str] = []
    act, saf = cfg.actuation, cfg.safety
    if act.stop_timeout_s >= saf.fallback_deadline_s:
        problems.append(
            f"actuation.stop_timeout_s = {act.stop_timeout_s} s must be < "
            f"safety.fallback_deadline_s = {saf.fallback_deadline_s} s (stopping the scrolls "
            "is one step of the fall-back that must finish within the deadline)"
        )
    if act.backend is ActuationBackend.RC_OVERRIDE:
        release_s = act.neutral_hold_s + (act.release_repeats - 1) * act.release_spacing_s
        if release_s >= act.stop_timeout_s:
            problems.append(
                f"actuation.neutral_hold_s + (release_repeats - 1) × release_spacing_s = "
                f"{release_s:.3f} s must be < actuation.stop_timeout_s = {act.stop_timeout_s} s "
                "(otherwise the release is cut off by the stop timeout)"
            )
    min_period_s = 1.0 / cfg.link.pose_rate_min_hz
    if saf.pose_stale_s <= min_period_s:
        problems.append(
            f"safety.pose_stale_s = {saf.pose_stale_s} s must be > 1 / link.pose_rate_min_hz = "
            f"{min_period_s:.3f} s (at the slowest accepted pose rate every pose would be stale)"
        )
    # the telemetry streams are stepped down no lower than this when the autopilot refuses
    telemetry_floor_hz = min(cfg.link.telemetry_rate_hz, cfg.link.pose_rate_min_hz)
    gps_gap_s = 1.0 / telemetry_floor_hz + GPS_FIX_PERIOD_MAX_S
    if saf.gps_stale_s <= gps_gap_s:
        problems.append(
            f"safety.gps_stale_s = {saf.gps_stale_s} s must be > 1 / min(link.telemetry_rate_hz, "
            f"link.pose_rate_min_hz) + {GPS_FIX_PERIOD_MAX_S} s = {gps_gap_s:.3f} s (GPS_RAW_INT "
            "comes at the telemetry rate, stepped down no lower than that; a new fix in it at "
            "least every 0.2 s, ArduPilot's slowest GPS_RATE_MS)"
        )
    if cfg.serve.switch_stale_s <= 1.0 / telemetry_floor_hz:
        problems.append(
            f"serve.switch_stale_s = {cfg.serve.switch_stale_s} s must be > 1 / "
            f"min(link.telemetry_rate_hz, link.pose_rate_min_hz) = {1.0 / telemetry_floor_hz:.3f}"
            " s (RC_CHANNELS comes at the telemetry rate, stepped down no lower than that)"
        )
    telemetry_period_s = 1.0 / cfg.link.telemetry_rate_hz
    if cfg.serve.target_stale_s <= telemetry_period_s:
        problems.append(
            f"serve.target_stale_s = {cfg.serve.target_stale_s} s must be > 1 / "
            f"link.telemetry_rate_hz = {telemetry_period_s:.3f} s (POSITION_TARGET_GLOBAL_INT "
            "comes at the telemetry rate)"
        )
    sta = cfg.startup
    if sta.arm_retry_interval_s > sta.arm_timeout_s:
        problems.append(
            f"startup.arm_retry_interval_s = {sta.arm_retry_interval_s} s must be <= "
            f"startup.arm_timeout_s = {sta.arm_timeout_s} s"
        )
    problems.extend(_channel_conflicts(cfg))
    return problems


def _channel_conflicts(cfg: HelixdConfig) -> list[str]:
    act, sta, tk = cfg.actuation, cfg.startup, cfg.safety.takeover
    problems: list[str] = []
    scrolls = {c.channel: i for i, c in enumerate(act.channels)}
    pilot: list[tuple[str, int]] = []
    if tk.switch_channel is not None:
        pilot.append(("safety.takeover.switch_channel", tk.switch_channel))
    if sta.start_switch_channel is not None:
        pilot.append(("startup.start_switch_channel", sta.start_switch_channel))
    pilot.extend(
        (f"safety.takeover.stick_channels.{i}", ch) for i, ch in enumerate(tk.stick_channels)
    )
    if act.backend is ActuationBackend.RC_OVERRIDE:
        for name, ch in pilot:
            if ch in scrolls:
                problems.append(
                    f"{name} = {ch} is the RC channel that drives scroll {scrolls[ch] + 1} "
                    f"(actuation.channels.{scrolls[ch]}.channel): our own override would read as "
                    f"the pilot's input; allowed: a channel 1..18 other than {sorted(scrolls)}"
                )
    if (
        tk.switch_channel is not None
        and sta.start_switch_channel is not None
        and tk.switch_channel == sta.start_switch_channel
    ):
        problems.append(
            f"safety.takeover.switch_channel and startup.start_switch_channel are both "
            f"{tk.switch_channel}: flipping the start switch would be read as a takeover"
        )
    for name, ch in pilot[:2]:
        if name == "startup.start_switch_channel" and ch in tk.stick_channels:
            problems.append(
                f"startup.start_switch_channel = {ch} is also in safety.takeover.stick_channels: "
                "flipping the start switch would be read as a stick deflection"
            )
    return problems


CONFIG_ENV = "HELIXD_CONFIG"  # the config file when no -c is given; set empty: built-in defaults
ROVER_CONFIG_PATH = Path("/etc/helixd/helixd.yaml")  # tools/install.sh writes it on the rover


def default_config_path(environ: Mapping[str, str] | None = None) -> Path | None:
    """The config a command reads when not given one (``-c``): ``$HELIXD_CONFIG`` when set
    (empty: the built-in defaults), else :data:`ROVER_CONFIG_PATH` when it exists (the rover),
    else None (the built-in defaults)."""
    env = os.environ if environ is None else environ
    named = env.get(CONFIG_ENV)
    if named is not None:
        return Path(named) if named.strip() else None
    return ROVER_CONFIG_PATH if ROVER_CONFIG_PATH.is_file() else None


def config_label(path: Path | str | None) -> str:
    """How a command names the config it read."""
    return "built-in defaults" if path is None else str(path)


def load_config(path: Path | str | None) -> HelixdConfig:
    """Load ``path`` (or the built-in defaults when None), and the files it names: what
    ``run`` would refuse on opening them, ``check`` refuses too (ConfigFileError, one line
    each)."""
    if path is None:
        return HelixdConfig()
    cfg = load_yaml_model(path, HelixdConfig)
    problems = named_file_problems(cfg, path)
    if problems:
        raise ConfigFileError(path, problems)
    return cfg


def named_file_problems(cfg: HelixdConfig, source: Path | str) -> list[str]:
    """Files the config names that ``run`` reads: ``link.signing_key_file`` must be a readable
    MAVLink signing key (the link reads it again when it opens)."""
    key = cfg.link.signing_key_file
    if key is None:
        return []
    where = f"{source}: link.signing_key_file"
    try:
        data = key.read_bytes()
    except OSError as exc:
        return [f"{where}: cannot read {key} ({exc.strerror or exc})"]
    try:
        parse_signing_key(data)
    except SigningKeyError as exc:
        return [f"{where}: {key}: {exc}"]
    return []


def config_to_yaml(cfg: BaseModel) -> str:
    """The resolved config as YAML (Paths and enums as plain strings)."""
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)
