"""MAVLink constants, taken from pymavlink's ``ardupilotmega`` dialect: the one place they are
defined (the link, the vehicle state, the actuators and the simulator import them from here
instead of copying numbers by hand).

A leaf module: it imports only pymavlink's dialect (no asyncio, sockets or helixd modules), so
the simulator can use it without loading the daemon's link.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as _mav

UINT16_MAX = 0xFFFF  # "not sent" / "leave unchanged" in several uint16 fields (MAVLink spec)

# MAV_RESULT (COMMAND_ACK.result)
MAV_RESULT_ACCEPTED = int(_mav.MAV_RESULT_ACCEPTED)
MAV_RESULT_TEMPORARILY_REJECTED = int(_mav.MAV_RESULT_TEMPORARILY_REJECTED)
MAV_RESULT_DENIED = int(_mav.MAV_RESULT_DENIED)
MAV_RESULT_UNSUPPORTED = int(_mav.MAV_RESULT_UNSUPPORTED)
MAV_RESULT_FAILED = int(_mav.MAV_RESULT_FAILED)
MAV_RESULT_IN_PROGRESS = int(_mav.MAV_RESULT_IN_PROGRESS)

# MAV_CMD
MAV_CMD_DO_SET_MODE = int(_mav.MAV_CMD_DO_SET_MODE)
MAV_CMD_DO_SET_SERVO = int(_mav.MAV_CMD_DO_SET_SERVO)
MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN = int(_mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN)
MAV_CMD_COMPONENT_ARM_DISARM = int(_mav.MAV_CMD_COMPONENT_ARM_DISARM)
MAV_CMD_GET_MESSAGE_INTERVAL = int(_mav.MAV_CMD_GET_MESSAGE_INTERVAL)
MAV_CMD_SET_MESSAGE_INTERVAL = int(_mav.MAV_CMD_SET_MESSAGE_INTERVAL)
MAV_CMD_REQUEST_MESSAGE = int(_mav.MAV_CMD_REQUEST_MESSAGE)
MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES = int(_mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES)

# HEARTBEAT
MAV_TYPE_GROUND_ROVER = int(_mav.MAV_TYPE_GROUND_ROVER)
MAV_AUTOPILOT_ARDUPILOTMEGA = int(_mav.MAV_AUTOPILOT_ARDUPILOTMEGA)
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = int(_mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)
MAV_MODE_FLAG_GUIDED_ENABLED = int(_mav.MAV_MODE_FLAG_GUIDED_ENABLED)
MAV_MODE_FLAG_MANUAL_INPUT_ENABLED = int(_mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)
MAV_MODE_FLAG_SAFETY_ARMED = int(_mav.MAV_MODE_FLAG_SAFETY_ARMED)
MAV_STATE_BOOT = int(_mav.MAV_STATE_BOOT)
MAV_STATE_CALIBRATING = int(_mav.MAV_STATE_CALIBRATING)
MAV_STATE_STANDBY = int(_mav.MAV_STATE_STANDBY)
MAV_STATE_ACTIVE = int(_mav.MAV_STATE_ACTIVE)
MAV_STATE_CRITICAL = int(_mav.MAV_STATE_CRITICAL)

# ArduPilot Rover custom modes (Rover/mode.h), from the dialect's ROVER_MODE enum; names as
# ArduPilot's Mode::name4/name() spell them (the dialect says INITIALIZING, Rover INITIALISING)
_ROVER_SPELLING = {"INITIALIZING": "INITIALISING"}
ROVER_MODES: dict[int, str] = {
    int(number): _ROVER_SPELLING.get(
        entry.name.removeprefix("ROVER_MODE_"), entry.name.removeprefix("ROVER_MODE_")
    )
    for number, entry in _mav.enums["ROVER_MODE"].items()
    if not entry.name.endswith("_ENUM_END")
}
ROVER_MODE_NUMBERS: dict[str, int] = {name: number for number, name in ROVER_MODES.items()}
