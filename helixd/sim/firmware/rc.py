"""RC input model: the pilot's receiver plus MAVLink overrides, as ArduPilot's RC_Channels does it.

Ported semantics (ArduPilot master):

* GCS_MAVLINK::handle_rc_channels_override (GCS_Common.cpp): accepted only from the GCS
  sysid; channels 1–8: UINT16_MAX = leave unchanged, anything else (0 included) is passed to
  set_override, and 0 releases; channels 9–18: 0 and UINT16_MAX = leave unchanged,
  UINT16_MAX−1 = release. Only NUM_RC_CHANNELS = 16 exist, so 17–18 are dropped.
* RC_Channel::has_override: active while value > 0 and ``now − last_override < RC_OVERRIDE_TIME``
  (negative time = never expires, 0 = overrides disabled).
* RC_Channels::read_input: radio_in is only refreshed when the receiver delivered a new frame
  or a new override arrived. With the receiver gone, an expired/cleared override leaves
  radio_in (and so every RCIN passthrough output) frozen at its last value.
* RC_Channel::update: radio_in = override when active, else the receiver value (once a
  receiver has ever been seen). RC_OPTIONS bit 0 ignores the receiver, bit 1 the overrides.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from helixd.mav.constants import UINT16_MAX

NUM_RC_CHANNELS = 16
# What SITL's receiver sends in its failsafe (SIM_RC_FAIL 2, AP_RCProtocol_UDP): every channel
# centred, the throttle channel at 950 µs: the "low throttle" receiver failsafe ArduPilot's
# radio failsafe looks for (below FS_THR_VALUE), on a receiver that keeps sending. SITL
# assumes throttle is channel 3; here it is ArduPilot's RCMAP_THROTTLE, as a receiver
# programmed for the vehicle would have it.
FAILSAFE_CENTRE_US = 1500
FAILSAFE_THROTTLE_US = 950
RC_OPTION_IGNORE_RECEIVER = 1 << 0
RC_OPTION_IGNORE_OVERRIDES = 1 << 1
NO_OVERRIDES = (False,) * NUM_RC_CHANNELS


@dataclass(frozen=True, slots=True)
class OverrideEvent:
    kind: str  # "set" | "release"
    channel: int  # 1-based
    pwm_us: int


class RcInputs:
    """Receiver + override state; every time argument is simulated seconds."""

    def __init__(self, receiver_us: Sequence[int]) -> None:
        self.receiver_us: list[int] = [int(v) for v in receiver_us][:NUM_RC_CHANNELS]
        self.receiver_ok = True
        self.failsafe_values = False  # the receiver sends its failsafe frame (SIM_RC_FAIL 2)
        self.throttle_channel = 3  # RCMAP_THROTTLE: the channel that frame puts low
        self.has_had_receiver = False
        # what hal.rcin->read() returns: the last frame actually received
        self.last_frame_us: list[int] = list(self.receiver_us)
        self.override_us: list[int] = [0] * NUM_RC_CHANNELS
        self.override_time_s: list[float] = [0.0] * NUM_RC_CHANNELS
        self.has_new_overrides = False
        self.radio_in_us: list[int] = [0] * NUM_RC_CHANNELS

    # -- overrides -------------------------------------------------------------------------

    def apply_override_message(
        self, raw: Sequence[int], now_s: float, rc_options: int
    ) -> list[OverrideEvent]:
        """RC_CHANNELS_OVERRIDE chan1..chan18 (already checked to come from the GCS sysid)."""
        events: list[OverrideEvent] = []
        for i, value in enumerate(raw):
            if i < 8:
                if value == UINT16_MAX:
                    continue
                pwm = int(value)
            else:
                if value in (0, UINT16_MAX):
                    continue
                pwm = 0 if value == UINT16_MAX - 1 else int(value)
            if i >= NUM_RC_CHANNELS:
                continue  # RC_Channels::set_override ignores chan >= NUM_RC_CHANNELS
            if rc_options & RC_OPTION_IGNORE_OVERRIDES:
                continue
            was = self.override_us[i]
            self.override_us[i] = pwm
            self.override_time_s[i] = now_s
            self.has_new_overrides = True
            if pwm == 0 and was != 0:
                events.append(OverrideEvent("release", i + 1, 0))
            elif pwm != 0 and pwm != was:
                events.append(OverrideEvent("set", i + 1, pwm))
        return events

    def set_override(self, channel: int, pwm_us: int, now_s: float) -> None:
        """RC_Channel::set_override from a script (``rc:get_channel(c):set_override(v)``): as a
        GCS override it expires after RC_OVERRIDE_TIME; it is no GCS contact."""
        if not 1 <= channel <= NUM_RC_CHANNELS:
            return
        self.override_us[channel - 1] = int(pwm_us)
        self.override_time_s[channel - 1] = now_s
        self.has_new_overrides = True

    def has_override(self, index: int, now_s: float, timeout_s: float) -> bool:
        if self.override_us[index] <= 0:
            return False
        if timeout_s < 0.0:
            return True
        if timeout_s == 0.0:
            return False
        return now_s - self.override_time_s[index] < timeout_s

    def active_overrides(self, now_s: float, timeout_s: float) -> tuple[bool, ...]:
        """:meth:`has_override` of every channel (read every loop: one pass, no calls)."""
        if timeout_s < 0.0:
            return tuple([pwm > 0 for pwm in self.override_us])
        if timeout_s == 0.0:
            return NO_OVERRIDES
        return tuple(
            [
                pwm > 0 and now_s - t < timeout_s
                for pwm, t in zip(self.override_us, self.override_time_s, strict=True)
            ]
        )

    def clear_overrides(self) -> None:
        """RC_Channels::clear_overrides: no read_input() follows, radio_in stays as it was."""
        self.override_us = [0] * NUM_RC_CHANNELS
        self.override_time_s = [0.0] * NUM_RC_CHANNELS

    # -- receiver --------------------------------------------------------------------------

    def set_receiver(self, channel: int, pwm_us: int) -> None:
        self.receiver_us[channel - 1] = int(pwm_us)

    def read_input(self, now_s: float, timeout_s: float, rc_options: int) -> bool:
        """One RC_Channels::read_input(); True when radio_in was refreshed."""
        new_frame = self.receiver_ok and not (rc_options & RC_OPTION_IGNORE_RECEIVER)
        if new_frame:
            self.has_had_receiver = True
            self.last_frame_us = (
                failsafe_frame(self.throttle_channel)
                if self.failsafe_values
                else list(self.receiver_us)
            )
        elif not self.has_new_overrides:
            return False
        self.has_new_overrides = False
        updated = False
        active = self.active_overrides(now_s, timeout_s)
        for i in range(NUM_RC_CHANNELS):
            if active[i] and not (rc_options & RC_OPTION_IGNORE_OVERRIDES):
                self.radio_in_us[i] = self.override_us[i]
                updated = True
            elif self.has_had_receiver and not (rc_options & RC_OPTION_IGNORE_RECEIVER):
                self.radio_in_us[i] = self.last_frame_us[i]
                updated = True
        return updated


def failsafe_frame(throttle_channel: int) -> list[int]:
    """The frame a receiver in failsafe sends (SITL's SIM_RC_FAIL 2)."""
    frame = [FAILSAFE_CENTRE_US] * NUM_RC_CHANNELS
    if 1 <= throttle_channel <= NUM_RC_CHANNELS:
        frame[throttle_channel - 1] = FAILSAFE_THROTTLE_US
    return frame
