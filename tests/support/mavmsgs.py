"""Decoded MAVLink messages as helixd's reader sees them, for tests that feed a vehicle state
without a socket (one place, so test modules do not import each other)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    EKF_ATTITUDE,
    EKF_POS_HORIZ_ABS,
    EKF_POS_HORIZ_REL,
    EKF_POS_VERT_ABS,
    EKF_VELOCITY_HORIZ,
    EKF_VELOCITY_VERT,
)


def codec(sysid: int = 1, compid: int = 1) -> Any:
    c = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    return c


def decoded(msg: Any, c: Any) -> Any:
    rx = mavlink.MAVLink(None)
    out = rx.parse_buffer(bytes(msg.pack(c)))
    assert out is not None
    return out[0]


AP = codec()
# EKF_STATUS_REPORT.flags of an EKF that has its attitude, velocities and positions
EKF_HEALTHY_FLAGS = (
    EKF_ATTITUDE
    | EKF_VELOCITY_HORIZ
    | EKF_VELOCITY_VERT
    | EKF_POS_HORIZ_REL
    | EKF_POS_HORIZ_ABS
    | EKF_POS_VERT_ABS
)
# the ids a GCS such as Mission Planner sends with (MAV_GCS_SYSID's default 255)
GCS_IDS = (255, 190)


def stamp(msg: Any, who: tuple[int, int] = GCS_IDS, v1: bool = False) -> Any:
    """``msg`` as received from ``who`` (packed and decoded: real sender ids; ``v1``: as a
    MAVLink 1 frame)."""
    mav = mavlink.MAVLink(None, srcSystem=who[0], srcComponent=who[1])
    return mav.decode(bytearray(msg.pack(mav, force_mavlink1=v1)))


def hb(custom_mode: int, armed: bool = False, c: Any = AP) -> Any:
    return decoded(c.heartbeat_encode(10, 3, 1 | (128 if armed else 0), custom_mode, 4), c)


def att(t_ms: int, yaw: float) -> Any:
    return decoded(AP.attitude_encode(t_ms, 0, 0, yaw, 0, 0, 0), AP)


def lpn(t_ms: int, north: float, east: float) -> Any:
    return decoded(AP.local_position_ned_encode(t_ms, north, east, 0, 0.5, -0.2, 0.0), AP)


def read_tlog(path: Path) -> list[Any]:
    """Every message of a .tlog as pymavlink (MAVExplorer's reader) reads it back."""
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    out = []
    try:
        while (msg := conn.recv_match(blocking=False)) is not None:
            out.append(msg)
    finally:
        conn.close()
    return out


class TextPane:
    """A ground station's message pane: every STATUSTEXT kept in ``texts``, a text sent in
    chunks (MAVLink 2's ``id``, a chunk under 50 characters ends it) joined into one."""

    def __init__(self, texts: list[str]) -> None:
        self.texts = texts
        self._chunks: dict[int, list[str]] = {}

    def note(self, msg: Any) -> None:
        text, chunk_id = str(msg.text), int(msg.id)
        if chunk_id == 0:
            self.texts.append(text)
            return
        parts = self._chunks.setdefault(chunk_id, [])
        parts.append(text)
        if len(text) < 50:
            self.texts.append("".join(parts))
            del self._chunks[chunk_id]
