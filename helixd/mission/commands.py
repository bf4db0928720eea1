"""ArduPilot Rover's mission commands: what each one is, what its parameters mean, and what
Rover's AUTO does with it. Pure data and lookups; no I/O.

Written from ArduPilot's source (the behaviour to copy, not a guess):

* ``libraries/AP_Mission/AP_Mission.cpp``: ``is_nav_cmd`` (ids up to MAV_CMD_NAV_LAST = 95,
  plus NAV_SET_YAW_SPEED, NAV_SCRIPT_TIME, NAV_ATTITUDE_TIME), ``stored_in_location`` (which
  commands carry a place), ``mavlink_int_to_mission_cmd`` (what a mission may hold at all —
  anything else is refused at upload with MAV_MISSION_UNSUPPORTED — and how parameters are
  stored: a waypoint's hold time in whole seconds 0..65535, a loiter's turns and radius), and
  ``start_command`` (the servo/relay/camera/gripper/sprayer/fence commands it runs itself);
* ``Rover/mode_auto.cpp``: ``start_command`` / ``verify_command``. A navigation command it does
  not start (NAV_TAKEOFF, NAV_LAND, altitude-only items, splines) is passed over; a do command
  it does not know is dropped with "Skipping invalid cmd #<id>".

Each command has a :class:`Role` (what helixd does with it, following Rover), and its
parameters have names with units for the YAML mission format (``hold_s``, ``speed_mps``,
``channel``, …; ``params: [p1, p2, …]`` is accepted for any command).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from helixd.mav.constants import (
    MAV_CMD_CONDITION_DELAY,
    MAV_CMD_CONDITION_DISTANCE,
    MAV_CMD_CONDITION_YAW,
    MAV_CMD_DO_AUTOTUNE_ENABLE,
    MAV_CMD_DO_AUX_FUNCTION,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_DIGICAM_CONFIGURE,
    MAV_CMD_DO_DIGICAM_CONTROL,
    MAV_CMD_DO_ENGINE_CONTROL,
    MAV_CMD_DO_FENCE_ENABLE,
    MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
    MAV_CMD_DO_GO_AROUND,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_GUIDED_LIMITS,
    MAV_CMD_DO_INVERTED_FLIGHT,
    MAV_CMD_DO_JUMP,
    MAV_CMD_DO_JUMP_TAG,
    MAV_CMD_DO_LAND_START,
    MAV_CMD_DO_MOUNT_CONTROL,
    MAV_CMD_DO_PARACHUTE,
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_DO_REPEAT_RELAY,
    MAV_CMD_DO_REPEAT_SERVO,
    MAV_CMD_DO_RETURN_PATH_START,
    MAV_CMD_DO_SEND_SCRIPT_MESSAGE,
    MAV_CMD_DO_SET_CAM_TRIGG_DIST,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_RELAY,
    MAV_CMD_DO_SET_RESUME_REPEAT_DIST,
    MAV_CMD_DO_SET_REVERSE,
    MAV_CMD_DO_SET_ROI,
    MAV_CMD_DO_SET_ROI_LOCATION,
    MAV_CMD_DO_SET_ROI_NONE,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_DO_SPRAYER,
    MAV_CMD_DO_VTOL_TRANSITION,
    MAV_CMD_DO_WINCH,
    MAV_CMD_IMAGE_START_CAPTURE,
    MAV_CMD_IMAGE_STOP_CAPTURE,
    MAV_CMD_JUMP_TAG,
    MAV_CMD_NAMES,
    MAV_CMD_NAV_ALTITUDE_WAIT,
    MAV_CMD_NAV_ARC_WAYPOINT,
    MAV_CMD_NAV_ATTITUDE_TIME,
    MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT,
    MAV_CMD_NAV_DELAY,
    MAV_CMD_NAV_GUIDED_ENABLE,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LAST,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_LOITER_TO_ALT,
    MAV_CMD_NAV_LOITER_TURNS,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_PAYLOAD_PLACE,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_SCRIPT_TIME,
    MAV_CMD_NAV_SET_YAW_SPEED,
    MAV_CMD_NAV_SPLINE_WAYPOINT,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_VTOL_LAND,
    MAV_CMD_NAV_VTOL_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_CMD_SET_CAMERA_FOCUS,
    MAV_CMD_SET_CAMERA_SOURCE,
    MAV_CMD_SET_CAMERA_ZOOM,
    MAV_CMD_VIDEO_START_CAPTURE,
    MAV_CMD_VIDEO_STOP_CAPTURE,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_MISSION,
)
from helixd.mav.mission_item import PLACE_COMMANDS

MAX_PARAMS = 6  # param1..param6 of a command without a place (param5/6 are x/y then)
HOLD_MAX_S = 65535.0  # AP_Mission stores a waypoint's hold in a uint16 of whole seconds
SPEED_MIN_MPS = 0.05  # AR_WPNav::set_speed_max refuses slower (AR_WPNAV_SPEED_MIN)
CIRCLE_RADIUS_MIN_M = 0.1  # Rover/mode_circle.cpp AR_CIRCLE_RADIUS_MIN
JUMP_FOREVER = -1  # AP_MISSION_JUMP_REPEAT_FOREVER


def speed_refused(asked_mps: float) -> bool:
    """A change of speed Rover refuses (not finite, or under :data:`SPEED_MIN_MPS`): nothing
    changes."""
    return not (math.isfinite(asked_mps) and asked_mps >= SPEED_MIN_MPS)


def speed_floor_mps(min_speed_mps: float) -> float:
    """The lowest speed a change of speed sets: control.min_speed_mps, and Rover's 0.05 m/s."""
    return max(min_speed_mps, SPEED_MIN_MPS)


def bound_speed(asked_mps: float, lo_mps: float, hi_mps: float) -> tuple[float, str]:
    """A change of speed within ``[lo_mps, hi_mps]``: the speed, and which bound set it
    (``"low"``, ``"high"``, or ``""`` when none). Non-finite: the low bound (itself at most
    ``hi_mps``)."""
    if not math.isfinite(asked_mps) or asked_mps < lo_mps:
        return min(lo_mps, hi_mps), "low"
    if asked_mps > hi_mps:
        return hi_mps, "high"
    return asked_mps, ""


class Role(StrEnum):
    """What ArduPilot Rover's AUTO does with a command, and so what helixd does."""

    WAYPOINT = "waypoint"  # go there (lat/lon 0,0: stay where the item starts), hold param1 s
    LOITER_TIME = "loiter_time"  # go there, stop, wait param1 s
    LOITER_TURNS = "loiter_turns"  # drive param1 circles of radius param3 around the place
    LOITER_UNLIM = "loiter_unlim"  # go there and wait until the operator continues
    RETURN = "return"  # drive to home
    NAV_DELAY = "nav_delay"  # stop and wait param1 s
    NAV_SKIPPED = "nav_skipped"  # a navigation command Rover does not start: passed over
    NAV_REFUSED = "nav_refused"  # Rover runs it, helixd cannot (it hands navigation away)
    CONDITION_DELAY = "condition_delay"  # the do items after it wait param1 s
    CONDITION_DISTANCE = "condition_distance"  # … until within param1 m of the next waypoint
    SPEED = "speed"  # DO_CHANGE_SPEED: param2 m/s from here on
    REVERSE = "reverse"  # DO_SET_REVERSE: drive backwards (param1 = 1) or forwards
    JUMP = "jump"  # DO_JUMP / DO_JUMP_TAG: resolved when the mission is expanded
    TAG = "tag"  # JUMP_TAG: a place a DO_JUMP_TAG jumps to
    SEND = "send"  # the autopilot runs it (servo, relay, camera, …): sent as COMMAND_LONG
    SET_HOME = "set_home"  # DO_SET_HOME: sent, and later returns go to the new home
    IGNORED = "ignored"  # Rover accepts it; it changes nothing on this rover (no mount, …)
    DO_SKIPPED = "do_skipped"  # Rover drops it: "Skipping invalid cmd"
    DO_REFUSED = "do_refused"  # Rover runs it, helixd cannot pass it on
    UNKNOWN = "unknown"  # ArduPilot refuses it in a mission (MAV_MISSION_UNSUPPORTED)


@dataclass(frozen=True, slots=True)
class ParamSpec:
    """One named parameter of a command in the YAML format."""

    name: str
    lo: float
    hi: float
    whole: bool = False  # ArduPilot stores it as an integer
    default: float | None = 0.0  # None: "unset" (NaN), as QGroundControl writes it
    help: str = ""


@dataclass(frozen=True, slots=True)
class CommandSpec:
    number: int
    role: Role
    params: tuple[ParamSpec | None, ...] = ()  # param1.. (None: not used)
    why: str = ""  # for skipped/ignored/refused commands: the reason, for the operator

    @property
    def name(self) -> str:
        return command_name(self.number)

    @property
    def has_place(self) -> bool:
        """AP_Mission::stored_in_location: x/y are a latitude/longitude."""
        return self.number in PLACE_COMMANDS

    @property
    def nav(self) -> bool:
        return is_nav(self.number)

    def param(self, name: str) -> tuple[int, ParamSpec] | None:
        for i, spec in enumerate(self.params):
            if spec is not None and spec.name == name:
                return i, spec
        return None

    def defaults(self) -> tuple[float | None, ...]:
        size = 4 if self.has_place else MAX_PARAMS
        out: list[float | None] = [0.0] * size
        for i, spec in enumerate(self.params[:size]):
            if spec is not None:
                out[i] = spec.default
        return tuple(out)

    def default_frame(self) -> int:
        return MAV_FRAME_GLOBAL_RELATIVE_ALT if self.has_place else MAV_FRAME_MISSION


def _p(name: str, lo: float, hi: float, *, whole: bool = False, default: float | None = 0.0,
       help: str = "") -> ParamSpec:  # fmt: skip
    return ParamSpec(name, lo, hi, whole, default, help)


BIG = 1e7
_HOLD = _p("hold_s", 0.0, HOLD_MAX_S, help="seconds stopped at the place (whole seconds)")
_YAW = _p("yaw_deg", -360.0, 360.0, default=None, help="yaw (ignored by a rover)")
_RADIUS = _p("radius_m", -BIG, BIG, help="loiter radius (m; negative: counter-clockwise)")
_CHANNEL = _p("channel", 1, 32, whole=True, help="servo output number")
_PWM = _p("pwm_us", 0, 3000, whole=True, help="output pulse width (µs)")
_RELAY = _p("relay", 0, 15, whole=True, help="relay instance (0 = RELAY1)")
_COUNT = _p("count", 0, 32767, whole=True, help="number of cycles")
_PERIOD = _p("period_s", 0.0, 3600.0, help="cycle time (s)")
_CAMERA = _p("camera", 0, 255, whole=True, help="camera id (0 = all)")

_COMMANDS: tuple[CommandSpec, ...] = (
    CommandSpec(MAV_CMD_NAV_WAYPOINT, Role.WAYPOINT, (
        _HOLD, _p("accept_radius_m", 0.0, BIG), _p("pass_radius_m", -BIG, BIG), _YAW)),
    CommandSpec(MAV_CMD_NAV_LOITER_UNLIM, Role.LOITER_UNLIM, (None, None, _RADIUS, _YAW)),
    CommandSpec(MAV_CMD_NAV_LOITER_TURNS, Role.LOITER_TURNS, (
        _p("turns", 0.0, 255.0, help="circles to drive"), _p("heading_required", 0, 1),
        _RADIUS, _p("xtrack_exit", -BIG, BIG))),
    CommandSpec(MAV_CMD_NAV_LOITER_TIME, Role.LOITER_TIME, (
        _HOLD, _p("heading_required", 0, 1), _RADIUS, _p("xtrack_exit", -BIG, BIG))),
    CommandSpec(MAV_CMD_NAV_RETURN_TO_LAUNCH, Role.RETURN),
    CommandSpec(MAV_CMD_NAV_LAND, Role.NAV_SKIPPED, (
        _p("abort_alt_m", -BIG, BIG), _p("land_mode", 0, 2), None, _YAW),
        why="a rover does not land"),
    CommandSpec(MAV_CMD_NAV_TAKEOFF, Role.NAV_SKIPPED, (
        _p("pitch_deg", -90.0, 90.0), None, None, _YAW), why="a rover does not take off"),
    CommandSpec(MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT, Role.NAV_SKIPPED, why="altitude only"),
    CommandSpec(MAV_CMD_NAV_LOITER_TO_ALT, Role.NAV_SKIPPED, why="altitude only"),
    CommandSpec(MAV_CMD_NAV_ALTITUDE_WAIT, Role.NAV_SKIPPED, why="altitude only"),
    CommandSpec(MAV_CMD_NAV_ARC_WAYPOINT, Role.NAV_SKIPPED, why="arcs are for planes"),
    CommandSpec(MAV_CMD_NAV_SPLINE_WAYPOINT, Role.NAV_SKIPPED, why="Rover flies no splines"),
    CommandSpec(MAV_CMD_NAV_VTOL_TAKEOFF, Role.NAV_SKIPPED, why="a rover does not take off"),
    CommandSpec(MAV_CMD_NAV_VTOL_LAND, Role.NAV_SKIPPED, why="a rover does not land"),
    CommandSpec(MAV_CMD_NAV_PAYLOAD_PLACE, Role.NAV_SKIPPED, why="a copter's descent"),
    CommandSpec(MAV_CMD_NAV_ATTITUDE_TIME, Role.NAV_SKIPPED, why="Rover does not run it"),
    CommandSpec(MAV_CMD_NAV_GUIDED_ENABLE, Role.NAV_REFUSED, (
        _p("enable", 0, 1), None, None, None),
        why="it hands navigation to an offboard computer; helixd is the one navigating"),
    CommandSpec(MAV_CMD_NAV_SET_YAW_SPEED, Role.NAV_REFUSED,
                why="a heading and a speed with no place to go: helixd flies to places"),
    CommandSpec(MAV_CMD_NAV_SCRIPT_TIME, Role.NAV_REFUSED,
                why="it hands navigation to a Lua script on the autopilot"),
    CommandSpec(MAV_CMD_NAV_DELAY, Role.NAV_DELAY, (
        _p("delay_s", -1.0, 86400.0, help="seconds stopped (-1: until hour:minute:second)"),
        _p("hour", -1, 23, whole=True), _p("minute", -1, 59, whole=True),
        _p("second", -1, 59, whole=True))),
    CommandSpec(MAV_CMD_CONDITION_DELAY, Role.CONDITION_DELAY, (
        _p("delay_s", 0.0, 86400.0, help="the items after it start this much later (s)"),)),
    CommandSpec(MAV_CMD_CONDITION_DISTANCE, Role.CONDITION_DISTANCE, (
        _p("distance_m", 0.0, BIG, help="… once this close to the next waypoint (m)"),)),
    CommandSpec(MAV_CMD_CONDITION_YAW, Role.DO_SKIPPED, why="Rover does not run it"),
    CommandSpec(MAV_CMD_DO_JUMP, Role.JUMP, (
        _p("item", 0, 65535, whole=True, help="mission item to jump to"),
        _p("repeat", -1, 32767, whole=True, help="times the jump is taken (-1: forever)"))),
    CommandSpec(MAV_CMD_DO_JUMP_TAG, Role.JUMP, (
        _p("tag", 0, 65535, whole=True), _p("repeat", -1, 32767, whole=True))),
    CommandSpec(MAV_CMD_JUMP_TAG, Role.TAG, (_p("tag", 0, 65535, whole=True),)),
    CommandSpec(MAV_CMD_DO_CHANGE_SPEED, Role.SPEED, (
        _p("speed_type", 0, 3, whole=True), _p("speed_mps", -1.0, 100.0,
        help="cruise speed from here on (m/s; -1: no change)"), _p("throttle_pct", -2, 100))),
    CommandSpec(MAV_CMD_DO_SET_HOME, Role.SET_HOME, (
        _p("use_current", 0, 1, whole=True, help="1: home where the rover is"),)),
    CommandSpec(MAV_CMD_DO_SET_REVERSE, Role.REVERSE, (
        _p("reverse", 0, 1, whole=True, help="1: drive backwards, 0: forwards"),)),
    CommandSpec(MAV_CMD_DO_SET_RELAY, Role.SEND, (
        _RELAY, _p("state", 0, 2, whole=True, help="0 off, 1 on, 2 toggle"))),
    CommandSpec(MAV_CMD_DO_REPEAT_RELAY, Role.SEND, (_RELAY, _COUNT, _PERIOD)),
    CommandSpec(MAV_CMD_DO_SET_SERVO, Role.SEND, (_CHANNEL, _PWM)),
    CommandSpec(MAV_CMD_DO_REPEAT_SERVO, Role.SEND, (_CHANNEL, _PWM, _COUNT, _PERIOD)),
    CommandSpec(MAV_CMD_DO_DIGICAM_CONFIGURE, Role.SEND),
    CommandSpec(MAV_CMD_DO_DIGICAM_CONTROL, Role.SEND, (
        _p("session", -BIG, BIG), _p("zoom_pos", -BIG, BIG), _p("zoom_step", -BIG, BIG),
        _p("focus_lock", -BIG, BIG), _p("shoot", -BIG, BIG), _p("command_id", -BIG, BIG))),
    CommandSpec(MAV_CMD_DO_SET_CAM_TRIGG_DIST, Role.SEND, (
        _p("distance_m", 0.0, BIG, help="picture every this many metres (0: stop)"),
        _p("shutter", -1, BIG), _p("trigger_once", 0, 1, whole=True))),
    CommandSpec(MAV_CMD_IMAGE_START_CAPTURE, Role.SEND, (
        _CAMERA, _p("interval_s", 0.0, BIG), _p("count", 0, BIG, whole=True),
        _p("sequence", 0, BIG, whole=True))),
    CommandSpec(MAV_CMD_IMAGE_STOP_CAPTURE, Role.SEND, (_CAMERA,)),
    CommandSpec(MAV_CMD_VIDEO_START_CAPTURE, Role.SEND),
    CommandSpec(MAV_CMD_VIDEO_STOP_CAPTURE, Role.SEND),
    CommandSpec(MAV_CMD_SET_CAMERA_ZOOM, Role.SEND),
    CommandSpec(MAV_CMD_SET_CAMERA_FOCUS, Role.SEND),
    CommandSpec(MAV_CMD_SET_CAMERA_SOURCE, Role.SEND),
    CommandSpec(MAV_CMD_DO_GRIPPER, Role.SEND, (
        _p("gripper", 0, 255, whole=True), _p("action", 0, 1, whole=True,
        help="0 release, 1 grab"))),
    CommandSpec(MAV_CMD_DO_SPRAYER, Role.SEND, (_p("enable", 0, 1, whole=True),)),
    CommandSpec(MAV_CMD_DO_AUX_FUNCTION, Role.SEND, (
        _p("function", 0, 65535, whole=True), _p("switch", 0, 2, whole=True))),
    CommandSpec(MAV_CMD_DO_FENCE_ENABLE, Role.SEND, (_p("enable", 0, 2, whole=True),)),
    CommandSpec(MAV_CMD_DO_GUIDED_LIMITS, Role.IGNORED, (
        _p("timeout_s", 0.0, BIG), _p("min_alt_m", -BIG, BIG), _p("max_alt_m", -BIG, BIG),
        _p("horiz_max_m", 0.0, BIG)), why="limits for GUIDED, which helixd never uses"),
    CommandSpec(MAV_CMD_DO_SET_ROI, Role.IGNORED, why="points a camera mount; the Helix has none"),
    CommandSpec(MAV_CMD_DO_SET_ROI_LOCATION, Role.IGNORED,
                why="points a camera mount; the Helix has none"),
    CommandSpec(MAV_CMD_DO_SET_ROI_NONE, Role.IGNORED,
                why="points a camera mount; the Helix has none"),
    CommandSpec(MAV_CMD_DO_SET_RESUME_REPEAT_DIST, Role.IGNORED,
                why="ArduPilot's own mission-resume rewind; helixd resumes runs itself"),
    CommandSpec(MAV_CMD_DO_MOUNT_CONTROL, Role.DO_SKIPPED, why="mount control"),
    CommandSpec(MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, Role.DO_SKIPPED, why="mount control"),
    CommandSpec(MAV_CMD_DO_PARACHUTE, Role.DO_SKIPPED, why="Rover has no parachute"),
    CommandSpec(MAV_CMD_DO_LAND_START, Role.DO_SKIPPED, why="a landing marker"),
    CommandSpec(MAV_CMD_DO_RETURN_PATH_START, Role.DO_SKIPPED, why="a plane's return path"),
    CommandSpec(MAV_CMD_DO_GO_AROUND, Role.DO_SKIPPED, why="an aborted landing"),
    CommandSpec(MAV_CMD_DO_VTOL_TRANSITION, Role.DO_SKIPPED, why="a VTOL transition"),
    CommandSpec(MAV_CMD_DO_ENGINE_CONTROL, Role.DO_SKIPPED, why="Rover does not run it"),
    CommandSpec(MAV_CMD_DO_INVERTED_FLIGHT, Role.DO_SKIPPED, why="a plane's"),
    CommandSpec(MAV_CMD_DO_AUTOTUNE_ENABLE, Role.DO_SKIPPED, why="a plane's autotune"),
    CommandSpec(MAV_CMD_DO_WINCH, Role.DO_SKIPPED, why="Rover does not run it"),
    CommandSpec(MAV_CMD_DO_PAUSE_CONTINUE, Role.DO_SKIPPED, why="Rover does not run it"),
    CommandSpec(MAV_CMD_DO_SEND_SCRIPT_MESSAGE, Role.DO_REFUSED,
                why="a message for the autopilot's Lua scripts, which only a mission can send"),
)  # fmt: skip

COMMANDS: dict[int, CommandSpec] = {c.number: c for c in _COMMANDS}

# The commands a helixd waypoint list flies to (a place, a route): what ``points()`` lists
FLY_ROLES = frozenset({Role.WAYPOINT, Role.LOITER_TIME, Role.LOITER_TURNS, Role.LOITER_UNLIM})
# Skipped or ignored, as ArduPilot Rover does: listed by ``check``, refused with --strict
SKIP_ROLES = frozenset({Role.NAV_SKIPPED, Role.DO_SKIPPED, Role.IGNORED})
REFUSED_ROLES = frozenset({Role.NAV_REFUSED, Role.DO_REFUSED, Role.UNKNOWN})
SERVO_COMMANDS = frozenset({MAV_CMD_DO_SET_SERVO, MAV_CMD_DO_REPEAT_SERVO})


def command_name(number: int) -> str:
    """The dialect's name without MAV_CMD_ (e.g. "DO_SET_SERVO"), or "command N"."""
    name = MAV_CMD_NAMES.get(number)
    return name if name is not None else f"command {number}"


_BY_NAME = {command_name(n): n for n in COMMANDS}


def command_spec(number: int) -> CommandSpec:
    """The command's spec; a command ArduPilot does not take in a mission is UNKNOWN."""
    spec = COMMANDS.get(number)
    if spec is None:
        why = "ArduPilot refuses it in a mission (MAV_MISSION_UNSUPPORTED)"
        return CommandSpec(number, Role.UNKNOWN, why=why)
    return spec


def command_number(value: object) -> int:
    """A command given by name ("DO_SET_SERVO", "MAV_CMD_DO_SET_SERVO", any case) or number;
    ValueError naming the problem."""
    if isinstance(value, bool):
        raise ValueError("command: true/false is not a command")
    if isinstance(value, int):
        if not 0 <= value <= 65535:
            raise ValueError(f"command: {value} is not a MAV_CMD number (0..65535)")
        return value
    if isinstance(value, str):
        key = value.strip().upper().removeprefix("MAV_CMD_")
        number = _BY_NAME.get(key)
        if number is None:
            for n, name in MAV_CMD_NAMES.items():
                if name == key:
                    return n
            raise ValueError(
                f"command: {value[:40]!r} is not a MAVLink command name (e.g. NAV_WAYPOINT, "
                "DO_CHANGE_SPEED, DO_SET_SERVO, DO_JUMP, NAV_RETURN_TO_LAUNCH)"
            )
        return number
    raise ValueError(f"command: expected a name or a number, got {type(value).__name__}")


def is_nav(number: int) -> bool:
    """AP_Mission::is_nav_cmd."""
    return number <= MAV_CMD_NAV_LAST or number in (
        MAV_CMD_NAV_SET_YAW_SPEED,
        MAV_CMD_NAV_SCRIPT_TIME,
        MAV_CMD_NAV_ATTITUDE_TIME,
    )


def stored_whole(value: float) -> int:
    """A float parameter as AP_Mission keeps it in an integer field (truncated toward 0)."""
    return int(value) if math.isfinite(value) else 0


__all__ = [
    "CIRCLE_RADIUS_MIN_M",
    "COMMANDS",
    "FLY_ROLES",
    "HOLD_MAX_S",
    "JUMP_FOREVER",
    "MAX_PARAMS",
    "REFUSED_ROLES",
    "SERVO_COMMANDS",
    "SKIP_ROLES",
    "SPEED_MIN_MPS",
    "CommandSpec",
    "ParamSpec",
    "Role",
    "command_name",
    "command_number",
    "command_spec",
    "is_nav",
    "stored_whole",
]
