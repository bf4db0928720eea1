"""Servo output model (SRV_Channel / AP_ServoRelayEvents / AP_MotorsUGV, simplified).

* RCIN passthrough (SERVOn_FUNCTION 51..66, and 1 = "manual" from the same channel):
  output = radio_in of the source RC channel, whatever the mode or arming state
  (SRV_Channel::output_ch in SRV_Channel_aux.cpp). HOLD and disarm therefore do NOT stop
  them — only ArduPilot's own throttle/steering functions go to trim in HOLD
  (Rover/mode_hold.cpp sets throttle and steering to 0) or when disarmed (safety output).
* MAV_CMD_DO_SET_SERVO (AP_ServoRelayEvents::do_set_servo): allowed only when the channel's
  function is in :data:`helixd.mav.servo_functions.DO_SET_SERVO_FUNCTIONS` (none, manual,
  sprayer, gripper, RCIN1..16 and RCIN1..16 mapped); otherwise FAILED with "ServoRelayEvent:
  Channel N is already in use". A mapped function's rescaling of the PWM to ±4500 is not
  modelled: the value is latched as sent. The value is latched (set_output_pwm, no timeout).
  On a passthrough channel it holds until the RC input moves by more than the channel's dead
  zone (ignore_small_rcin_changes).
* Function 0 before any DO_SET_SERVO outputs SERVOn_TRIM (an approximation).
* A script's ``SRV_Channels:set_output_pwm_chan_timeout`` (:meth:`ServoOutputs.hold`;
  SRV_Channels.cpp): the output is forced to the value for a number of main loops (the timeout
  rounded up to loops). While it is active, a DO_SET_SERVO is accepted but changes nothing
  (``set_output_pwm`` without force); ArduPilot's own functions keep the value instead of
  their computed one. An RC passthrough output ignores it: ``output_ch`` copies the RC input
  onto the output after the override is applied (helixd-guard overrides the RC input as well).
  When it ends, a function-0 output keeps the held value (``have_pwm_mask``), ArduPilot's own
  functions are computed again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from helixd.mav.servo_functions import (
    DO_SET_SERVO_FUNCTIONS,
    K_MANUAL,
    K_RCIN1,
    K_RCIN16,
    K_STEERING,
    K_THROTTLE,
    K_THROTTLE_LEFT,
    K_THROTTLE_RIGHT,
)
from helixd.sim.firmware.param_store import ParamStore

NUM_SERVO_CHANNELS = 16


@dataclass(frozen=True, slots=True)
class MotorDemand:
    """ArduPilot's own drive demand (AP_MotorsUGV): throttle and steering in −1..1."""

    throttle: float = 0.0
    steering: float = 0.0


@dataclass(slots=True)
class _Channel:
    latched: bool = False
    latched_pwm_us: int = 0
    ignore_small_rcin_changes: bool = False
    previous_radio_in_us: int = 0
    output_pwm_us: int = 0
    override_loops: int = 0  # SRV_Channels::override_counter
    override_active: bool = False
    override_pwm_us: int = 0


def _scaled_pwm(value: float, n: int, params: ParamStore) -> int:
    """−1..1 → PWM around SERVOn_TRIM within SERVOn_MIN/MAX (honours SERVOn_REVERSED)."""
    lo = params.get_int(f"SERVO{n}_MIN")
    trim = params.get_int(f"SERVO{n}_TRIM")
    hi = params.get_int(f"SERVO{n}_MAX")
    v = max(-1.0, min(1.0, value))
    if params.get_int(f"SERVO{n}_REVERSED"):
        v = -v
    return round(trim + v * (hi - trim)) if v >= 0.0 else round(trim + v * (trim - lo))


def skid_mix(demand: MotorDemand) -> tuple[float, float]:
    """AP_MotorsUGV::output_skid_steering: left = t + s, right = t − s, scaled to fit."""
    left = demand.throttle + demand.steering
    right = demand.throttle - demand.steering
    peak = max(1.0, abs(left), abs(right))
    return left / peak, right / peak


@dataclass(frozen=True, slots=True)
class _ChannelParams:
    """What one output's loop reads of the parameters: SERVOn_FUNCTION, its RC source (−1:
    none) and that source's RCn_DZ, SERVOn_TRIM."""

    function: int
    source: int
    source_dz: int
    trim: int


def channel_params(params: ParamStore) -> tuple[_ChannelParams, ...]:
    """Every output's :class:`_ChannelParams`, as the parameters are now."""
    out = []
    for i in range(NUM_SERVO_CHANNELS):
        n = i + 1
        function = params.get_int(f"SERVO{n}_FUNCTION")
        source = -1
        if function == K_MANUAL:
            source = i
        elif K_RCIN1 <= function <= K_RCIN16:
            source = function - K_RCIN1
        dz = params.get_int(f"RC{source + 1}_DZ") if source >= 0 else 0
        out.append(_ChannelParams(function, source, dz, params.get_int(f"SERVO{n}_TRIM")))
    return tuple(out)


class ServoOutputs:
    def __init__(self) -> None:
        self._ch = [_Channel() for _ in range(NUM_SERVO_CHANNELS)]
        self.outputs_us: list[int] = [0] * NUM_SERVO_CHANNELS
        # channel_params of the parameter store and version they were read at (every loop
        # reads them; a parameter set bumps the version, so they are read again)
        self._params_read: tuple[ParamStore | None, int, tuple[_ChannelParams, ...]] = (
            None,
            -1,
            (),
        )

    def _channel_params(self, params: ParamStore) -> tuple[_ChannelParams, ...]:
        store, version, read = self._params_read
        if store is not params or version != params.version:
            read = channel_params(params)
            self._params_read = (params, params.version, read)
        return read

    def latched_channels(self) -> tuple[int, ...]:
        return tuple(i + 1 for i, c in enumerate(self._ch) if c.latched)

    def check_servo(self, channel: int, params: ParamStore) -> str | None:
        """Why DO_SET_SERVO / DO_REPEAT_SERVO is refused on ``channel`` (None: it is not); the
        STATUSTEXT ArduPilot sends, or '' when it sends none."""
        if not 1 <= channel <= NUM_SERVO_CHANNELS:
            return ""  # srv_channel(channel-1) == nullptr → false → FAILED, no text
        function = params.get_int(f"SERVO{channel}_FUNCTION")
        if function not in DO_SET_SERVO_FUNCTIONS:
            return f"ServoRelayEvent: Channel {channel} is already in use"
        return None

    def latch(self, channel: int, pwm_us: int) -> None:
        """SRV_Channel::set_output_pwm + ignore_small_rcin_changes (a checked channel)."""
        c = self._ch[channel - 1]
        c.ignore_small_rcin_changes = True
        if c.override_active:
            return None  # set_output_pwm() does not overwrite an override: ACCEPTED, no effect
        c.latched = True
        c.latched_pwm_us = int(pwm_us)
        c.output_pwm_us = int(pwm_us)

    def do_set_servo(self, channel: int, pwm_us: int, params: ParamStore) -> str | None:
        """Returns None when accepted, else the STATUSTEXT ArduPilot sends (or '')."""
        refusal = self.check_servo(channel, params)
        if refusal is not None:
            return refusal
        self.latch(channel, pwm_us)
        return None

    def hold(self, channel: int, pwm_us: int, loops: int) -> None:
        """``set_output_pwm_chan_timeout(channel - 1, pwm_us, ·)`` lasting ``loops`` main loops."""
        if not 1 <= channel <= NUM_SERVO_CHANNELS:
            return
        c = self._ch[channel - 1]
        c.override_loops = max(0, int(loops))
        c.override_active = True
        c.override_pwm_us = int(pwm_us)
        c.output_pwm_us = int(pwm_us)
        if c.latched:  # had_pwm: the held value stays after the timeout
            c.latched_pwm_us = int(pwm_us)

    def held_channels(self) -> tuple[int, ...]:
        """Outputs (1-based) under a script's timed override."""
        return tuple(i + 1 for i, c in enumerate(self._ch) if c.override_active)

    def update(
        self,
        radio_in_us: Sequence[int],
        params: ParamStore,
        demand: MotorDemand | None,
    ) -> list[int]:
        """Recompute all 16 outputs; ``demand`` None = disarmed (safety output = trim)."""
        left_right = skid_mix(demand) if demand is not None else (0.0, 0.0)
        for i, (c, p) in enumerate(zip(self._ch, self._channel_params(params), strict=True)):
            n = i + 1
            # SRV_Channels::calc_pwm: count the override down, one main loop at a time
            if c.override_loops == 0:
                c.override_active = False
            else:
                c.override_active = True
                c.override_loops -= 1
            function, source = p.function, p.source
            if source >= 0:
                radio_in = int(radio_in_us[source])
                if not c.ignore_small_rcin_changes:
                    c.output_pwm_us = radio_in
                    c.previous_radio_in_us = radio_in
                elif abs(radio_in - c.previous_radio_in_us) > p.source_dz:
                    c.output_pwm_us = radio_in
                    c.ignore_small_rcin_changes = False
                    c.latched = False
            elif c.override_active:
                c.output_pwm_us = c.override_pwm_us
            elif function == K_THROTTLE:
                c.output_pwm_us = _scaled_pwm(demand.throttle if demand else 0.0, n, params)
            elif function == K_STEERING:
                c.output_pwm_us = _scaled_pwm(demand.steering if demand else 0.0, n, params)
            elif function == K_THROTTLE_LEFT:
                c.output_pwm_us = _scaled_pwm(left_right[0], n, params)
            elif function == K_THROTTLE_RIGHT:
                c.output_pwm_us = _scaled_pwm(left_right[1], n, params)
            elif c.latched:
                c.output_pwm_us = c.latched_pwm_us
            else:
                c.output_pwm_us = p.trim
            self.outputs_us[i] = c.output_pwm_us
        return self.outputs_us
