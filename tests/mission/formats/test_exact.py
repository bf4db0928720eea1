"""Exactness of the one mission-item record (:class:`helixd.mav.mission_item.MissionItem`): the
wire's int32 x/y (degE7 on a place) survive receive → record → file item → upload → encode
unchanged, and a ``.waypoints`` file's 8-decimal places survive read → write, and read → items
for upload → file, unchanged (the record holds the degrees as read; degE7 only at the wire)."""

from __future__ import annotations

from dataclasses import astuple

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_MISSION_TYPE_FENCE,
)
from helixd.mav.mission_item import (
    PLACE_COMMANDS,
    MissionItem,
    item_from_message,
    wire_xy,
    xy_in_degrees,
)
from helixd.mission.formats.wire import gcs_to_wire, wire_to_gcs
from helixd.mission.formats.wpl import parse_wpl_text, wpl_to_text

i32 = st.integers(-(2**31), 2**31 - 1)
lat_e7 = st.integers(-900_000_000, 900_000_000).filter(lambda v: v != 0)
lon_e7 = st.integers(-1_800_000_000, 1_800_000_000).filter(lambda v: v != 0)
params = st.floats(allow_nan=False, allow_infinity=False, width=32)
commands = st.sampled_from([*sorted(PLACE_COMMANDS), 177, 178, 183, 112, 31000])
_mav = mavlink.MAVLink(None)


def received(
    seq: int, frame: int, command: int, x: int, y: int, *, mission_type: int = 0, **kw: float
) -> MissionItem:
    """A MISSION_ITEM_INT with these int32 x/y, packed and decoded, as the link receives it."""
    p = [float(kw.get(f"param{k}", 0.0)) for k in (1, 2, 3, 4)]
    msg = _mav.mission_item_int_encode(
        1, 1, seq, frame, command, 0, int(kw.get("autocontinue", 1)), *p, x, y,
        float(kw.get("z", 0.0)), mission_type,
    )  # fmt: skip
    item = item_from_message(_mav.decode(bytearray(msg.pack(_mav))))
    assert item is not None
    return item


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 255), st.integers(0, 65535), st.sampled_from([0, 1, 2]), i32, i32)
def test_int32_x_y_received_are_sent_again_bit_identical(
    frame: int, command: int, mission_type: int, x: int, y: int
) -> None:
    item = received(0, frame, command, x, y, mission_type=mission_type)
    assert wire_xy(item) == (x, y)
    degrees = xy_in_degrees(command, mission_type)
    assert (item.x, item.y) == ((x / 1e7, y / 1e7) if degrees else (float(x), float(y)))


@st.composite
def downloaded(draw: st.DrawFn) -> tuple[tuple[MissionItem, ...], tuple[MissionItem, ...]]:
    """A mission and fence as the link receives them: home in slot 0, items 1.., a polygon."""
    home = received(0, MAV_FRAME_GLOBAL, MAV_CMD_NAV_WAYPOINT, draw(lat_e7), draw(lon_e7))
    n = draw(st.integers(1, 6))
    items = tuple(
        received(
            seq,
            draw(st.integers(0, 255)),
            draw(commands),
            draw(i32),
            draw(i32),
            autocontinue=draw(st.sampled_from([0, 1])),
            param1=draw(params),
            param2=draw(params),
            param3=draw(params),
            param4=draw(params),
            z=draw(params),
        )
        for seq in range(1, n + 1)
    )
    k = draw(st.sampled_from([0, 3, 4]))
    fence = tuple(
        received(
            seq,
            MAV_FRAME_GLOBAL,
            MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            draw(lat_e7),
            draw(lon_e7),
            mission_type=MAV_MISSION_TYPE_FENCE,
            autocontinue=0,
            param1=float(k),
        )
        for seq in range(k)
    )
    return (home, *items), fence


def as_wire(items: tuple[MissionItem, ...]) -> list[tuple[object, ...]]:
    return [(*astuple(it)[:9], *wire_xy(it), it.z, it.mission_type) for it in items]


@settings(max_examples=300, deadline=None)
@given(downloaded())
def test_items_downloaded_and_uploaded_again_are_bit_identical(
    got: tuple[tuple[MissionItem, ...], tuple[MissionItem, ...]],
) -> None:
    mission, fence = got
    gcs, notes = wire_to_gcs(mission, fence)
    assert notes == []
    again = gcs_to_wire(gcs)
    assert as_wire(again.mission) == as_wire(mission)
    assert as_wire(again.fence) == as_wire(fence)
    assert again.mission == mission and again.fence == fence


def deg8(v: int) -> str:
    """An integer count of 1e-8 degrees as the 8-decimal text Mission Planner writes."""
    sign = "-" if v < 0 else ""
    return f"{sign}{abs(v) // 10**8}.{abs(v) % 10**8:08d}"


lat_e8 = st.integers(-9_000_000_000, 9_000_000_000).filter(lambda v: v != 0)
lon_e8 = st.integers(-18_000_000_000, 18_000_000_000).filter(lambda v: v != 0)


@st.composite
def waypoints_files(draw: st.DrawFn) -> str:
    zero = "0.00000000"
    rows = [
        "QGC WPL 110",
        "\t".join(["0", "1", "0", "16", zero, zero, zero, zero, deg8(draw(lat_e8)),
                   deg8(draw(lon_e8)), zero, "1"]),
    ]  # fmt: skip
    for i in range(1, draw(st.integers(1, 6)) + 1):
        rows.append(
            "\t".join([str(i), "0", "3", "16", zero, zero, zero, zero, deg8(draw(lat_e8)),
                       deg8(draw(lon_e8)), zero, "1"])
        )  # fmt: skip
    return "\n".join(rows) + "\n"


@settings(max_examples=200, deadline=None)
@given(waypoints_files())
def test_a_waypoints_file_read_and_written_again_keeps_its_8th_decimal(text: str) -> None:
    gcs = parse_wpl_text(text, "t.waypoints")
    assert wpl_to_text(gcs) == text
    # the items made ready for upload still hold the file's degrees (degE7 only when encoded)
    wire = gcs_to_wire(gcs)
    back, _ = wire_to_gcs(wire.mission, wire.fence)
    assert wpl_to_text(back) == text
    first = text.splitlines()[2].split("\t")
    assert (gcs.items[0].x, gcs.items[0].y) == (float(first[8]), float(first[9]))
