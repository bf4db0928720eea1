"""Exactness of the two mission-item forms, pinned so that merging them cannot lose a bit:
the wire's int32 x/y (degE7 on a place) survive download → file item → upload unchanged, and a
``.waypoints`` file's 8-decimal places survive read → write unchanged (the file item holds the
degrees as read, not a degE7 rounding of them)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.mav.constants import (
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_MISSION_TYPE_FENCE,
)
from helixd.mav.mission_item import WireItem
from helixd.mission.commands import PLACE_COMMANDS
from helixd.mission.formats.wire import gcs_to_wire, wire_to_gcs
from helixd.mission.formats.wpl import parse_wpl_text, wpl_to_text

i32 = st.integers(-(2**31), 2**31 - 1)
lat_e7 = st.integers(-900_000_000, 900_000_000).filter(lambda v: v != 0)
lon_e7 = st.integers(-1_800_000_000, 1_800_000_000).filter(lambda v: v != 0)
params = st.floats(allow_nan=False, allow_infinity=False, width=32)
commands = st.sampled_from([*sorted(PLACE_COMMANDS), 177, 178, 183, 112, 31000])


@st.composite
def uploaded(draw: st.DrawFn) -> tuple[tuple[WireItem, ...], tuple[WireItem, ...]]:
    """A mission and fence as helixd uploads them: home in slot 0, items 1.., a polygon."""
    home = WireItem(
        seq=0, frame=MAV_FRAME_GLOBAL, command=MAV_CMD_NAV_WAYPOINT, x=draw(lat_e7), y=draw(lon_e7)
    )
    n = draw(st.integers(1, 6))
    items = tuple(
        WireItem(
            seq=seq,
            frame=draw(st.integers(0, 255)),
            command=draw(commands),
            autocontinue=draw(st.sampled_from([0, 1])),
            param1=draw(params),
            param2=draw(params),
            param3=draw(params),
            param4=draw(params),
            x=draw(i32),
            y=draw(i32),
            z=draw(params),
        )
        for seq in range(1, n + 1)
    )
    k = draw(st.sampled_from([0, 3, 4]))
    fence = tuple(
        WireItem(
            seq=seq,
            frame=MAV_FRAME_GLOBAL,
            command=MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            autocontinue=0,
            param1=float(k),
            x=draw(lat_e7),
            y=draw(lon_e7),
            mission_type=MAV_MISSION_TYPE_FENCE,
        )
        for seq in range(k)
    )
    return (home, *items), fence


@settings(max_examples=300, deadline=None)
@given(uploaded())
def test_wire_items_downloaded_and_uploaded_again_are_bit_identical(
    got: tuple[tuple[WireItem, ...], tuple[WireItem, ...]],
) -> None:
    mission, fence = got
    gcs, notes = wire_to_gcs(mission, fence)
    assert notes == []
    again = gcs_to_wire(gcs)
    assert again.mission == mission
    assert again.fence == fence


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
    first = text.splitlines()[2].split("\t")
    assert (gcs.items[0].x, gcs.items[0].y) == (float(first[8]), float(first[9]))
