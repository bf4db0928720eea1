"""ArduPilot's mission item protocol in the simulator (helixd.sim.firmware.mission_items), one
type at a time and without the router: what an item must be to be stored, what is read back,
MISSION_ITEM's float coordinates, the guided requests outside the protocol, and one upload."""

from __future__ import annotations

import math
import os
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_MISSION,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_ERROR,
    MAV_MISSION_INVALID_PARAM1,
    MAV_MISSION_INVALID_PARAM5_X,
    MAV_MISSION_INVALID_PARAM6_Y,
    MAV_MISSION_INVALID_PARAM7,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_UNSUPPORTED,
    MAV_MISSION_UNSUPPORTED_FRAME,
)
from helixd.sim.firmware.mission_items import (
    ALTITUDE_ONLY,
    GUIDED_PLACE,
    MISSION_RULES,
    ItemProtocol,
    Outcome,
    StoredItem,
    fence_readback,
    guided_request,
    item_from_float,
    mission_readback,
    rally_readback,
    validate_fence_item,
    validate_mission_item,
    validate_rally_item,
)
from helixd.sim.firmware.rover_firmware import SimStatusText
from tests.support.mavmsgs import stamp

_mav = mavlink.MAVLink(None)
LAT_E7, LON_E7 = 535_000_000, -1_135_000_000
WP = StoredItem(16, MAV_FRAME_GLOBAL_RELATIVE_ALT, x=LAT_E7, y=LON_E7, z=5.0)


def float_item(x: float, y: float, frame: int = 3, current: int = 0, mission_type: int = 0) -> Any:
    return _mav.mission_item_encode(
        1, 1, 0, frame, 16, current, 1, 0.0, 0.0, 0.0, 0.0, x, y, 0.0, mission_type
    )


def test_a_mission_item_is_stored_only_as_arduplot_would() -> None:
    assert validate_mission_item(WP) == MAV_MISSION_ACCEPTED
    assert validate_mission_item(StoredItem(9999)) == MAV_MISSION_UNSUPPORTED
    assert validate_mission_item(StoredItem(16, param2=math.nan)) == MAV_MISSION_ERROR
    assert validate_mission_item(StoredItem(16, param1=70_000.0)) == MAV_MISSION_INVALID_PARAM1
    assert validate_mission_item(StoredItem(16, x=900_000_001)) == MAV_MISSION_INVALID_PARAM5_X
    assert validate_mission_item(StoredItem(16, y=-1_800_000_001)) == MAV_MISSION_INVALID_PARAM6_Y
    # a local frame: no lat/lng check, and frame 1 is not one ArduPilot stores
    assert validate_mission_item(StoredItem(16, MAV_FRAME_MISSION, x=10**9)) == MAV_MISSION_ACCEPTED
    assert validate_mission_item(StoredItem(16, 1)) == MAV_MISSION_UNSUPPORTED_FRAME


def test_fence_and_rally_items_have_their_own_rules() -> None:
    vertex = StoredItem(5001, MAV_FRAME_GLOBAL, param1=4.0, x=LAT_E7, y=LON_E7)
    assert validate_fence_item(vertex) == MAV_MISSION_ACCEPTED
    assert validate_fence_item(StoredItem(5001, MAV_FRAME_MISSION)) == MAV_MISSION_UNSUPPORTED_FRAME
    assert validate_fence_item(StoredItem(16, MAV_FRAME_GLOBAL)) == MAV_MISSION_UNSUPPORTED
    rally = StoredItem(5100, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, x=LAT_E7, y=LON_E7, z=30.0)
    assert validate_rally_item(rally) == MAV_MISSION_ACCEPTED
    assert validate_rally_item(StoredItem(5100, MAV_FRAME_GLOBAL)) == MAV_MISSION_UNSUPPORTED_FRAME
    too_high = StoredItem(5100, MAV_FRAME_GLOBAL_RELATIVE_ALT, z=40_000.0)
    assert validate_rally_item(too_high) == MAV_MISSION_INVALID_PARAM7


def test_what_is_read_back_is_what_arduplot_keeps() -> None:
    as_int = StoredItem(16, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, param2=2.0, x=LAT_E7, y=LON_E7)
    assert mission_readback(as_int).frame == MAV_FRAME_GLOBAL_RELATIVE_ALT  # _INT dropped
    assert mission_readback(as_int).param2 == 2.0
    vertex = StoredItem(5001, MAV_FRAME_GLOBAL_RELATIVE_ALT, 4.0, 7.0, 8.0, 9.0, LAT_E7, LON_E7, 3)
    assert fence_readback(vertex) == StoredItem(5001, 0, param1=4.0, x=LAT_E7, y=LON_E7)
    rally = StoredItem(5100, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 1.0, x=LAT_E7, y=LON_E7, z=12.7)
    back = rally_readback(rally)
    assert (back.frame, back.param1, back.z) == (MAV_FRAME_GLOBAL_RELATIVE_ALT, 0.0, 12.0)


def test_mission_item_floats_are_scaled_to_degE7_unless_local() -> None:
    got = item_from_float(float_item(53.5, -113.5))
    assert got is not None and (got.x, got.y) == (LAT_E7, LON_E7)
    local = item_from_float(float_item(12.5, -3.0, frame=MAV_FRAME_MISSION))
    assert local is not None and (local.x, local.y) == (12, -3)  # rounded, not scaled
    assert item_from_float(float_item(math.nan, 0.0)) is None
    assert item_from_float(float_item(300.0, 0.0)) is None  # beyond an int32 in degE7


def test_guided_requests_stand_outside_the_protocol() -> None:
    place = guided_request(float_item(53.5, -113.5, current=GUIDED_PLACE))
    assert place is not None and place.current == GUIDED_PLACE
    assert place.item is not None and place.item.x == LAT_E7
    assert place.result == MAV_MISSION_ACCEPTED
    bad = guided_request(float_item(95.0, 0.0, current=GUIDED_PLACE))
    assert bad is not None and bad.result == MAV_MISSION_INVALID_PARAM5_X
    assert guided_request(float_item(53.5, -113.5, current=ALTITUDE_ONLY)) is not None
    assert guided_request(float_item(53.5, -113.5, current=0)) is None  # a mission item
    assert guided_request(float_item(53.5, -113.5, current=2, mission_type=1)) is None
    assert guided_request(_mav.mission_count_encode(1, 1, 3, 0)) is None


def test_one_upload_on_one_protocol_is_requested_item_by_item_and_acked() -> None:
    home = StoredItem(16, MAV_FRAME_GLOBAL, x=LAT_E7, y=LON_E7)
    prot = ItemProtocol(MAV_MISSION_TYPE_MISSION, MISSION_RULES, 5, home)
    out = Outcome()
    prot.handle_count(out, 0, (255, 190), stamp(_mav.mission_count_encode(1, 1, 2, 0)), 0.0)
    assert prot.receiving
    assert [int(m.seq) for _, m in out.sends] == [0]  # MISSION_REQUEST 0
    for seq, item in enumerate((home, WP)):
        out = Outcome()
        prot.handle_item(out, 0, (255, 190), item, seq, 0.1)
    assert not prot.receiving
    assert [m.get_type() for _, m in out.sends] == ["MISSION_ACK"]
    assert int(out.sends[0][1].type) == MAV_MISSION_ACCEPTED
    assert out.texts == [SimStatusText(6, "Flight plan received", 0)]
    assert prot.item_at(0) == home and prot.item_at(1) == WP
    assert prot.item_at(2) is None
