"""ArduPilot's servo output functions (``SERVOn_FUNCTION``) that helixd reasons about, and the
ones a DO_SET_SERVO / DO_REPEAT_SERVO may move: the one place these numbers are written down
(preflight, the daemon's mission check and the simulator read them from here).

The numbers are ``SRV_Channel::Function`` (ArduPilot ``libraries/SRV_Channel/SRV_Channel.h``).
:data:`DO_SET_SERVO_FUNCTIONS` is the ``switch`` in ``AP_ServoRelayEvents::do_set_servo``
(``libraries/AP_ServoRelayEvents/AP_ServoRelayEvents.cpp``): ``k_none``, ``k_manual``,
``k_sprayer_pump``, ``k_sprayer_spinner``, ``k_gripper``, ``k_rcin1 ... k_rcin16`` (RC
passthrough) and ``k_rcin1_mapped ... k_rcin16_mapped`` (the PWM is rescaled to the channel's
±4500 angle range first) pass; every other function (``k_GPIO`` -1, scripting 94..109, the
vehicle's own motors and steering, ...) is ``default:`` → refused with STATUSTEXT
"ServoRelayEvent: Channel N is already in use" and MAV_RESULT_FAILED.
"""

from __future__ import annotations

K_NONE = 0  # k_none: general-purpose output, moved only by DO_SET_SERVO and scripts
K_MANUAL = 1  # k_manual: passes RC input n through to output n
K_SPRAYER_PUMP = 22
K_SPRAYER_SPINNER = 23
K_STEERING = 26  # k_steering (Rover)
K_GRIPPER = 28
K_RCIN1 = 51  # k_rcin1: passes RC input 1 through; RCINn = 50 + n
K_RCIN16 = 66
K_THROTTLE = 70  # k_throttle (Rover)
K_THROTTLE_LEFT = 73
K_THROTTLE_RIGHT = 74
K_RCIN1_MAPPED = 140  # k_rcin1_mapped: RC input 1 through, rescaled to ±4500
K_RCIN16_MAPPED = 155

RCIN_CHANNELS = K_RCIN16 - K_RCIN1 + 1  # RC inputs 1..16 exist for passthrough

DO_SET_SERVO_FUNCTIONS = frozenset(
    {
        K_NONE,
        K_MANUAL,
        K_SPRAYER_PUMP,
        K_SPRAYER_SPINNER,
        K_GRIPPER,
        *range(K_RCIN1, K_RCIN16 + 1),
        *range(K_RCIN1_MAPPED, K_RCIN16_MAPPED + 1),
    }
)


def rcin_function(channel: int) -> int:
    """The function that passes RC input ``channel`` (1..16) through: RCINn."""
    return K_RCIN1 - 1 + channel


def passthrough_input(function: int) -> int | None:
    """The RC input an RCINn function (51..66) passes through, or None for any other function."""
    return function - K_RCIN1 + 1 if K_RCIN1 <= function <= K_RCIN16 else None
