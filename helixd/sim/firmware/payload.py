"""The payload commands a mission (or a ground station) sends: relays, repeated servo/relay
cycles, the camera, the gripper, the sprayer, auxiliary functions, the fence switch. Pure: no
sockets, no clocks; times are simulated seconds.

Written from ArduPilot (the wire behaviour, not a guess):

* ``GCS_ServoRelay.cpp`` / ``AP_ServoRelayEvents.cpp``: DO_SET_RELAY → ACCEPTED when the relay
  instance (param1, 0 = RELAY1) is enabled (``RELAYn_FUNCTION`` 1 = relay and ``RELAYn_PIN`` set,
  ``AP_Relay::enabled``), else FAILED; state 1 on, 0 off, anything else toggles.
  DO_REPEAT_RELAY toggles it ``count`` × 2 times, every ``period / 2``. DO_REPEAT_SERVO: the
  same output rule as DO_SET_SERVO (:mod:`helixd.sim.firmware.outputs`), then ``count`` cycles of
  value / SERVOn_TRIM, half a period each; a DO_SET_SERVO on that output cancels the cycling.
  ``update_events`` runs the first half-cycle at once.
* ``AP_Relay::send_relay_status``: RELAY_STATUS present/on masks of the relays with a function.
* ``GCS_Common.cpp`` → ``AP_Camera::handle_command`` (``CAM1_TYPE`` 0: no camera backend):
  DO_DIGICAM_CONFIGURE, DO_DIGICAM_CONTROL and DO_SET_CAM_TRIGG_DIST are ACCEPTED with or without
  a camera (nothing happens without one); IMAGE_START_CAPTURE is FAILED without a camera (no
  backend takes the picture), ACCEPTED with one; IMAGE_STOP_CAPTURE for all cameras is
  ACCEPTED. With a camera, DO_DIGICAM_CONTROL's shoot (param5 = 1) and IMAGE_START_CAPTURE take
  a picture, DO_SET_CAM_TRIGG_DIST takes one every ``distance`` metres driven (0 stops it;
  param3 = 1: one at once).
* ``handle_command_do_gripper``: FAILED unless ``GRIP_ENABLE``; action 0 release, 1 grab.
  ``handle_command_do_sprayer``: ACCEPTED (Rover builds the sprayer library in).
  ``handle_command_do_aux_function``: DENIED for a switch position above 2, else ACCEPTED.
  DO_FENCE_ENABLE: ACCEPTED for 0/1/2 (the simulator keeps the state only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from helixd.mav.constants import (
    MAV_CMD_DO_AUX_FUNCTION,
    MAV_CMD_DO_DIGICAM_CONFIGURE,
    MAV_CMD_DO_DIGICAM_CONTROL,
    MAV_CMD_DO_FENCE_ENABLE,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_REPEAT_RELAY,
    MAV_CMD_DO_REPEAT_SERVO,
    MAV_CMD_DO_SET_CAM_TRIGG_DIST,
    MAV_CMD_DO_SET_RELAY,
    MAV_CMD_DO_SPRAYER,
    MAV_CMD_IMAGE_START_CAPTURE,
    MAV_CMD_IMAGE_STOP_CAPTURE,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_UNSUPPORTED,
)
from helixd.sim.firmware.outputs import ServoOutputs
from helixd.sim.firmware.param_store import ParamStore

NUM_RELAYS = 6  # RELAY1..RELAY6 as the simulator models them
RELAY_FUNCTION_RELAY = 1

RELAY_COMMANDS = frozenset({MAV_CMD_DO_SET_RELAY, MAV_CMD_DO_REPEAT_RELAY, MAV_CMD_DO_REPEAT_SERVO})
CAMERA_COMMANDS = frozenset(
    {
        MAV_CMD_DO_DIGICAM_CONFIGURE,
        MAV_CMD_DO_DIGICAM_CONTROL,
        MAV_CMD_DO_SET_CAM_TRIGG_DIST,
        MAV_CMD_IMAGE_START_CAPTURE,
        MAV_CMD_IMAGE_STOP_CAPTURE,
    }
)
# the gripper, the sprayer, an auxiliary function, the fence
DEVICE_COMMANDS = frozenset(
    {MAV_CMD_DO_GRIPPER, MAV_CMD_DO_SPRAYER, MAV_CMD_DO_AUX_FUNCTION, MAV_CMD_DO_FENCE_ENABLE}
)
PAYLOAD_COMMANDS = RELAY_COMMANDS | CAMERA_COMMANDS | DEVICE_COMMANDS


@dataclass(frozen=True, slots=True)
class PayloadEvent:
    kind: str  # relay, servo_repeat, picture, gripper, sprayer, aux_function, fence_enable
    details: dict[str, object]


@dataclass(slots=True)
class _Repeat:
    """AP_ServoRelayEvents' one repeating event."""

    servo: bool  # EVENT_TYPE_SERVO, else relay
    channel: int  # servo output (1-based) or relay instance
    value_us: int
    half_period_s: float
    remaining: int  # half-cycles left (repeat × 2)
    next_s: float


@dataclass
class Payload:
    relays: dict[int, bool] = field(default_factory=dict)  # instance → on
    repeat: _Repeat | None = None
    pictures: int = 0
    trigger_distance_m: float = 0.0
    last_picture_ne: tuple[float, float] | None = None
    gripper_grabbed: bool | None = None
    sprayer_on: bool = False
    fence_enabled: int | None = None

    # -- relays ------------------------------------------------------------------------------

    @staticmethod
    def relay_enabled(instance: int, params: ParamStore) -> bool:
        if not 0 <= instance < NUM_RELAYS:
            return False
        n = instance + 1
        return (
            params.get_int(f"RELAY{n}_FUNCTION") == RELAY_FUNCTION_RELAY
            and params.get_int(f"RELAY{n}_PIN") != -1
        )

    def relay_status(self, params: ParamStore) -> tuple[int, int]:
        """RELAY_STATUS (on, present) masks: relays with a function are present."""
        on = present = 0
        for i in range(NUM_RELAYS):
            if params.get_int(f"RELAY{i + 1}_FUNCTION") > 0:
                present |= 1 << i
                if self.relays.get(i, False):
                    on |= 1 << i
        return on, present

    def _toggle(self, instance: int) -> bool:
        self.relays[instance] = not self.relays.get(instance, False)
        return self.relays[instance]

    # -- commands ----------------------------------------------------------------------------

    def command(
        self,
        command: int,
        p: list[float],
        params: ParamStore,
        outputs: ServoOutputs,
        here_ne: tuple[float, float],
        now_s: float,
    ) -> tuple[int, list[PayloadEvent]]:
        """The MAV_RESULT and what happened, for one of :data:`PAYLOAD_COMMANDS`."""
        if command in CAMERA_COMMANDS:
            return self._camera_command(command, p, params, here_ne)
        if command in DEVICE_COMMANDS:
            return self._device_command(command, p, params)
        events: list[PayloadEvent] = []
        if command == MAV_CMD_DO_SET_RELAY:
            instance, state = int(p[0]), int(p[1])
            if not self.relay_enabled(instance, params):
                return MAV_RESULT_FAILED, events
            r = self.repeat
            if r is not None and not r.servo and r.channel == instance:
                self.repeat = None  # cancel previous repeat
            if state in (0, 1):
                self.relays[instance] = state == 1
            else:
                self._toggle(instance)
            events.append(PayloadEvent("relay", {"relay": instance, "on": self.relays[instance]}))
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_DO_REPEAT_RELAY:
            instance = int(p[0])
            if not self.relay_enabled(instance, params):
                return MAV_RESULT_FAILED, events
            self.repeat = _Repeat(False, instance, 0, p[2] / 2.0, int(p[1]) * 2, now_s)
            events += self.update(now_s, params, outputs, here_ne)
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_DO_REPEAT_SERVO:
            channel = int(p[0])
            refusal = outputs.check_servo(channel, params)
            if refusal is not None:
                return MAV_RESULT_FAILED, events
            self.repeat = _Repeat(True, channel, int(p[1]), p[3] / 2.0, int(p[2]) * 2, now_s)
            events += self.update(now_s, params, outputs, here_ne)
            return MAV_RESULT_ACCEPTED, events
        raise ValueError(f"not a payload command: {command}")

    def _device_command(
        self, command: int, p: list[float], params: ParamStore
    ) -> tuple[int, list[PayloadEvent]]:
        """The gripper's, the sprayer's, an auxiliary function's and the fence's commands
        (:data:`DEVICE_COMMANDS`)."""
        events: list[PayloadEvent] = []
        if command == MAV_CMD_DO_GRIPPER:
            if not params.get_int("GRIP_ENABLE") or int(p[1]) not in (0, 1):
                return MAV_RESULT_FAILED, events
            self.gripper_grabbed = int(p[1]) == 1
            events.append(PayloadEvent("gripper", {"grabbed": self.gripper_grabbed}))
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_DO_SPRAYER:
            if p[0] in (0.0, 1.0):
                self.sprayer_on = p[0] == 1.0
                events.append(PayloadEvent("sprayer", {"on": self.sprayer_on}))
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_DO_AUX_FUNCTION:
            if p[1] > 2:
                return MAV_RESULT_DENIED, events
            events.append(
                PayloadEvent("aux_function", {"function": int(p[0]), "switch": int(p[1])})
            )
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_DO_FENCE_ENABLE:
            if int(p[0]) not in (0, 1, 2):
                return MAV_RESULT_FAILED, events
            self.fence_enabled = int(p[0])
            events.append(PayloadEvent("fence_enable", {"enable": self.fence_enabled}))
            return MAV_RESULT_ACCEPTED, events
        raise ValueError(f"not a device command: {command}")

    def _camera_command(
        self, command: int, p: list[float], params: ParamStore, here_ne: tuple[float, float]
    ) -> tuple[int, list[PayloadEvent]]:
        """The camera's commands (:data:`CAMERA_COMMANDS`)."""
        events: list[PayloadEvent] = []
        if command in (MAV_CMD_DO_DIGICAM_CONFIGURE, MAV_CMD_DO_DIGICAM_CONTROL):
            if command == MAV_CMD_DO_DIGICAM_CONTROL and p[4] == 1.0 and self.camera(params):
                events.append(self._picture(here_ne, "DO_DIGICAM_CONTROL"))
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_DO_SET_CAM_TRIGG_DIST:
            if self.camera(params):
                self.trigger_distance_m = max(0.0, p[0])
                self.last_picture_ne = here_ne
                if p[2] == 1.0:
                    events.append(self._picture(here_ne, "DO_SET_CAM_TRIGG_DIST"))
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_IMAGE_START_CAPTURE:
            if p[0] < 0:
                return MAV_RESULT_UNSUPPORTED, events  # is_negative(param1)
            if not self.camera(params):
                return MAV_RESULT_FAILED, events
            events.append(self._picture(here_ne, "IMAGE_START_CAPTURE"))
            return MAV_RESULT_ACCEPTED, events
        if command == MAV_CMD_IMAGE_STOP_CAPTURE:
            self.trigger_distance_m = 0.0
            return MAV_RESULT_ACCEPTED, events
        raise ValueError(f"not a camera command: {command}")

    @staticmethod
    def camera(params: ParamStore) -> bool:
        return params.get_int("CAM1_TYPE") != 0

    def _picture(self, here_ne: tuple[float, float], why: str) -> PayloadEvent:
        self.pictures += 1
        self.last_picture_ne = here_ne
        return PayloadEvent(
            "picture",
            {"count": self.pictures, "north_m": here_ne[0], "east_m": here_ne[1], "by": why},
        )

    # -- time --------------------------------------------------------------------------------

    def update(
        self,
        now_s: float,
        params: ParamStore,
        outputs: ServoOutputs,
        here_ne: tuple[float, float],
    ) -> list[PayloadEvent]:
        """AP_ServoRelayEvents::update_events and the camera's distance trigger."""
        events: list[PayloadEvent] = []
        r = self.repeat
        while r is not None and r.remaining > 0 and now_s >= r.next_s:
            r.next_s += max(r.half_period_s, 1e-3)
            if r.servo:
                value = (
                    r.value_us if r.remaining % 2 == 0 else params.get_int(f"SERVO{r.channel}_TRIM")
                )
                outputs.latch(r.channel, value)
                events.append(PayloadEvent("servo_repeat", {"channel": r.channel, "pwm_us": value}))
            else:
                on = self._toggle(r.channel)
                events.append(PayloadEvent("relay", {"relay": r.channel, "on": on}))
            r.remaining -= 1
        if r is not None and r.remaining <= 0:
            self.repeat = None
        last = self.last_picture_ne
        if (
            self.trigger_distance_m > 0.0
            and last is not None
            and math.dist(here_ne, last) >= self.trigger_distance_m
        ):
            events.append(self._picture(here_ne, "distance"))
        return events


__all__ = ["NUM_RELAYS", "PAYLOAD_COMMANDS", "Payload", "PayloadEvent"]
