"""ArduPilot's MAVLink mission protocol, as a pure state machine (messages in, messages out).

Written from ArduPilot's ``libraries/GCS_MAVLink/MissionItemProtocol.cpp`` (the shared
upload/download logic), ``MissionItemProtocol_Waypoints.cpp`` / ``_Fence.cpp`` / ``_Rally.cpp``
(per type storage) and ``GCS_Common.cpp`` (``GCS_MAVLINK::handle_common_mission_message``:
which message goes to which protocol). One :class:`ItemProtocol` per mission type (MISSION,
FENCE, RALLY) holds the stored items and at most one upload in progress; :class:`MissionServer`
routes messages to them by ``mission_type`` and answers an unknown type with
MAV_MISSION_UNSUPPORTED.

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
* The current item (``AP_Mission::set_current_cmd`` with the mission not running — Rover
  runs it only in AUTO, :mod:`helixd.sim.firmware.mode_auto`): an index past the end, or a mission of
  home alone, fails; index 0 means 1 and restarts the jump counters; the current *nav* index
  becomes the first NAV command (``is_nav_cmd``: id ≤ MAV_CMD_NAV_LAST, NAV_SET_YAW_SPEED,
  NAV_SCRIPT_TIME, NAV_ATTITUDE_TIME) at or after it, following DO_JUMP / DO_JUMP_TAG
  (``get_next_cmd`` with its jump counters, "Mission: N Jump i/n" texts and the 64-jump
  limit); no NAV command there fails and leaves no current command (seq 0). The mission
  stays stopped. At boot and after a clear there is no current command
  (``get_current_nav_index`` reads 0); an upload leaves it as it was.
* MISSION_SET_CURRENT (``GCS_MAVLINK::handle_mission_set_current``): ``set_current_cmd(seq)``;
  on success MISSION_CURRENT with the *requested* seq goes back to the sender's link only
  (``send_mission_current(mission, packet.seq)``, some GCSs take it as the ack); on failure
  nothing.
* MAV_CMD_DO_SET_MISSION_CURRENT (``GCS_MAVLINK::handle_command_do_set_mission_current``,
  :meth:`MissionServer.do_set_mission_current`): seq = param1 as uint32, narrowed to uint16 by
  ``is_valid_index``; seq ≥ count → DENIED (a NaN/negative param1, undefined in C++, is DENIED
  here); param2 == 1 ``reset()``s the mission first (current command and jump counters) and
  ``resume()``s it after; ``set_current_cmd`` failing → FAILED; ACCEPTED → MISSION_CURRENT
  (``send_message(MSG_CURRENT_WAYPOINT)``: the nav index) after the ACK, on the commanding
  link only (``GCS_MAVLINK::send_message`` is per channel despite the source's "all
  listeners" comment). A resumed mission is RUNNING: further set-current calls take
  ``advance_current_nav_cmd``'s search (same NAV item found; the DO/NAV ``start_command``
  callbacks it runs, even outside AUTO, are not modelled).
* MISSION_CURRENT (``GCS_MAVLINK::send_mission_current``, streamed in EXTENDED_STATUS as
  MSG_CURRENT_WAYPOINT): seq = ``get_current_nav_index()``, total excludes home, mission_state
  from ``GCS_MAVLINK::mission_state`` (NO_MISSION unless ``present()`` — more than home —,
  stopped NOT_STARTED, running ACTIVE, complete COMPLETE), mission_mode 1 only in a mode that
  ``current_mode_requires_mission`` (Rover: AUTO).
* A disarm outside AUTO resets the mission (``AP_Arming_Rover::disarm`` → ``AP_Mission::reset``):
  no current command, so MISSION_CURRENT reads seq 0 until the current item is set again.
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
    MAV_CMD_DO_JUMP_TAG,
    MAV_CMD_JUMP_TAG,
    MAV_CMD_NAV_ATTITUDE_TIME,
    MAV_CMD_NAV_LAST,
    MAV_CMD_NAV_SCRIPT_TIME,
    MAV_CMD_NAV_SET_YAW_SPEED,
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
    MAV_MISSION_TYPE_RALLY,
    MAV_MISSION_UNSUPPORTED,
    MAV_MISSION_UNSUPPORTED_FRAME,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_WARNING,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_COMPLETE,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_NOT_STARTED,
    UINT16_MAX,
)
from helixd.sim.firmware.messages import Message
from helixd.sim.firmware.rover_firmware import SimStatusText

__all__ = [
    "ItemProtocol",
    "MissionServer",
    "Outcome",
    "StoredItem",
]


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

# AP_Mission
CMD_INDEX_NONE = UINT16_MAX  # AP_MISSION_CMD_INDEX_NONE
NAV_EXCEPTIONS = frozenset(
    {MAV_CMD_NAV_SET_YAW_SPEED, MAV_CMD_NAV_SCRIPT_TIME, MAV_CMD_NAV_ATTITUDE_TIME}
)
MAX_JUMP_COMMANDS = 100  # AP_MISSION_MAX_NUM_DO_JUMP_COMMANDS (HAL_MEM_CLASS_500 and SITL)
JUMP_TIMES_MAX = 32767  # AP_MISSION_JUMP_TIMES_MAX: what an untracked jump has "run"
JUMP_REPEAT_FOREVER = -1  # AP_MISSION_JUMP_REPEAT_FOREVER
GET_NEXT_CMD_MAX_JUMPS = 64  # get_next_cmd's max_loops
ADVANCE_MAX_LOOPS = 255  # advance_current_nav_cmd's max_loops
FLT_EPSILON = 1.1920929e-07  # is_equal(float, float)
MISSION_STOPPED, MISSION_RUNNING, MISSION_COMPLETE = 0, 1, 2  # AP_Mission::mission_state
# AP_Mission::Mission_Command::type(): the names "Mission: N <type>" says (the few modelled)
COMMAND_TYPES = {16: "WP", 17: "LoitUnlim", 19: "LoitTime", 20: "RTL", 93: "Delay"}
MISSION_STATES = {  # GCS_MAVLINK::mission_state
    MISSION_STOPPED: MISSION_STATE_NOT_STARTED,
    MISSION_RUNNING: MISSION_STATE_ACTIVE,
    MISSION_COMPLETE: MISSION_STATE_COMPLETE,
}

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


def is_nav_cmd(command: int) -> bool:
    """AP_Mission::is_nav_cmd."""
    return command <= MAV_CMD_NAV_LAST or command in NAV_EXCEPTIONS


def seq_from_param(param1: float) -> int | None:
    """handle_command_do_set_mission_current: ``(uint32_t)packet.param1``, then the uint16 of
    ``is_valid_index`` / ``set_current_cmd``. None where C++ is undefined (NaN, negative,
    beyond uint32): the simulator refuses those rather than guess."""
    if not math.isfinite(param1) or param1 < 0.0 or param1 >= 2.0**32:
        return None
    return int(param1) & UINT16_MAX


class MissionServer:
    """GCS_MAVLINK::handle_common_mission_message: the three protocols and AP_Mission's
    current command (nav index, DO_JUMP counters, mission state)."""

    MESSAGES = frozenset(
        {
            "MISSION_COUNT",
            "MISSION_ITEM",
            "MISSION_ITEM_INT",
            "MISSION_REQUEST",
            "MISSION_REQUEST_INT",
            "MISSION_REQUEST_LIST",
            "MISSION_CLEAR_ALL",
            "MISSION_SET_CURRENT",
            "MISSION_ACK",
        }
    )

    def __init__(
        self,
        home_lat_deg: float,
        home_lon_deg: float,
        home_alt_m: float,
        max_mission_items: int = 700,
        max_fence_items: int = 84,
        max_rally_items: int = 10,
        requires_mission: Callable[[], bool] = lambda: False,
    ) -> None:
        """``requires_mission``: AP_Vehicle::current_mode_requires_mission (Rover: in AUTO)."""
        home = StoredItem(
            MAV_CMD_NAV_WAYPOINT,
            MAV_FRAME_GLOBAL,
            x=round(home_lat_deg * 1e7),
            y=round(home_lon_deg * 1e7),
            z=home_alt_m,
        )
        self.protocols = {
            MAV_MISSION_TYPE_MISSION: ItemProtocol(
                MAV_MISSION_TYPE_MISSION, MISSION_RULES, max_mission_items, home
            ),
            MAV_MISSION_TYPE_FENCE: ItemProtocol(
                MAV_MISSION_TYPE_FENCE, FENCE_RULES, max_fence_items
            ),
            MAV_MISSION_TYPE_RALLY: ItemProtocol(
                MAV_MISSION_TYPE_RALLY, RALLY_RULES, max_rally_items
            ),
        }
        self.requires_mission = requires_mission
        # AP_Mission: _nav_cmd.index / _do_cmd.index (CMD_INDEX_NONE: none), _flags.state,
        # _jump_tracking (jump index → times run, at most MAX_JUMP_COMMANDS entries)
        self.nav_index = CMD_INDEX_NONE
        self.do_index = CMD_INDEX_NONE
        self.state = MISSION_STOPPED
        self.jumps_run: dict[int, int] = {}

    @property
    def current_seq(self) -> int:
        """AP_Mission::get_current_nav_index: 0 while there is no current command."""
        return 0 if self.nav_index == CMD_INDEX_NONE else self.nav_index

    @property
    def _mission(self) -> ItemProtocol:
        return self.protocols[MAV_MISSION_TYPE_MISSION]

    def stored(self, mission_type: int = MAV_MISSION_TYPE_MISSION) -> tuple[StoredItem, ...]:
        return tuple(self.protocols[mission_type].items)

    def mission_state(self) -> int:
        """GCS_MAVLINK::mission_state: NO_MISSION unless AP_Mission::present() (> home)."""
        if len(self._mission.items) <= 1:
            return MISSION_STATE_NO_MISSION
        return MISSION_STATES[self.state]

    def mission_current_fields(self, seq: int | None = None) -> tuple[int, int, int, int]:
        """(seq, total, mission_state, mission_mode) as GCS_MAVLINK::send_mission_current
        fills them; ``seq`` defaults to the current nav index (MSG_CURRENT_WAYPOINT)."""
        total = max(0, len(self._mission.items) - 1)  # home excluded
        return (
            self.current_seq if seq is None else seq,
            total,
            self.mission_state(),
            1 if self.requires_mission() else 0,
        )

    def mission_current(self, seq: int | None = None) -> Message:
        return _m(_mav.mission_current_encode(*self.mission_current_fields(seq)))

    # -- AP_Mission's current command ------------------------------------------------------

    def _command_at(self, index: int) -> StoredItem:
        """read_cmd_from_storage: row 0 is home (a NAV_WAYPOINT)."""
        prot = self._mission
        if index == 0 and prot.home is not None:
            return prot.home
        return prot.items[index]

    def _jump_tag_index(self, tag: int) -> int:
        """get_index_of_jump_tag: the first JUMP_TAG with this tag, 0 if none."""
        for i in range(1, len(self._mission.items)):
            cmd = self._command_at(i)
            if cmd.command == MAV_CMD_JUMP_TAG and int(cmd.param1) == tag:
                return i
        return 0

    def _jump_times_run(self, index: int) -> int:
        """get_jump_times_run (allocates a tracking entry on first use)."""
        if index in self.jumps_run:
            return self.jumps_run[index]
        if len(self.jumps_run) >= MAX_JUMP_COMMANDS:
            return JUMP_TIMES_MAX
        self.jumps_run[index] = 0
        return 0

    def _next_cmd(self, start: int, out: Outcome) -> tuple[int, StoredItem] | None:
        """get_next_cmd(start, cmd, increment_jump_num_times_if_found=true): the first
        non-jump command at or after ``start``, following jumps and counting them."""
        total = len(self._mission.items)
        index = start
        jumps_left = GET_NEXT_CMD_MAX_JUMPS
        while index < total:
            cmd = self._command_at(index)
            if cmd.command not in (MAV_CMD_DO_JUMP, MAV_CMD_DO_JUMP_TAG):
                return index, cmd
            target = int(cmd.param1)
            if cmd.command == MAV_CMD_DO_JUMP_TAG:
                target = self._jump_tag_index(target)
            if jumps_left == 0:
                return None
            jumps_left -= 1
            if target >= total or target == 0:
                return None
            times = int(cmd.param2)
            run = self._jump_times_run(index)
            if times == JUMP_REPEAT_FOREVER or run < times:
                if index in self.jumps_run:  # increment_jump_times_run
                    self.jumps_run[index] += 1
                    of = "unlimited" if times == JUMP_REPEAT_FOREVER else str(times)
                    out.say(
                        SimStatusText(
                            MAV_SEVERITY_INFO, f"Mission: {index} Jump {self.jumps_run[index]}/{of}"
                        )
                    )
                index = target
            else:
                if index in self.jumps_run:  # a finished loop starts over (MIS_OPTIONS 0)
                    self.jumps_run[index] = 0
                index += 1
        return None

    def set_current_cmd(self, index: int, out: Outcome) -> bool:
        """AP_Mission::set_current_cmd."""
        total = len(self._mission.items)
        if index >= total or total == 1:
            return False
        self.do_index = CMD_INDEX_NONE
        if index == 0 or self.state == MISSION_COMPLETE:
            self.jumps_run.clear()  # init_jump_tracking
            index = max(index, 1)
        if self.state == MISSION_RUNNING:  # in AUTO: the command starts at once
            started = self._advance_current_nav_cmd(index, out)
            if started:
                self._say_started(out)
            return started
        while True:
            found = self._next_cmd(index, out)
            if found is None:
                self.nav_index = CMD_INDEX_NONE
                return False
            at, cmd = found
            if is_nav_cmd(cmd.command):
                self.nav_index = at
                break
            if self.do_index == CMD_INDEX_NONE:
                self.do_index = at
            index = at + 1
        self.state = MISSION_STOPPED
        return True

    def _advance_current_nav_cmd(self, index: int, out: Outcome) -> bool:
        """AP_Mission::advance_current_nav_cmd from ``index`` (the mission running); every
        start_command is taken to succeed. Running out of commands completes the mission."""
        for _ in range(ADVANCE_MAX_LOOPS):
            found = self._next_cmd(index, out)
            if found is None:
                break
            at, cmd = found
            if is_nav_cmd(cmd.command):
                self.nav_index = at
                return True
            if self.do_index == CMD_INDEX_NONE:
                self.do_index = at
            index = at + 1
        self.state = MISSION_COMPLETE  # set_current_cmd: "on failure set mission complete"
        return False

    def _reset(self) -> None:
        """AP_Mission::reset."""
        self.nav_index = CMD_INDEX_NONE
        self.do_index = CMD_INDEX_NONE
        self.jumps_run.clear()

    def _resume(self, out: Outcome) -> None:
        """AP_Mission::resume, for a mission set_current_cmd has just stopped at a NAV item
        (``start()`` and the repeat-distance rewind are not reachable from here)."""
        self.state = MISSION_RUNNING
        index = self.do_index if self.do_index != CMD_INDEX_NONE else self.nav_index
        self.set_current_cmd(index, out)

    def do_set_mission_current(
        self, link: int, param1: float, param2: float
    ) -> tuple[int, Outcome]:
        """GCS_MAVLINK::handle_command_do_set_mission_current: (MAV_RESULT, what follows the
        COMMAND_ACK: jump texts, and MISSION_CURRENT to ``link`` when ACCEPTED)."""
        out = Outcome()
        seq = seq_from_param(param1)
        if seq is None or seq >= len(self._mission.items):  # is_valid_index
            return MAV_RESULT_DENIED, out
        reset_and_restart = abs(param2 - 1.0) < FLT_EPSILON
        if reset_and_restart:
            self._reset()
        if not self.set_current_cmd(seq, out):
            return MAV_RESULT_FAILED, out
        if reset_and_restart:
            self._resume(out)
        out.send((link, self.mission_current()))  # send_message(MSG_CURRENT_WAYPOINT)
        return MAV_RESULT_ACCEPTED, out

    # -- messages --------------------------------------------------------------------------

    def handle(self, link: int, msg: Any, now_s: float) -> Outcome:
        out = Outcome()
        kind = msg.get_type()
        if kind not in self.MESSAGES or kind == "MISSION_ACK":
            return out  # MISSION_ACK from a GCS: nothing to do
        who = (int(msg.get_srcSystem()), int(msg.get_srcComponent()))
        if kind == "MISSION_SET_CURRENT":
            seq = int(msg.seq)
            if self.set_current_cmd(seq, out):
                out.send((link, self.mission_current(seq)))  # the requested seq, echoed
            return out
        mission_type = int(getattr(msg, "mission_type", 0))
        prot = self.protocols.get(mission_type)
        if prot is None:
            out.send((link, mission_ack(who, MAV_MISSION_UNSUPPORTED, mission_type)))
            return out
        if kind == "MISSION_COUNT":
            prot.handle_count(out, link, who, msg, now_s)
        elif kind == "MISSION_ITEM_INT":
            prot.handle_item(out, link, who, item_from_int(msg), int(msg.seq), now_s)
        elif kind == "MISSION_ITEM":
            prot.handle_item(out, link, who, item_from_float(msg), int(msg.seq), now_s)
        elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            as_int = kind == "MISSION_REQUEST_INT"
            prot.handle_request(out, link, who, msg, as_int, self.nav_index)
        elif kind == "MISSION_REQUEST_LIST":
            prot.handle_request_list(out, link, who, msg)
        elif kind == "MISSION_CLEAR_ALL":
            cleared = prot.upload is None
            prot.handle_clear_all(out, link, who)
            if mission_type == MAV_MISSION_TYPE_MISSION and cleared:
                # AP_Mission::clear (ArduPilot refuses it while armed with the mission
                # running in AUTO: not modelled)
                self._reset()
                self.state = MISSION_STOPPED
        return out

    # -- AP_Mission running in AUTO (ModeAuto drives it: helixd.sim.firmware.mode_auto) ---------------

    def nav_item(self) -> tuple[int, StoredItem] | None:
        """The current nav command (index, item) while the mission runs; None otherwise."""
        if self.state != MISSION_RUNNING or self.nav_index == CMD_INDEX_NONE:
            return None
        if self.nav_index >= len(self._mission.items):
            return None
        return self.nav_index, self._command_at(self.nav_index)

    def start_or_resume(self, out: Outcome) -> None:
        """AP_Mission::start_or_resume with MIS_RESTART 0 (resume): a completed mission, or
        one with no current command (or one the mission no longer has), starts from its first
        command (jump counters cleared); otherwise the current nav command starts again. Each
        nav command started says "Mission: N WP" (AP_Mission::start_command)."""
        if self.state == MISSION_RUNNING:
            return
        # a current command the stored mission no longer has (a shorter one uploaded since):
        # AP_Mission::resume finds read_cmd_from_storage failing and starts again
        gone = self.nav_index != CMD_INDEX_NONE and self.nav_index >= len(self._mission.items)
        restart = self.state == MISSION_COMPLETE or self.nav_index == CMD_INDEX_NONE or gone
        self.state = MISSION_RUNNING
        if restart:
            self.jumps_run.clear()
            self.do_index = CMD_INDEX_NONE
            if not self._advance_current_nav_cmd(1, out):
                return
        self._say_started(out)

    def stop(self) -> None:
        """AP_Mission::stop (ModeAuto::_exit: leaving AUTO stops a running mission)."""
        if self.state == MISSION_RUNNING:
            self.state = MISSION_STOPPED

    def nav_done(self, out: Outcome) -> bool:
        """The current nav command verified: on to the next one (True), or the mission is
        complete (False; the caller says "Mission Complete", ModeAuto::exit_mission)."""
        if self.state != MISSION_RUNNING or self.nav_index == CMD_INDEX_NONE:
            return False
        self.do_index = CMD_INDEX_NONE
        if not self._advance_current_nav_cmd(self.nav_index + 1, out):
            return False
        self._say_started(out)
        return True

    def _say_started(self, out: Outcome) -> None:
        if self.state == MISSION_RUNNING and self.nav_index != CMD_INDEX_NONE:
            cmd = self._command_at(self.nav_index)
            name = COMMAND_TYPES.get(cmd.command, f"Cmd{cmd.command}")
            out.say(SimStatusText(MAV_SEVERITY_INFO, f"Mission: {self.nav_index} {name}"))

    def reset_on_disarm(self) -> None:
        """``AP_Arming_Rover::disarm`` outside AUTO: ``mission.reset()`` — no current command
        (MISSION_CURRENT seq 0), jump counters cleared; the state is left as it was."""
        self._reset()

    def reboot(self) -> None:
        """A reboot loses uploads in progress and the current command (AP_Mission's
        constructor: no nav command, stopped); stored items persist."""
        for prot in self.protocols.values():
            prot.upload = None
        self._reset()
        self.state = MISSION_STOPPED

    def update(self, now_s: float) -> Outcome:
        out = Outcome()
        for prot in self.protocols.values():
            prot.update(out, now_s)
        return out
