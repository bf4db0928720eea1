"""Scroll fraction ⇄ PWM, and the RC_CHANNELS_OVERRIDE frames (pure functions).

PWM per :class:`helixd.config.vehicle.ChannelConfig`: ``trim + f·(max − trim)`` for f > 0,
``trim + f·(trim − min)`` for f < 0 (``reversed`` swaps the ends), ``|pwm − trim| <
deadband_us`` sent as trim, clamped to [min, max].

RC_CHANNELS_OVERRIDE field semantics (ArduPilot GCS_MAVLINK::handle_rc_channels_override and
the MAVLink spec; docs/ardupilot.md, RC override):

=============  ==========================  ===================================
channels       leave unchanged (not ours)  release to the pilot's radio
=============  ==========================  ===================================
1–8            UINT16_MAX (65535)          0
9–18           0 (or UINT16_MAX)           UINT16_MAX − 1 (65534)
=============  ==========================  ===================================
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Generic, TypeVar

from helixd.config.vehicle import ActuationConfig, ChannelConfig, VehicleConfig
from helixd.mav.constants import UINT16_MAX

SenderT = TypeVar("SenderT")
RC_OVERRIDE_CHANNELS = 18
FIRST_EXTENDED_CHANNEL = 9  # channels 9..18 use the second set of semantics


class ChannelSink(Generic[SenderT]):
    """What the RC-override and the DO_SET_SERVO sinks share: the four scroll channels
    (``actuation.channels``), their neutral PWM, the output clamp, the PWM last commanded
    (neutral until the first command), and the autopilot ``ap`` they send through."""

    def __init__(self, actuation: ActuationConfig, vehicle: VehicleConfig, ap: SenderT) -> None:
        self._cfg = actuation
        self._clamp = vehicle.output_clamp
        self._channels = tuple(actuation.channels)
        n = [neutral_pwm(c) for c in self._channels]
        self._neutral: tuple[int, int, int, int] = (n[0], n[1], n[2], n[3])
        self.last_pwm_us: tuple[int, int, int, int] = self._neutral
        self._ap = ap
        self._warned_idle = False

    def _pwm_for(self, fractions: Sequence[float]) -> tuple[int, int, int, int]:
        """The PWM of each scroll channel for checked ``fractions``."""
        p = [fraction_to_pwm(x, ch) for x, ch in zip(fractions, self._channels, strict=True)]
        return (p[0], p[1], p[2], p[3])

    def _first_idle(self) -> bool:
        """True the first time the sink is commanded before it started (it warns once)."""
        first = not self._warned_idle
        self._warned_idle = True
        return first


def neutral_pwm(ch: ChannelConfig) -> int:
    return ch.pwm_trim_us


def fraction_to_pwm(fraction: float, ch: ChannelConfig) -> int:
    """Signed fraction of max scroll speed → PWM (µs). Non-finite input gives neutral."""
    if not math.isfinite(fraction):
        return ch.pwm_trim_us
    f = max(-1.0, min(1.0, fraction))
    if ch.reversed:
        f = -f
    trim = ch.pwm_trim_us
    span = (ch.pwm_max_us - trim) if f > 0 else (trim - ch.pwm_min_us)
    pwm = round(trim + f * span)
    if abs(pwm - trim) < ch.deadband_us:
        pwm = trim
    return max(ch.pwm_min_us, min(ch.pwm_max_us, pwm))


def pwm_to_fraction(pwm_us: float, ch: ChannelConfig) -> float:
    """Inverse of :func:`fraction_to_pwm` (up to rounding; deadband reads as 0)."""
    trim = ch.pwm_trim_us
    if abs(pwm_us - trim) < ch.deadband_us:
        return 0.0
    pwm = max(ch.pwm_min_us, min(ch.pwm_max_us, pwm_us))
    if pwm >= trim:
        f = (pwm - trim) / (ch.pwm_max_us - trim)
    else:
        f = (pwm - trim) / (trim - ch.pwm_min_us)
    return -f if ch.reversed else f


def leave_unchanged_value(channel: int) -> int:
    _check_channel(channel)
    return UINT16_MAX if channel < FIRST_EXTENDED_CHANNEL else 0


def release_value(channel: int) -> int:
    _check_channel(channel)
    return 0 if channel < FIRST_EXTENDED_CHANNEL else UINT16_MAX - 1


def override_slots(channels: Iterable[int]) -> tuple[int, ...]:
    """Positions of ``channels`` in the 18 override fields (checked once, for a sink that
    fills the same channels at every command with :func:`frame_at`)."""
    out = []
    for channel in channels:
        _check_channel(channel)
        out.append(channel - 1)
    return tuple(out)


def frame_at(slots: Sequence[int], pwms_us: Sequence[int]) -> tuple[int, ...]:
    """18 override fields: ``pwms_us`` at ``slots`` (from :func:`override_slots`; PWMs from
    :func:`fraction_to_pwm`, never a reserved value), "leave unchanged" elsewhere."""
    frame = list(_LEAVE_UNCHANGED)
    for slot, pwm in zip(slots, pwms_us, strict=True):
        frame[slot] = pwm
    return tuple(frame)


def release_frame(channels: Iterable[int]) -> tuple[int, ...]:
    """18 override fields releasing ``channels`` and leaving every other channel alone."""
    frame = list(_LEAVE_UNCHANGED)
    for channel in channels:
        frame[channel - 1] = release_value(channel)
    return tuple(frame)


def _check_channel(channel: int) -> None:
    if not 1 <= channel <= RC_OVERRIDE_CHANNELS:
        raise ValueError(f"RC channel {channel} is outside 1..{RC_OVERRIDE_CHANNELS}")


# the "leave unchanged" frame, built once (every override frame starts from it)
_LEAVE_UNCHANGED: tuple[int, ...] = tuple(
    leave_unchanged_value(c) for c in range(1, RC_OVERRIDE_CHANNELS + 1)
)
