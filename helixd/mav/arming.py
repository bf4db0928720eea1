"""ArduPilot Rover's PreArm check on the motor outputs, from SERVOn_FUNCTION values (pure).

``AP_MotorsUGV::pre_arm_check`` (libraries/AR_Motors/AP_MotorsUGV.cpp), called by
``AP_Arming_Rover::motor_checks`` on every arm that is not forced (param2 21196) — whatever
ARMING_SKIPCHK (ARMING_CHECK on older firmware) says, unless that skips *all* checks. It
counts an output function as "assigned" when any SERVOn_FUNCTION holds it
(``SRV_Channels::function_assigned``), connected or not, and refuses, in this order:

1. none of Throttle (70), ThrottleLeft (73), ThrottleRight (74), GroundSteering (26),
   Script1 (94), a sail (MainSail 89, WingSailElevator 128, MastRotation 137) nor an omni
   frame (FRAME_TYPE 1..4) → "PreArm: no motor, sail or scripting outputs defined";
2. only one of ThrottleLeft/ThrottleRight → "PreArm: check skid steering config";
3. (a sail or Throttle) without GroundSteering, or GroundSteering without either →
   "PreArm: check steering and throttle config";
4. an omni frame with one of its motor functions (Motor1.. = 33..) missing →
   "PreArm: servo function <f> unassigned".

RC passthrough (51..66, 1) and function 0 count as nothing, so a Helix whose four scroll
outputs are passthrough (or function 0 for DO_SET_SERVO) has "no motor outputs". The Helix
setup: one spare, unconnected output with SERVOn_FUNCTION = 94 (Script1). No script drives
it (helixd-guard.lua only touches the HXG_CHANn outputs by number): ArduPilot gives it its
idle value only (Script1 is an angle output, 0 → SERVOn_TRIM; SITL reports output 16 as 0, no
pulses), and ``AP_Arming::servo_checks`` lets a
scripting function sit on a disabled channel. Every other PreArm check is still made.

The relay check for MOT_PWM_TYPE 5 (brushed with relay) is not modelled: a Helix's scroll
motor controllers are not ArduPilot's motors.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

K_STEERING = 26
K_MOTOR1 = 33
K_THROTTLE = 70
K_THROTTLE_LEFT = 73
K_THROTTLE_RIGHT = 74
K_MAINSAIL_SHEET = 89
K_SCRIPTING1 = 94
K_WINGSAIL_ELEVATOR = 128
K_MAST_ROTATION = 137
SAIL_FUNCTIONS = frozenset({K_MAINSAIL_SHEET, K_WINGSAIL_ELEVATOR, K_MAST_ROTATION})
# AP_MotorsUGV::setup_omni: FRAME_TYPE → number of omni motors (0 = not omni)
OMNI_MOTORS = {1: 3, 2: 4, 3: 4, 4: 3}

NO_OUTPUTS_TEXT = "no motor, sail or scripting outputs defined"
SKID_TEXT = "check skid steering config"
STEERING_THROTTLE_TEXT = "check steering and throttle config"
PREARM_PREFIX = "PreArm: "
FORCE_ARM_MAGIC = 21196  # COMPONENT_ARM_DISARM param2: arm without the PreArm checks


def motor_prearm_failure(functions: Mapping[int, int], frame_type: int = 0) -> str | None:
    """The text (without "PreArm: ") AP_MotorsUGV::pre_arm_check refuses with, or None.

    ``functions``: output number → SERVOn_FUNCTION; ``frame_type``: FRAME_TYPE.
    """
    assigned = set(functions.values())
    motors = OMNI_MOTORS.get(frame_type, 0)
    has_sail = bool(assigned & SAIL_FUNCTIONS)
    left = K_THROTTLE_LEFT in assigned
    right = K_THROTTLE_RIGHT in assigned
    throttle = K_THROTTLE in assigned
    steering = K_STEERING in assigned
    if not (
        left or right or throttle or steering or K_SCRIPTING1 in assigned or has_sail or motors
    ):
        return NO_OUTPUTS_TEXT
    if left != right:
        return SKID_TEXT
    if (has_sail or throttle) != steering:
        return STEERING_THROTTLE_TEXT
    for i in range(motors):
        if K_MOTOR1 + i not in assigned:
            return f"servo function {K_MOTOR1 + i} unassigned"
    return None


def servo_functions(params: Mapping[str, float | None]) -> dict[int, int]:
    """Output number → SERVOn_FUNCTION, for every SERVOn_FUNCTION in ``params`` with a value."""
    out: dict[int, int] = {}
    for name, value in params.items():
        if value is None or not name.startswith("SERVO") or not name.endswith("_FUNCTION"):
            continue
        number = name[len("SERVO") : -len("_FUNCTION")]
        if number.isdigit():
            out[int(number)] = round(value)
    return out


# AP_Arming::rc_arm_checks (made on every arm that is not forced, once a receiver has sent in
# the last second): "Arm: Throttle (RCn) is not neutral" unless the throttle channel's control
# input is 0. Rover's throttle (RCMAP_THROTTLE) is an angle channel (Rover/radio.cpp
# set_angle(100)), so its input is 0 when RCn reads within RCn_TRIM ± RCn_DZ
# (RC_Channel::pwm_to_angle_dz_trim; Rover's default dead zone there is 30 µs).
ARM_PREFIX = "Arm: "
THROTTLE_NOT_NEUTRAL = re.compile(r"Throttle \(RC(\d+)\) is not neutral")


def not_neutral_channel(text: str | None) -> int | None:
    """The RC channel of an "Arm: Throttle (RCn) is not neutral" refusal, else None."""
    found = THROTTLE_NOT_NEUTRAL.search(text or "")
    return None if found is None else int(found.group(1))


def throttle_neutral(reading_us: int, trim_us: int, dz_us: int) -> bool:
    """Does the throttle channel's reading let ArduPilot arm (within RCn_TRIM ± RCn_DZ)?"""
    return abs(reading_us - trim_us) <= dz_us


def rc_reading(rc_inputs_us: Sequence[int], channel: int) -> int | None:
    """RCn's last RC_CHANNELS value (µs), None when not reported (0 or missing)."""
    if not 1 <= channel <= len(rc_inputs_us):
        return None
    value = int(rc_inputs_us[channel - 1])
    return value if value > 0 else None


def throttle_must_read(
    channel: int, trim_us: float | None, dz_us: float | None, reading_us: int | None
) -> str:
    """What the throttle channel must read to arm, and what it reads (pure)."""
    n = channel
    if trim_us is None:
        need = f"RC{n} (RCMAP_THROTTLE) must read its trim RC{n}_TRIM ± RC{n}_DZ to arm"
    else:
        trim, dz = round(trim_us), round(dz_us or 0)
        need = (
            f"RC{n} (RCMAP_THROTTLE) must read its trim RC{n}_TRIM = {trim} µs ± RC{n}_DZ = "
            f"{dz} µs ({trim - dz}–{trim + dz} µs) to arm"
        )
    if reading_us is None:
        return f"{need}: put the stick or switch on RC{n} where it reads that (centred)"
    if trim_us is not None and throttle_neutral(reading_us, round(trim_us), round(dz_us or 0)):
        return f"{need}; it reads {reading_us} µs"
    return (
        f"{need}; it reads {reading_us} µs — put the stick or switch on RC{n} where it reads "
        f"its trim (a 3-position switch in its middle position), or set RC{n}_TRIM to the "
        f"value RC{n} rests at"
    )
