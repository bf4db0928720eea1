"""The vehicle: the scrolls' geometry and calibration, and the outputs that drive them
(``vehicle``, ``actuation``)."""

from __future__ import annotations

from enum import StrEnum

from pydantic import Field, model_validator

from helixd.config.fields import ConfigSection

# ---------------------------------------------------------------------------------------------
# Vehicle


class ScrollCalibration(ConfigSection):
    """Per-scroll fraction calibration, the mecanum report's v = a·ω + b idea.

    applied = gain·f + sign(f)·offset for |f| ≥ deadband, 0 below it; negated when reversed.
    """

    gain: float = Field(1.0, ge=0.5, le=2.0)
    """slope a (dimensionless)"""
    offset: float = Field(0.0, ge=0.0, le=0.3)
    """fraction of max RPM added in the direction of motion"""
    deadband: float = Field(0.0, ge=0.0, le=0.3)
    """commands with |fraction| below this are sent as 0"""
    reversed: bool = Field(False)
    """scroll motor wired backwards"""


class VehicleConfig(ConfigSection):
    scroll_radius_m: float = Field(0.175, gt=0.01, le=1.0)
    """scroll radius r (m)"""
    lx_m: float = Field(0.565, gt=0.05, le=3.0)
    """front-back scroll distance l_x (m)"""
    ly_m: float = Field(0.508, gt=0.05, le=3.0)
    """left-right scroll distance l_y (m)"""
    max_rpm: float = Field(195.0, gt=1.0, le=2000.0)
    """scroll no-load max speed (RPM)"""
    output_clamp: float = Field(0.9, gt=0.0, le=1.0)
    """max |scroll command| as a fraction of max_rpm"""
    scrolls: tuple[ScrollCalibration, ScrollCalibration, ScrollCalibration, ScrollCalibration] = (
        Field(
            default_factory=lambda: (
                ScrollCalibration(),
                ScrollCalibration(),
                ScrollCalibration(),
                ScrollCalibration(),
            )
        )
    )
    """calibration of scrolls 1..4 (thesis Fig. 2 numbering)"""


# ---------------------------------------------------------------------------------------------
# Actuation


class ActuationBackend(StrEnum):
    RC_OVERRIDE = "rc_override"
    SERVO = "servo"
    DRY_RUN = "dry_run"


class ChannelConfig(ConfigSection):
    channel: int = Field(ge=1, le=18)
    """RC/servo channel number (1..18)"""
    pwm_min_us: int = Field(1000, ge=800, le=2200)
    """PWM at full reverse (µs)"""
    pwm_trim_us: int = Field(1500, ge=800, le=2200)
    """PWM at neutral (µs)"""
    pwm_max_us: int = Field(2000, ge=800, le=2200)
    """PWM at full forward (µs)"""
    reversed: bool = Field(False)
    """swap min and max on this channel"""
    deadband_us: int = Field(0, ge=0, le=200)
    """|PWM − trim| below this sent as trim"""

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


class ActuationConfig(ConfigSection):
    backend: ActuationBackend = Field(ActuationBackend.RC_OVERRIDE)
    """command sink"""
    channels: tuple[ChannelConfig, ChannelConfig, ChannelConfig, ChannelConfig] = Field(
        default_factory=_default_channels
    )
    """scrolls 1..4 → channel and PWM range"""
    repeat_rate_hz: float = Field(20.0, ge=10.0, le=100.0)
    """RC override re-send rate while healthy (Hz)"""
    release_repeats: int = Field(3, ge=1, le=20)
    """times the release message is sent (UDP may drop one)"""
    release_spacing_s: float = Field(0.02, ge=0.0, le=0.1)
    """pause between the repeated release messages (s)"""
    neutral_hold_s: float = Field(0.05, ge=0.0, le=0.2)
    """stop(): neutral is held this long before overrides are released (s)"""
    stop_timeout_s: float = Field(0.4, gt=0.0, le=5.0)
    """stop() gives up (and logs) after this long (s); below safety.fallback_deadline_s, of which
    stopping the scrolls is one step"""
    servo_refresh_s: float = Field(1.0, ge=0.1, le=10.0)
    """servo backend: each channel's DO_SET_SERVO is sent again after this long even when unchanged
    (s); an ACK is no proof: a value sent while helixd-guard holds the output is accepted and
    dropped"""

    @model_validator(mode="after")
    def _distinct(self) -> ActuationConfig:
        numbers = [c.channel for c in self.channels]
        if len(set(numbers)) != len(numbers):
            raise ValueError(f"each scroll needs its own channel, got {numbers}")
        return self
