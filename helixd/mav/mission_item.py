"""One mission item as it crosses the wire (MISSION_ITEM_INT), checked once at the edge.

Shared by the link's mission-protocol client, the ground-station formats that convert to and
from it, and the simulator's mission server. Constants come from pymavlink's dialect.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_FRAME_MISSION,
    MAV_MISSION_TYPE_MISSION,
)

# MAV_MISSION_TYPE, MAV_MISSION_RESULT and the frame whose x/y are not degE7


def mission_result_name(result: int) -> str:
    """MAV_MISSION_RESULT name (e.g. 'MAV_MISSION_NO_SPACE'), or the number if unknown."""
    entry = mavlink.enums["MAV_MISSION_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_MISSION_RESULT({result})"


@dataclass(frozen=True, slots=True)
class WireItem:
    """One mission item as MISSION_ITEM_INT carries it (x/y in degE7 for global frames): what
    goes over the wire, as opposed to :class:`helixd.mission.formats.items.MissionItem` (a
    ground-station file's item, lat/lon in degrees)."""

    seq: int
    frame: int
    command: int
    current: int = 0
    autocontinue: int = 1
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    mission_type: int = MAV_MISSION_TYPE_MISSION


def _u8(v: int) -> bool:
    return 0 <= v <= 255


def check_wire_item(item: WireItem) -> None:
    floats = (item.param1, item.param2, item.param3, item.param4, item.z)
    if not all(isinstance(v, float | int) and math.isfinite(v) for v in floats):
        raise ValueError(f"mission item {item.seq}: params and z must be finite")
    if not (-(2**31) <= item.x < 2**31 and -(2**31) <= item.y < 2**31):
        raise ValueError(f"mission item {item.seq}: x/y do not fit int32")
    if not (0 <= item.command <= 65535 and _u8(item.frame) and _u8(item.current)):
        raise ValueError(f"mission item {item.seq}: command/frame/current out of range")
    if not _u8(item.autocontinue) or not _u8(item.mission_type):
        raise ValueError(f"mission item {item.seq}: autocontinue/mission_type out of range")


def item_from_message(msg: Any) -> WireItem | None:
    """A received MISSION_ITEM_INT or MISSION_ITEM as a :class:`WireItem` (None: invalid)."""
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
        item = WireItem(
            seq=int(msg.seq),
            frame=frame,
            command=int(msg.command),
            current=int(msg.current),
            autocontinue=int(msg.autocontinue),
            param1=float(msg.param1),
            param2=float(msg.param2),
            param3=float(msg.param3),
            param4=float(msg.param4),
            x=x,
            y=y,
            z=float(msg.z),
            mission_type=int(getattr(msg, "mission_type", 0)),
        )
        check_wire_item(item)
    except (AttributeError, TypeError, ValueError, OverflowError):
        return None
    return item
