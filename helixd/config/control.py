"""Control: the PID gains, the line guidance and the slip estimate (``control``)."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from helixd.config.fields import ConfigSection


class PidGains(ConfigSection):
    kp: float = Field(ge=0.0, le=100.0)
    """proportional gain"""
    ki: float = Field(ge=0.0, le=100.0)
    """integral gain (1/s)"""
    kd: float = Field(ge=0.0, le=100.0)
    """derivative gain (s)"""
    integral_limit: float = Field(ge=0.0, le=100.0)
    """anti-windup clamp on |ki·∫e dt| (output units)"""


GROUND_FRACTION_FIELDS = ("ground_roll_fraction", "ground_scroll_fraction", "ground_yaw_fraction")


class SlipConfig(ConfigSection):
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

    enabled: bool = Field(True)
    """feed the estimate forward (the command is divided by it)"""
    time_constant_s: float = Field(5.0, ge=0.5, le=600.0)
    """memory of the estimate: older evidence fades with this time constant, counted in autopilot
    time while learning (s)"""
    prior_weight_s: float = Field(1.0, ge=0.01, le=60.0)
    """weight of the no-slip prior (fraction 1), as seconds of evidence at the learning threshold
    (s)"""
    min_speed_mps: float = Field(0.15, gt=0.0, le=2.0)
    """translation is learnt only while the commanded (no-slip) speed exceeds this (m/s); frozen
    below it and while turning in place"""
    min_yaw_rate_radps: float = Field(0.2, gt=0.0, le=5.0)
    """yaw is learnt only while the commanded yaw rate exceeds this (rad/s)"""
    command_lag_s: float = Field(0.3, ge=0.0, le=5.0)
    """scroll response lag: the command is low-passed by this before it is compared with the
    measured motion (s)"""
    max_gap_s: float = Field(0.5, gt=0.0, le=5.0)
    """poses farther apart than this (autopilot time) teach nothing (s)"""
    steady_tolerance: float = Field(0.2, gt=0.0, le=1.0)
    """a channel teaches only while its command is steady: the command differs from its lagged
    value by at most this fraction of it (1)"""
    max_gain: float = Field(2.0, ge=1.0, le=5.0)
    """the feed-forward never amplifies a command by more than this factor (1)"""
    stuck_fraction: float = Field(0.15, gt=0.0, lt=1.0)
    """a delivered fraction below this is a stall, not slip: no amplification, the stall watchdog
    judges it (1)"""
    max_fraction: float = Field(1.2, ge=1.0, le=3.0)
    """upper bound of the estimate (more motion than commanded: noise, slope) (1)"""
    skew_share: float = Field(0.2, gt=0.0, le=0.5)
    """OMNI: the translation axis that delivers more is slowed to the other's fraction, so the
    rover moves in the direction commanded; ramped in while the other axis carries less than this
    share of the command (1)"""
    ground_roll_fraction: float = Field(1.0, gt=0.0, le=1.0)
    """the ground the operator expects: fraction of the no-slip (eq. 1) velocity along the roll
    axis it delivers. The estimate starts from it and the time estimate counts it; 1 = no slip (1)
    """
    ground_scroll_fraction: float = Field(1.0, gt=0.0, le=1.0)
    """the same along the scroll axis (1)"""
    ground_yaw_fraction: float = Field(1.0, gt=0.0, le=1.0)
    """the same for the yaw rate (1)"""

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


class ControlConfig(ConfigSection):
    distance_pid: PidGains = Field(
        default_factory=lambda: PidGains(kp=1.2, ki=0.0002, kd=0.05, integral_limit=0.2)
    )
    """distance error (m) → forward speed (m/s); thesis field-test gains"""
    yaw_pid: PidGains = Field(
        default_factory=lambda: PidGains(kp=8.0, ki=0.0, kd=0.05, integral_limit=0.3)
    )
    """heading error (rad) → yaw rate (rad/s); thesis gains"""
    heading_threshold_rad: float = Field(0.2, gt=0.0, le=1.5)
    """turn in place while |heading error| exceeds this (rad)"""
    waypoint_tolerance_m: float = Field(1.0, gt=0.05, le=20.0)
    """waypoint reached inside this radius (m)"""
    max_speed_mps: float = Field(0.6, gt=0.0, le=3.0)
    """translation speed cap (m/s)"""
    max_yaw_rate_radps: float = Field(1.0, gt=0.0, le=5.0)
    """yaw rate cap (rad/s)"""
    slowdown_radius_m: float = Field(2.0, ge=0.0, le=50.0)
    """speed ramps down linearly inside this radius (m)"""
    corner_slowdown_rad: float = Field(0.5, ge=0.0, le=math.pi)
    """waypoints where the path turns more than this are approached with the slow-down ramp;
    gentler ones are flown through at speed (rad)"""
    min_speed_mps: float = Field(0.1, ge=0.0, le=1.0)
    """speed floor while outside tolerance, avoids creeping (m/s)"""
    final_heading_tolerance_rad: float = Field(0.1, gt=0.0, le=1.0)
    """final-heading turn ends inside this (rad)"""
    guidance: Literal["line", "thesis"] = Field("line")
    """'line': track the leg previous waypoint → waypoint (lookahead law, perpendicular-line
    switching, pivot/gentle corners, acceleration limits); 'thesis': turn to the waypoint and drive
    at it (thesis eq. 3-6)"""
    lookahead_m: float = Field(1.0, gt=0.05, le=20.0)
    """line guidance: the course aims at the leg this far ahead, course = leg − atan(cross-track /
    lookahead) (m)"""
    mode_change_speed_mps: float = Field(0.2, gt=0.0, le=1.0)
    """a change of mode at a stop waits, scrolls stopped, until the measured ground speed is at
    most this: the mode is changed at rest even where the pose came late and the rover overran
    the stop's braking profile (m/s)"""
    mode_change_wait_s: float = Field(3.0, ge=0.0, le=30.0)
    """the longest a change of mode waits for mode_change_speed_mps; then it changes anyway
    (a current or a slope may keep the measured speed up) (s)"""
    stop_tolerance_m: float = Field(0.1, gt=0.01, le=5.0)
    """line guidance: the final waypoint, waypoints with a final heading and pivot corners are
    reached inside this radius (or by crossing the line through them perpendicular to the leg) (m)
    """
    pivot_angle_rad: float = Field(0.785, ge=0.0, le=math.pi)
    """line guidance: corners turning more than this are stopped at and pivoted in place
    (ROLL/SCROLL; OMNI stops), and TRACK re-aligns in place beyond this heading error (like
    ArduPilot WP_PIVOT_ANGLE) (rad)"""
    corner_error_m: float = Field(0.25, ge=0.0, le=2.0)
    """line guidance: a corner that is not a stop is flown as an arc tangent to both legs passing
    at most this far from the waypoint (never farther than the waypoint's tolerance), at the speed
    the radius and max_lateral_accel_mps2 allow; a corner whose arc would be slower than
    min_speed_mps is a pivot stop. 0: no arcs, corners sharper than pivot_angle_rad are pivots (the
    behaviour before arcs). Default 0.25 m, the value measured against AUTO (the time estimate
    follows the arcs): a 90° survey turn gets R = 0.60 m at 0.43 m/s instead of a stop and a pivot
    (≈ 0.8 s lost instead of ≈ 8 s); the arc passes 0.18 m from the legs, under half of ArduPilot
    AUTO's 0.45 m largest cross-track on SITL; 0.15–0.2 m would not beat AUTO's time (m)"""
    max_accel_mps2: float = Field(0.3, gt=0.0, le=5.0)
    """line guidance: translation command changes at most this fast, and the rover brakes for
    waypoints with it (m/s²)"""
    max_lateral_accel_mps2: float = Field(0.3, gt=0.0, le=5.0)
    """line guidance: gentle corners are flown at most at sqrt(a_lat · R), R = lookahead / tan(turn
    / 2) (m/s²)"""
    max_yaw_accel_radps2: float = Field(2.0, gt=0.0, le=50.0)
    """line guidance: yaw-rate command changes at most this fast, and turns brake with it (rad/s²)
    """
    braking_accel_mps2: float = Field(0.15, gt=0.0, le=5.0)
    """line guidance: the speed profile plans to slow down for stops and corners at this
    deceleration, at most max_accel_mps2, so a plant whose speed lags the command still arrives
    slowly (m/s²)"""

    @model_validator(mode="after")
    def _braking_within_accel(self) -> ControlConfig:
        if self.braking_accel_mps2 > self.max_accel_mps2:
            raise ValueError(
                f"control.braking_accel_mps2 = {self.braking_accel_mps2} exceeds "
                f"control.max_accel_mps2 = {self.max_accel_mps2}: the commands could not "
                "follow the planned braking"
            )
        return self

    max_dt_s: float = Field(0.5, gt=0.0, le=5.0)
    """larger control steps are treated as a restart (s)"""
    control_rate_max_hz: float = Field(50.0, ge=1.0, le=200.0)
    """ceiling on control steps per second (Hz)"""
    slip: SlipConfig = Field(default_factory=SlipConfig)
    """online slip estimate (delivered fraction of the command) and feed-forward"""
