"""The one mission-item record, and its one conversion to and from the wire (MISSION_ITEM_INT),
checked at the edge.

Shared by the link's mission-protocol client, the ground-station file formats (.plan,
.waypoints, YAML) and the runtime. x/y are held in the item's natural unit: degrees where they
are a place (:func:`xy_in_degrees`), the raw value otherwise. They become int32 degE7 only when
encoded (:func:`wire_xy`) and come back from it only when received (:func:`item_from_message`):
a file keeps its full float precision, and an item downloaded and uploaded again is
bit-identical (int32 → /1e7 → *1e7 → round() is exact for every int32). Constants come from
pymavlink's dialect.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_GO_AROUND,
    MAV_CMD_DO_LAND_START,
    MAV_CMD_DO_RETURN_PATH_START,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_ROI,
    MAV_CMD_DO_SET_ROI_LOCATION,
    MAV_CMD_NAV_ARC_WAYPOINT,
    MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT,
    MAV_CMD_NAV_GUIDED_ENABLE,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_LOITER_TO_ALT,
    MAV_CMD_NAV_LOITER_TURNS,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_PAYLOAD_PLACE,
    MAV_CMD_NAV_SPLINE_WAYPOINT,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_VTOL_LAND,
    MAV_CMD_NAV_VTOL_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_MISSION,
    MAV_MISSION_TYPE_MISSION,
)

# AP_Mission::stored_in_location (mission commands only; fences and rally are elsewhere): the
# commands whose x/y AP_Mission::mavlink_int_to_mission_cmd reads as latitude/longitude degE7,
# whatever the frame
PLACE_COMMANDS = frozenset(
    {
        MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_UNLIM, MAV_CMD_NAV_LOITER_TURNS,
        MAV_CMD_NAV_LOITER_TIME, MAV_CMD_NAV_LAND, MAV_CMD_NAV_TAKEOFF,
        MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT, MAV_CMD_NAV_LOITER_TO_ALT,
        MAV_CMD_NAV_SPLINE_WAYPOINT, MAV_CMD_NAV_GUIDED_ENABLE, MAV_CMD_DO_SET_HOME,
        MAV_CMD_DO_RETURN_PATH_START, MAV_CMD_DO_LAND_START, MAV_CMD_DO_GO_AROUND,
        MAV_CMD_DO_SET_ROI_LOCATION, MAV_CMD_DO_SET_ROI, MAV_CMD_NAV_VTOL_TAKEOFF,
        MAV_CMD_NAV_VTOL_LAND, MAV_CMD_NAV_PAYLOAD_PLACE, MAV_CMD_NAV_ARC_WAYPOINT,
    }
)  # fmt: skip
DEG_E7 = 1e7


def mission_result_name(result: int) -> str:
    """MAV_MISSION_RESULT name (e.g. 'MAV_MISSION_NO_SPACE'), or the number if unknown."""
    entry = mavlink.enums["MAV_MISSION_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_MISSION_RESULT({result})"


@dataclass(frozen=True, slots=True)
class MissionItem:
    """One mission item as ArduPilot stores it and MISSION_ITEM_INT carries it, with x/y in the
    item's natural unit: x = latitude, y = longitude in degrees where they are a place
    (:func:`xy_in_degrees`), the raw value otherwise. ``where`` says where it came from, for
    messages (e.g. "mission.items.3"); it is not part of the item's value."""

    seq: int
    frame: int
    command: int
    current: int = 0
    autocontinue: int = 1
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    mission_type: int = MAV_MISSION_TYPE_MISSION
    where: str = field(default="", compare=False)


def xy_in_degrees(command: int, mission_type: int) -> bool:
    """Whether x/y are a latitude/longitude (degE7 on the wire): a fence or rally item's always,
    a mission item's when its command has a place."""
    return mission_type != MAV_MISSION_TYPE_MISSION or command in PLACE_COMMANDS


def _from_int(v: int, degrees: bool) -> float:
    return v / DEG_E7 if degrees else float(v)


def _to_int(v: float, degrees: bool) -> int:
    return round(v * DEG_E7) if degrees else round(v)


def wire_xy(item: MissionItem) -> tuple[int, int]:
    """x/y as MISSION_ITEM_INT carries them (int32; degE7 where they are a place).
    ValueError if they are not finite or do not fit int32."""
    degrees = xy_in_degrees(item.command, item.mission_type)
    try:
        x, y = _to_int(item.x, degrees), _to_int(item.y, degrees)
    except (ValueError, OverflowError, TypeError):
        raise ValueError(f"mission item {item.seq}: x/y do not fit int32") from None
    if not (-(2**31) <= x < 2**31 and -(2**31) <= y < 2**31):
        raise ValueError(f"mission item {item.seq}: x/y do not fit int32")
    return x, y


def _u8(v: int) -> bool:
    return 0 <= v <= 255


def check_item(item: MissionItem) -> None:
    """ValueError naming the item if it cannot go over the wire as it is."""
    floats = (item.param1, item.param2, item.param3, item.param4, item.z)
    if not all(isinstance(v, float | int) and math.isfinite(v) for v in floats):
        raise ValueError(f"mission item {item.seq}: params and z must be finite")
    wire_xy(item)
    if not (0 <= item.command <= 65535 and _u8(item.frame) and _u8(item.current)):
        raise ValueError(f"mission item {item.seq}: command/frame/current out of range")
    if not _u8(item.autocontinue) or not _u8(item.mission_type):
        raise ValueError(f"mission item {item.seq}: autocontinue/mission_type out of range")


def item_from_message(msg: Any) -> MissionItem | None:
    """A received MISSION_ITEM_INT or MISSION_ITEM as a :class:`MissionItem` (None: invalid)."""
    try:
        x_raw, y_raw = msg.x, msg.y
        frame = int(msg.frame)
        if msg.get_type() == "MISSION_ITEM":
            scale = 1.0 if frame == MAV_FRAME_MISSION else 1e7
            xf, yf = float(x_raw) * scale, float(y_raw) * scale
            if not (math.isfinite(xf) and math.isfinite(yf)):
                return None
            x, y = round(xf), round(yf)
        else:
            x, y = int(x_raw), int(y_raw)
        if not (-(2**31) <= x < 2**31 and -(2**31) <= y < 2**31):
            return None
        command = int(msg.command)
        mission_type = int(getattr(msg, "mission_type", 0))
        degrees = xy_in_degrees(command, mission_type)
        item = MissionItem(
            seq=int(msg.seq),
            frame=frame,
            command=command,
            current=int(msg.current),
            autocontinue=int(msg.autocontinue),
            param1=float(msg.param1),
            param2=float(msg.param2),
            param3=float(msg.param3),
            param4=float(msg.param4),
            x=_from_int(x, degrees),
            y=_from_int(y, degrees),
            z=float(msg.z),
            mission_type=mission_type,
        )
        check_item(item)
    except (AttributeError, TypeError, ValueError, OverflowError):
        return None
    return item
