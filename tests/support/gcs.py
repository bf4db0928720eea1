"""A ground station as QGroundControl behaves on the wire, for ``helixd serve`` tests: system
255, heartbeats, uploads a mission with the MAVLink mission protocol (MISSION_COUNT, answering
each MISSION_REQUEST(_INT) with MISSION_ITEM_INT, until MISSION_ACK) and sends commands to
helixd's own system/component id, reading the COMMAND_ACK helixd sends back. Waiting is on
messages with deadlines, never on sleeps."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.frames import ne_to_latlon
from helixd.config.link import LinkConfig
from helixd.mav.constants import (
    MAV_CMD_DO_SET_MODE,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
)
from helixd.sim.firmware.modes import MODE_NUMBERS
from helixd.sim.sim_config import SimConfig
from tests.support.harness import MavClient

QGC_SYSID = 255
HELIXD = (
    int(LinkConfig.model_fields["source_system"].default),
    int(LinkConfig.model_fields["source_component"].default),
)
SIM = SimConfig()


def set_mode_command(name: str) -> tuple[int, float, float]:
    """QGroundControl's Vehicle::setFlightMode for ArduPilot: MAV_CMD_DO_SET_MODE to the
    autopilot with the custom mode ``name``; (command, param1, param2)."""
    return MAV_CMD_DO_SET_MODE, MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODE_NUMBERS[name]


def shows_mode(name: str) -> Callable[[Any], bool]:
    """A HEARTBEAT naming mode ``name``."""
    return lambda m: bool(m.custom_mode == MODE_NUMBERS[name])


def shows_armed(m: Any) -> bool:
    """A HEARTBEAT saying armed."""
    return bool(m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)


def latlon(north_m: float, east_m: float) -> tuple[float, float]:
    return ne_to_latlon(north_m, east_m, SIM.origin_lat_deg, SIM.origin_lon_deg)


def waypoint(
    seq: int, north_m: float, east_m: float, command: int = mavlink.MAV_CMD_NAV_WAYPOINT
) -> Any:
    lat, lon = latlon(north_m, east_m)
    return mavlink.MAVLink_mission_item_int_message(
        1, 1, seq, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command,
        0, 1, 0.0, 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0,
        mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip


def upload(
    gcs: MavClient,
    points_ne_m: list[tuple[float, float]],
    timeout_s: float = 20.0,
    commands: dict[int, int] | None = None,
) -> None:
    """Upload home + one NAV_WAYPOINT per point (``commands``: item number → another
    navigation command at that point); AssertionError unless MISSION_ACK ACCEPTED."""
    cmds = commands or {}
    items = [
        waypoint(0, 0.0, 0.0),
        *(
            waypoint(i + 1, n, e, cmds.get(i + 1, mavlink.MAV_CMD_NAV_WAYPOINT))
            for i, (n, e) in enumerate(points_ne_m)
        ),
    ]
    upload_items(gcs, items, timeout_s)


def do_item(seq: int, command: int, *params: float) -> Any:
    """A do item (no place): ``params`` are param1.. in order."""
    p = [*params, 0.0, 0.0, 0.0, 0.0][:4]
    return mavlink.MAVLink_mission_item_int_message(
        1, 1, seq, mavlink.MAV_FRAME_MISSION, command, 0, 1, *p, 0, 0, 0.0,
        mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip


UPLOAD_REPLIES = ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK")


def upload_reply(mav: Any, items: list[Any], msg: Any, what: str) -> bool:
    """One of the autopilot's replies (:data:`UPLOAD_REPLIES`, or None) in an upload of
    ``items`` from the ground station: a request is answered with its item on ``mav``, sent
    with the requested seq; True once MISSION_ACK ACCEPTED, AssertionError on another ACK
    (``what`` names the list). What is not for the ground station is passed over."""
    if msg is None or int(msg.target_system) != QGC_SYSID:
        return False
    if msg.get_type() == "MISSION_ACK":
        assert int(msg.type) == mavlink.MAV_MISSION_ACCEPTED, f"{what} refused: {msg}"
        return True
    item = items[int(msg.seq)]
    item.seq = int(msg.seq)
    mav.send(item)
    return False


def upload_typed(
    gcs: MavClient, items: list[Any], mission_type: int, what: str, timeout_s: float = 20.0
) -> None:
    """Upload ``items`` of ``mission_type`` by the mission protocol (:func:`upload_reply`);
    AssertionError unless MISSION_ACK ACCEPTED (``what`` names the list)."""
    gcs.mav.mission_count_send(1, 1, len(items), mission_type)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = gcs.conn.recv_match(type=list(UPLOAD_REPLIES), blocking=True, timeout=0.5)
        if upload_reply(gcs.mav, items, msg, what):
            return
    raise AssertionError(f"{what} upload: no MISSION_ACK")


def upload_items(gcs: MavClient, items: list[Any], timeout_s: float = 20.0) -> None:
    """Upload ``items`` (home first) by the mission protocol; AssertionError unless
    MISSION_ACK ACCEPTED."""
    upload_typed(gcs, items, mavlink.MAV_MISSION_TYPE_MISSION, "mission", timeout_s)


def fence_circle(seq: int, north_m: float, east_m: float, radius_m: float, inclusion: bool) -> Any:
    """One fence circle item (MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION/EXCLUSION, param1 radius)."""
    lat, lon = latlon(north_m, east_m)
    cmd = (
        mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
        if inclusion
        else mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
    )
    return mavlink.MAVLink_mission_item_int_message(
        1, 1, seq, mavlink.MAV_FRAME_GLOBAL, cmd, 0, 1, radius_m, 0.0, 0.0, 0.0,
        round(lat * 1e7), round(lon * 1e7), 0.0, mavlink.MAV_MISSION_TYPE_FENCE,
    )  # fmt: skip


def upload_fence(gcs: MavClient, items: list[Any], timeout_s: float = 20.0) -> None:
    """Upload fence items; AssertionError unless MISSION_ACK ACCEPTED."""
    upload_typed(gcs, items, mavlink.MAV_MISSION_TYPE_FENCE, "fence", timeout_s)


def command(gcs: MavClient, cmd: int, *params: float, timeout_s: float = 10.0) -> int:
    """COMMAND_LONG to helixd; the result of helixd's COMMAND_ACK for it."""
    p = [*params, *([0.0] * (7 - len(params)))]
    gcs.drain()  # a full socket buffer would drop the ACK: read what queued up meanwhile
    gcs.heartbeat()  # a GCS heartbeats all the time: the autopilot knows its route
    gcs.mav.command_long_send(HELIXD[0], HELIXD[1], cmd, 0, *p)
    ack = gcs.recv(
        "COMMAND_ACK",
        timeout_s,
        lambda m: int(m.command) == cmd and int(m.get_srcSystem()) == HELIXD[0],
    )
    assert ack is not None, f"no COMMAND_ACK from helixd for command {cmd}"
    return int(ack.result)
