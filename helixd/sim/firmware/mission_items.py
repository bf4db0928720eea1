"""ArduPilot's MAVLink mission item protocol, as a pure state machine (messages in, messages out).

Written from ArduPilot's ``libraries/GCS_MAVLink/MissionItemProtocol.cpp`` (the shared
upload/download logic) and ``MissionItemProtocol_Waypoints.cpp`` / ``_Fence.cpp`` /
``_Rally.cpp`` (per type storage). One :class:`ItemProtocol` per mission type (MISSION, FENCE,
RALLY) holds the stored items (:class:`StoredItem`, in ArduPilot's units) and at most one upload
in progress; :class:`helixd.sim.firmware.mission_server.MissionServer` routes messages to them.

Behaviours (each cites its ArduPilot function):

* MISSION_COUNT starts an upload (``handle_mission_count``): a non-MISSION type over a
  MAVLink1 link is refused with UNSUPPORTED and "Need mavlink2 for item transfer"
  (``mavlink2_requirement_met``); another sender while one uploads gets DENIED, the same
  sender restarts; more than ``max_items`` gets NO_SPACE; count 0 completes at once. The
  vehicle then asks for each item with MISSION_REQUEST (``queued_request_send`` sends the
  non-INT request in this code) and re-asks after 1 s without an item (``update``,
  ``wp_recv_timeout_ms``); 8 s without an item ends the upload with OPERATION_CANCELLED and
  "Mission upload timeout" (``upload_timeout_ms``, ``MissionItemProtocol_Waypoints::timeout``).
* MISSION_ITEM / MISSION_ITEM_INT (``handle_mission_item``): a seq other than the one asked for
  gets INVALID_SEQUENCE (the upload goes on); an item from another sender gets DENIED; an item
  ArduPilot cannot store (unknown command, frame, lat/lon out of range) ends the upload with
  that result. After the last item: MISSION_ACK ACCEPTED (``transfer_is_complete``) and, for
  the mission, "Flight plan received" (``MissionItemProtocol_Waypoints::complete``). An item
  while nothing is uploading is ignored (ArduPilot flags an internal error, sends nothing).
* MISSION_REQUEST_LIST → MISSION_COUNT; MISSION_REQUEST_INT → MISSION_ITEM_INT; MISSION_REQUEST
  → MISSION_ITEM (floats, ``convert_MISSION_ITEM_INT_to_MISSION_ITEM``); all DENIED while an
  upload is in progress. A seq past the end: the mission answers MISSION_COUNT and ERROR
  (``MissionItemProtocol_Waypoints::get_item``), fence/rally INVALID_SEQUENCE.
* Row 0 of the MISSION type is home (``AP_Mission``): a download always reads ArduPilot's
  own home there (``read_cmd_from_storage`` index 0), whatever an upload wrote to it.
* MISSION_CLEAR_ALL → ACCEPTED, or ERROR while an upload is in progress
  (``handle_mission_clear_all``); clearing the mission leaves 0 items (``AP_Mission::clear``).
* MISSION_ITEM(_INT).current as ``MissionItemProtocol_Waypoints::get_item`` sets it: 1 when the
  item's *command id* equals the current nav index (ArduPilot compares ``cmd.id``, not the
  index), so normally 0.
* Per type (:class:`TypeRules`): the mission and rally points are written item by item and
  truncated to the announced count at MISSION_COUNT; the fence is collected aside and written
  on completion (``MissionItemProtocol_Fence::complete``), so a failed fence upload keeps the
  old fence. What is read back is what ArduPilot stores: a mission item's *_INT frame comes back
  without _INT; a fence item only as command, param1 (vertex count / radius) and x/y in frame 0
  (``get_item_as_mission_item``; a fence request with seq == count is ERROR, seq > count
  INVALID_SEQUENCE); a rally point in MAV_FRAME_GLOBAL_RELATIVE_ALT with an int16 altitude.
  Item checks: mission — supported command, finite params, lat/lng, frame; fence — frame
  (global only) then command; rally — MAV_CMD_NAV_RALLY_POINT, relative-altitude frame,
  lat/lng, altitude within int16 (INVALID_PARAM7). Timeout texts are "Mission/Fence/Rally
  upload timeout", completion texts "Flight plan received" and "Rally points received".

Not modelled: MISSION_WRITE_PARTIAL_LIST, the stream slowdown added to the 1 s re-request,
AP_Mission's per-command parameter packing (every param is kept as sent).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, cast

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_JUMP,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    MAV_FRAME_MISSION,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_DENIED,
    MAV_MISSION_ERROR,
    MAV_MISSION_INVALID_PARAM1,
    MAV_MISSION_INVALID_PARAM5_X,
    MAV_MISSION_INVALID_PARAM6_Y,
    MAV_MISSION_INVALID_PARAM7,
    MAV_MISSION_INVALID_SEQUENCE,
    MAV_MISSION_NO_SPACE,
    MAV_MISSION_OPERATION_CANCELLED,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_UNSUPPORTED,
    MAV_MISSION_UNSUPPORTED_FRAME,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_WARNING,
)
from helixd.sim.firmware.messages import Message
from helixd.sim.firmware.rover_firmware import SimStatusText

__all__ = ["ItemProtocol", "Outcome", "StoredItem"]


ACCEPTED_FRAMES = frozenset(
    {
        MAV_FRAME_GLOBAL,
        MAV_FRAME_MISSION,
        MAV_FRAME_GLOBAL_RELATIVE_ALT,
        MAV_FRAME_GLOBAL_INT,
        MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        MAV_FRAME_GLOBAL_TERRAIN_ALT,
        MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
FLOAT_XY_FRAMES = frozenset({MAV_FRAME_MISSION})  # x/y not scaled by 1e7 in MISSION_ITEM

# The commands AP_Mission::mavlink_int_to_mission_cmd stores (its switch, current master);
# anything else is MAV_MISSION_UNSUPPORTED.
MISSION_COMMANDS = frozenset(
    {16, 17, 18, 19, 20, 21, 22, 30, 31, 36, 82, 83, 84, 85, 92, 93, 94, 112, 114, 115, 177,
     178, 179, 181, 182, 183, 184, 188, 189, 191, 193, 194, 195, 197, 201, 202, 203, 205,
     206, 207, 208, 210, 211, 212, 213, 215, 216, 217, 218, 222, 223, 531, 532, 534, 600,
     601, 1000, 2000, 2001, 2500, 2501, 3000, 42600, 42702, 42703}
)  # fmt: skip
# Commands with a location whose x/y ArduPilot range-checks (AP_Mission::stored_in_location)
LOCATION_COMMANDS = frozenset(
    {16, 17, 18, 19, 21, 22, 30, 31, 36, 82, 84, 85, 92, 94, 179, 188, 189, 191, 195, 201}
)
# MissionItemProtocol_Fence: AC_PolyFenceItem types
FENCE_COMMANDS = frozenset({5000, 5001, 5002, 5003, 5004})
FENCE_FRAMES = ACCEPTED_FRAMES - {MAV_FRAME_MISSION}
RALLY_COMMANDS = frozenset({5100})  # MissionItemProtocol_Rally: MAV_CMD_NAV_RALLY_POINT

UPLOAD_TIMEOUT_S = 8.0  # MissionItemProtocol::upload_timeout_ms
REREQUEST_S = 1.0  # MissionItemProtocol::update: wp_recv_timeout_ms (no stream slowdown)

_mav = mavlink.MAVLink(None)


@dataclass(frozen=True, slots=True)
class StoredItem:
    """One item as AP_Mission stores it (x/y: the int32 degE7 of its Location for global
    frames). Not :class:`helixd.mav.mission_item.MissionItem` on purpose: the simulator is an
    independent model of the autopilot's storage, checked against helixd's client. It holds what
    ArduPilot keeps (no seq: the slot is the index; no current, autocontinue or mission_type:
    get_item makes them up per type, see :class:`TypeRules`), in ArduPilot's integer units, so
    its validation and read-back (:func:`validate_mission_item`, :func:`fence_readback`, ...)
    work on the values ArduPilot works on, and a unit mistake in helixd's edge is caught rather
    than shared."""

    command: int
    frame: int = MAV_FRAME_GLOBAL_RELATIVE_ALT
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0


Send = tuple[int | None, Message]  # (link, or None for every link; message)


@dataclass(slots=True)
class Outcome:
    """What handling one message (or the passing of time) produced, in ArduPilot's order."""

    steps: list[Send | SimStatusText] = field(default_factory=list)

    def send(self, item: Send) -> None:
        self.steps.append(item)

    def say(self, text: SimStatusText) -> None:
        self.steps.append(text)

    @property
    def sends(self) -> list[Send]:
        return [s for s in self.steps if not isinstance(s, SimStatusText)]

    @property
    def texts(self) -> list[SimStatusText]:
        return [s for s in self.steps if isinstance(s, SimStatusText)]


@dataclass(slots=True)
class _Upload:
    link: int
    sysid: int
    compid: int
    request_i: int
    request_last: int
    last_receive_s: float
    last_request_s: float
    items: list[StoredItem]


def _m(msg: Any) -> Message:
    return cast(Message, msg)


def _is_mavlink1(msg: Any) -> bool:
    buf = msg.get_msgbuf() if hasattr(msg, "get_msgbuf") else None
    return isinstance(buf, (bytes, bytearray)) and len(buf) > 0 and buf[0] == 0xFE


def mission_ack(target: tuple[int, int], result: int, mission_type: int) -> Message:
    return _m(_mav.mission_ack_encode(target[0], target[1], result, mission_type))


def _check_lat_lng(item: StoredItem) -> int:
    """check_lat / check_lng (AP_Common/Location): |lat| ≤ 90°, |lng| ≤ 180° in degE7."""
    if abs(item.x) > 900_000_000:
        return MAV_MISSION_INVALID_PARAM5_X
    if abs(item.y) > 1_800_000_000:
        return MAV_MISSION_INVALID_PARAM6_Y
    return MAV_MISSION_ACCEPTED


def _finite(item: StoredItem) -> bool:
    values = (item.param1, item.param2, item.param3, item.param4, item.z)
    return all(math.isfinite(v) for v in values)


def validate_mission_item(item: StoredItem) -> int:
    """AP_Mission::mavlink_int_to_mission_cmd's verdict on one item (MAV_MISSION_RESULT)."""
    if item.command not in MISSION_COMMANDS:
        return MAV_MISSION_UNSUPPORTED
    if not _finite(item):
        return MAV_MISSION_ERROR
    if item.command == MAV_CMD_NAV_WAYPOINT and not 0.0 <= item.param1 <= 65535.0:
        return MAV_MISSION_INVALID_PARAM1  # a rover's hold time is a uint16 of seconds
    if item.command in LOCATION_COMMANDS and item.frame != MAV_FRAME_MISSION:
        lat_lng = _check_lat_lng(item)
        if lat_lng != MAV_MISSION_ACCEPTED:
            return lat_lng
    if item.frame not in ACCEPTED_FRAMES:
        return MAV_MISSION_UNSUPPORTED_FRAME
    return MAV_MISSION_ACCEPTED


def validate_fence_item(item: StoredItem) -> int:
    """convert_MISSION_ITEM_INT_to_AC_PolyFenceItem (MissionItemProtocol_Fence.cpp)."""
    if item.frame not in FENCE_FRAMES:
        return MAV_MISSION_UNSUPPORTED_FRAME
    if item.command not in FENCE_COMMANDS:
        return MAV_MISSION_UNSUPPORTED
    return MAV_MISSION_ACCEPTED if math.isfinite(item.param1) else MAV_MISSION_ERROR


def validate_rally_item(item: StoredItem) -> int:
    """convert_MISSION_ITEM_INT_to_RallyLocation (MissionItemProtocol_Rally.cpp)."""
    if item.command not in RALLY_COMMANDS:
        return MAV_MISSION_UNSUPPORTED
    if item.frame not in (MAV_FRAME_GLOBAL_RELATIVE_ALT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
        return MAV_MISSION_UNSUPPORTED_FRAME
    lat_lng = _check_lat_lng(item)
    if lat_lng != MAV_MISSION_ACCEPTED:
        return lat_lng
    if not (math.isfinite(item.z) and -32768 <= item.z <= 32767):
        return MAV_MISSION_INVALID_PARAM7
    return MAV_MISSION_ACCEPTED


# A global frame given as *_INT is stored as a plain Location and read back without _INT
# (AP_Mission::mission_cmd_to_mavlink_int).
NON_INT_FRAME = {
    MAV_FRAME_GLOBAL_INT: MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: MAV_FRAME_GLOBAL_TERRAIN_ALT,
}


def mission_readback(item: StoredItem) -> StoredItem:
    return replace(item, frame=NON_INT_FRAME.get(item.frame, item.frame))


def fence_readback(item: StoredItem) -> StoredItem:
    """get_item_as_mission_item: only type, param1 (vertex count/radius) and x/y are kept."""
    return StoredItem(item.command, MAV_FRAME_GLOBAL, param1=item.param1, x=item.x, y=item.y)


def rally_readback(item: StoredItem) -> StoredItem:
    """MissionItemProtocol_Rally::get_item: RallyLocation keeps lat, lng and an int16 alt."""
    return StoredItem(
        item.command, MAV_FRAME_GLOBAL_RELATIVE_ALT, x=item.x, y=item.y, z=float(int(item.z))
    )


@dataclass(frozen=True, slots=True)
class TypeRules:
    """What differs between MissionItemProtocol_Waypoints, _Fence and _Rally."""

    validate: Callable[[StoredItem], int]
    readback: Callable[[StoredItem], StoredItem]
    staged: bool  # fence: items kept aside, written by complete(); others: stored at once
    autocontinue: int  # what get_item puts in autocontinue
    complete_text: str | None
    timeout_text: str


MISSION_RULES = TypeRules(
    validate_mission_item, mission_readback, False, 1, "Flight plan received",
    "Mission upload timeout",
)  # fmt: skip
FENCE_RULES = TypeRules(validate_fence_item, fence_readback, True, 0, None, "Fence upload timeout")
RALLY_RULES = TypeRules(
    validate_rally_item, rally_readback, False, 0, "Rally points received",
    "Rally upload timeout",
)  # fmt: skip


def _stored(msg: Any, x: int, y: int) -> StoredItem:
    return StoredItem(
        int(msg.command),
        int(msg.frame),
        float(msg.param1),
        float(msg.param2),
        float(msg.param3),
        float(msg.param4),
        x,
        y,
        float(msg.z),
    )


def item_from_int(msg: Any) -> StoredItem:
    return _stored(msg, int(msg.x), int(msg.y))


def item_from_float(msg: Any) -> StoredItem | None:
    """AP_Mission::convert_MISSION_ITEM_to_MISSION_ITEM_INT (None: x/y not representable)."""
    frame = int(msg.frame)
    x, y = float(msg.x), float(msg.y)
    if not (math.isfinite(x) and math.isfinite(y)):
        return None
    if frame not in FLOAT_XY_FRAMES:
        x, y = x * 1e7, y * 1e7
    if abs(x) >= 2**31 or abs(y) >= 2**31:
        return None
    return _stored(msg, round(x), round(y))


GUIDED_PLACE, ALTITUDE_ONLY = 2, 3  # MISSION_ITEM.current flags outside the mission protocol


@dataclass(frozen=True, slots=True)
class GuidedRequest:
    """A MISSION_ITEM(_INT) that is not part of an upload (``GCS_MAVLINK::
    handle_mission_item``): ``current`` 2 is a place for GUIDED (QGroundControl's older *Go
    to location*, ``MissionManager::writeArduPilotGuidedMissionItem``), 3 an altitude change;
    ``result`` AP_Mission::mavlink_int_to_mission_cmd's verdict on the item."""

    current: int
    item: StoredItem | None
    result: int


def guided_request(msg: Any) -> GuidedRequest | None:
    """The guided request ``msg`` carries, or None (an item of the mission protocol)."""
    if msg.get_type() not in ("MISSION_ITEM", "MISSION_ITEM_INT"):
        return None
    current = int(msg.current)
    if int(getattr(msg, "mission_type", 0)) != 0 or current not in (GUIDED_PLACE, ALTITUDE_ONLY):
        return None
    item = item_from_int(msg) if msg.get_type() == "MISSION_ITEM_INT" else item_from_float(msg)
    result = MAV_MISSION_ERROR if item is None else validate_mission_item(item)
    return GuidedRequest(current, item, result)


class ItemProtocol:
    """MissionItemProtocol for one mission type: stored items and at most one upload."""

    def __init__(
        self,
        mission_type: int,
        rules: TypeRules,
        max_items: int,
        home: StoredItem | None = None,
    ) -> None:
        self.mission_type = mission_type
        self.rules = rules
        self.max_items = max_items
        self.home = home  # MISSION only: row 0 as ArduPilot reads it back
        self.items: list[StoredItem] = [home] if home is not None else []
        self.upload: _Upload | None = None
        self.version = 0  # bumped on every stored change

    @property
    def receiving(self) -> bool:
        return self.upload is not None

    def _ack(self, out: Outcome, link: int, who: tuple[int, int], result: int) -> None:
        out.send((link, mission_ack(who, result, self.mission_type)))

    def _request(self, up: _Upload) -> Message:
        return _m(_mav.mission_request_encode(up.sysid, up.compid, up.request_i, self.mission_type))

    def _mavlink2_ok(self, out: Outcome, link: int, who: tuple[int, int], msg: Any) -> bool:
        """MissionItemProtocol::mavlink2_requirement_met."""
        if self.mission_type == MAV_MISSION_TYPE_MISSION or not _is_mavlink1(msg):
            return True
        out.say(SimStatusText(MAV_SEVERITY_WARNING, "Need mavlink2 for item transfer"))
        self._ack(out, link, who, MAV_MISSION_UNSUPPORTED)
        return False

    def handle_count(
        self, out: Outcome, link: int, who: tuple[int, int], msg: Any, now_s: float
    ) -> None:
        """MissionItemProtocol::handle_mission_count."""
        if not self._mavlink2_ok(out, link, who, msg):
            return
        count = int(msg.count)
        if self.upload is not None and (self.upload.sysid, self.upload.compid) != who:
            self._ack(out, link, who, MAV_MISSION_DENIED)
            return
        self.upload = None  # the same sender restarts
        if count > self.max_items:
            self._ack(out, link, who, MAV_MISSION_NO_SPACE)
            out.say(
                SimStatusText(MAV_SEVERITY_WARNING, f"Only {self.max_items} items are supported")
            )
            return
        if self.rules.staged:
            staged: list[StoredItem] = []  # fence: allocate_receive_resources; truncate is a no-op
        else:
            # mission/rally truncate(): the stored list shrinks to the announced length at once
            if len(self.items) > count:
                self.items = self.items[:count]
                self.version += 1
            staged = list(self.items)
        if count == 0:
            self.items = []  # fence: write_fence(new_items, 0); others already truncated
            self._complete(out, link, who)
            return
        up = _Upload(link, who[0], who[1], 0, count - 1, now_s, now_s, staged)
        self.upload = up
        out.send((link, self._request(up)))

    def handle_item(
        self,
        out: Outcome,
        link: int,
        who: tuple[int, int],
        item: StoredItem | None,
        seq: int,
        now_s: float,
    ) -> None:
        """MissionItemProtocol::handle_mission_item (item None: not convertible to INT)."""
        up = self.upload
        if up is None:
            return  # link == nullptr: INTERNAL_ERROR, no reply
        if seq != up.request_i:
            self._ack(out, link, who, MAV_MISSION_INVALID_SEQUENCE)
            return
        if who != (up.sysid, up.compid):
            self._ack(out, link, who, MAV_MISSION_DENIED)
            return
        result = MAV_MISSION_ERROR if item is None else self.rules.validate(item)
        if item is not None and result == MAV_MISSION_ACCEPTED and item.command == MAV_CMD_DO_JUMP:
            target = int(item.param1)  # append_item/replace_item: DO_JUMP sanity check
            if target == 0 or (target >= len(up.items) and target > up.request_last):
                result = MAV_MISSION_ERROR
        if result != MAV_MISSION_ACCEPTED or item is None:
            self._ack(out, up.link, who, result)
            self.upload = None
            return
        if seq < len(up.items):
            up.items[seq] = item
        else:
            up.items.append(item)
        if not self.rules.staged:
            self.items = list(up.items)  # AP_Mission / AP_Rally write each item at once
            self.version += 1
        up.last_receive_s = now_s
        up.request_i += 1
        if up.request_i > up.request_last:
            self.items = list(up.items)
            self.version += 1
            self.upload = None
            self._complete(out, link, who)
            return
        up.last_request_s = now_s
        out.send((up.link, self._request(up)))

    def _complete(self, out: Outcome, link: int, who: tuple[int, int]) -> None:
        """MissionItemProtocol::transfer_is_complete: the text to the uploading link only
        (``link.send_text``): another ground station, and helixd, are not told."""
        if self.rules.complete_text is not None:
            out.say(SimStatusText(MAV_SEVERITY_INFO, self.rules.complete_text, link))
        self.version += 1
        self._ack(out, link, who, MAV_MISSION_ACCEPTED)

    def item_at(self, seq: int) -> StoredItem | None:
        """get_item, as read back: row 0 of the mission is ArduPilot's own home."""
        if seq == 0 and self.home is not None:
            return self.home
        if 0 <= seq < len(self.items):
            return self.rules.readback(self.items[seq])
        return None

    def _past_end(self, out: Outcome, link: int, who: tuple[int, int], seq: int) -> None:
        if self.mission_type == MAV_MISSION_TYPE_MISSION:
            # MissionItemProtocol_Waypoints::get_item "educates" the GCS with the real count
            count = _mav.mission_count_encode(who[0], who[1], len(self.items), 0)
            out.send((link, _m(count)))
            self._ack(out, link, who, MAV_MISSION_ERROR)
        elif self.mission_type == MAV_MISSION_TYPE_FENCE and seq == len(self.items):
            # MissionItemProtocol_Fence::get_item checks seq > count; seq == count then
            # fails in get_item_as_mission_item
            self._ack(out, link, who, MAV_MISSION_ERROR)
        else:
            self._ack(out, link, who, MAV_MISSION_INVALID_SEQUENCE)

    def handle_request(
        self,
        out: Outcome,
        link: int,
        who: tuple[int, int],
        msg: Any,
        as_int: bool,
        nav_index: int,
    ) -> None:
        """handle_mission_request_int / handle_mission_request (``nav_index``: AP_Mission's
        raw current nav index, CMD_INDEX_NONE when there is none)."""
        if not self._mavlink2_ok(out, link, who, msg):
            return
        if self.upload is not None:
            self._ack(out, link, who, MAV_MISSION_DENIED)
            return
        seq = int(msg.seq)
        item = self.item_at(seq)
        if item is None or (seq != 0 and seq >= len(self.items)):
            self._past_end(out, link, who, seq)
            return
        # MissionItemProtocol_Waypoints::get_item compares the item's command id with the
        # current nav index (``cmd.id == get_current_nav_cmd().index``)
        is_mission = self.mission_type == MAV_MISSION_TYPE_MISSION
        current = 1 if is_mission and item.command == nav_index else 0
        auto = self.rules.autocontinue
        if as_int:
            reply = _mav.mission_item_int_encode(
                who[0], who[1], seq, item.frame, item.command, current, auto,
                item.param1, item.param2, item.param3, item.param4, item.x, item.y, item.z,
                self.mission_type,
            )  # fmt: skip
        else:
            scale = 1.0 if item.frame in FLOAT_XY_FRAMES else 1e-7
            reply = _mav.mission_item_encode(
                who[0], who[1], seq, item.frame, item.command, current, auto,
                item.param1, item.param2, item.param3, item.param4, item.x * scale,
                item.y * scale, item.z, self.mission_type,
            )  # fmt: skip
        out.send((link, _m(reply)))

    def handle_request_list(self, out: Outcome, link: int, who: tuple[int, int], msg: Any) -> None:
        """MissionItemProtocol::handle_mission_request_list."""
        if not self._mavlink2_ok(out, link, who, msg):
            return
        if self.upload is not None:
            self._ack(out, link, who, MAV_MISSION_DENIED)
            return
        count = _mav.mission_count_encode(who[0], who[1], len(self.items), self.mission_type)
        out.send((link, _m(count)))

    def handle_clear_all(self, out: Outcome, link: int, who: tuple[int, int]) -> None:
        """MissionItemProtocol::handle_mission_clear_all."""
        if self.upload is not None:
            self._ack(out, link, who, MAV_MISSION_ERROR)
            return
        self.items = []
        self.version += 1
        self._ack(out, link, who, MAV_MISSION_ACCEPTED)

    def update(self, out: Outcome, now_s: float) -> None:
        """MissionItemProtocol::update: upload timeout and the 1 s re-request."""
        up = self.upload
        if up is None:
            return
        if now_s - up.last_receive_s > UPLOAD_TIMEOUT_S:
            self.upload = None
            out.say(SimStatusText(MAV_SEVERITY_WARNING, self.rules.timeout_text))
            out.send(
                (up.link, mission_ack((up.sysid, up.compid), MAV_MISSION_OPERATION_CANCELLED,
                                      self.mission_type))
            )  # fmt: skip
            return
        if now_s - up.last_request_s > REREQUEST_S:
            up.last_request_s = now_s
            out.send((up.link, self._request(up)))
