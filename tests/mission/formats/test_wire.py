"""helixd.mission.formats.wire: file items ⇄ MISSION_ITEM_INT items (mission and fence), the
one place the two item types meet. Round trips on the real test files, and totality under
hypothesis for anything a vehicle could send back."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.mav.constants import MAV_MISSION_TYPE_FENCE, MAV_MISSION_TYPE_MISSION
from helixd.mav.mission_item import MissionItem, wire_xy, xy_in_degrees
from helixd.mission.formats import read_gcs
from helixd.mission.formats.items import (
    FenceCircle,
    FencePolygon,
    FormatError,
    GcsMission,
)
from helixd.mission.formats.wire import fence_items, gcs_to_wire, wire_to_gcs
from tests.support.paths import DATA_DIR

DATA = DATA_DIR


def finite(v: float) -> float:
    return v if math.isfinite(v) else 0.0


def assert_round_trip(gcs: GcsMission) -> None:
    wire = gcs_to_wire(gcs)
    back, notes = wire_to_gcs(wire.mission, wire.fence)
    assert notes == []
    assert len(back.items) == len(gcs.items)
    for a, b in zip(gcs.items, back.items, strict=True):
        assert (b.seq, b.command, b.frame, b.autocontinue) == (
            a.seq, a.command, a.frame, a.autocontinue,
        )  # fmt: skip
        assert (b.param1, b.param2, b.param3, b.param4, b.z) == pytest.approx(
            tuple(finite(v) for v in (a.param1, a.param2, a.param3, a.param4, a.z))
        )
        assert (b.x, b.y) == pytest.approx((a.x, a.y), abs=0.6e-7)
    assert [p.inclusion for p in back.polygons] == [p.inclusion for p in gcs.polygons]
    for p, q in zip(back.polygons, gcs.polygons, strict=True):
        assert len(p.vertices_latlon_deg) == len(q.vertices_latlon_deg)
        for u, v in zip(p.vertices_latlon_deg, q.vertices_latlon_deg, strict=True):
            assert u == pytest.approx(v, abs=0.6e-7)
    assert [(c.inclusion, c.radius_m) for c in back.circles] == [
        (c.inclusion, pytest.approx(c.radius_m)) for c in gcs.circles
    ]


@pytest.mark.parametrize("name", ["pond_survey.plan", "sim_square.plan", "square.waypoints"])
def test_test_files_round_trip(name: str) -> None:
    assert_round_trip(read_gcs(DATA / name))


def test_home_is_seq_0_and_items_follow_as_qgc_sends_them() -> None:
    gcs = read_gcs(DATA / "pond_survey.plan")
    wire = gcs_to_wire(gcs)
    home = wire.mission[0]
    assert (home.seq, home.command, home.frame) == (0, 16, 0)
    assert gcs.home_latlon_deg is not None
    assert wire_xy(home) == (
        round(gcs.home_latlon_deg[0] * 1e7),
        round(gcs.home_latlon_deg[1] * 1e7),
    )
    assert [w.seq for w in wire.mission] == list(range(len(gcs.items) + 1))
    assert all(w.mission_type == MAV_MISSION_TYPE_MISSION for w in wire.mission)
    assert all(
        math.isfinite(v) for w in wire.mission for v in (w.param1, w.param2, w.param3, w.param4)
    )  # QGC's null params go out as 0 (ArduPilot refuses NaN)
    # fence: inclusion polygon, exclusion polygon, exclusion circle; param1 = count / radius
    cmds = [(w.command, w.param1) for w in wire.fence]
    assert cmds == [(5001, 4.0)] * 4 + [(5002, 4.0)] * 4 + [(5004, 6.0)]
    assert [w.seq for w in wire.fence] == list(range(9))
    assert all(w.mission_type == MAV_MISSION_TYPE_FENCE and w.frame == 0 for w in wire.fence)


def fw(
    seq: int, command: int, param1: float, lat: float = 53.5, lon: float = -113.5
) -> MissionItem:
    return MissionItem(
        seq=seq, frame=0, command=command, param1=param1, x=lat, y=lon,
        mission_type=MAV_MISSION_TYPE_FENCE,
    )  # fmt: skip


def test_a_polygon_cut_short_is_refused_by_item() -> None:
    fence = [fw(0, 5001, 4.0), fw(1, 5001, 4.0, 53.6), fw(2, 5001, 4.0, 53.6, -113.4)]
    with pytest.raises(FormatError, match="autopilot fence item 0: a polygon of 4 vertices"):
        wire_to_gcs([], fence)
    mixed = [fw(0, 5001, 3.0), fw(1, 5002, 3.0), fw(2, 5001, 3.0)]
    with pytest.raises(FormatError, match="not whole"):
        wire_to_gcs([], mixed)


def test_return_point_and_unknown_fence_commands_are_noted() -> None:
    fence = [fw(0, 5000, 0.0), fw(1, 5003, 25.0), fw(2, 16, 0.0)]
    gcs, notes = wire_to_gcs([], fence)
    assert gcs.circles == (FenceCircle((53.5, -113.5), 25.0, True),)
    assert len(notes) == 2 and "return point" in notes[0] and "command 16" in notes[1]


def test_nothing_to_upload_or_no_home_is_refused() -> None:
    with pytest.raises(FormatError, match="no mission items"):
        gcs_to_wire(GcsMission(items=()))
    jump = MissionItem(seq=1, frame=2, command=177, param1=1.0, param2=2.0)
    with pytest.raises(FormatError, match="no home position"):
        gcs_to_wire(GcsMission(items=(jump,)))
    bad = FencePolygon(((53.5, -113.5), (53.6, -113.5)), inclusion=True)
    with pytest.raises(FormatError, match="2 vertices"):
        fence_items(GcsMission(items=(), polygons=(bad,)))


lats = st.floats(-89.0, 89.0).filter(lambda v: abs(v) > 1e-3)
lons = st.floats(-179.0, 179.0).filter(lambda v: abs(v) > 1e-3)
params = st.one_of(st.floats(-1e6, 1e6), st.just(math.nan))


@st.composite
def gcs_missions(draw: st.DrawFn) -> GcsMission:
    n = draw(st.integers(1, 20))
    items = tuple(
        MissionItem(
            seq=i + 1,
            frame=draw(st.sampled_from([0, 3, 6])),
            command=draw(st.sampled_from([16, 17, 19, 21])),
            param1=draw(params),
            param4=draw(params),
            x=draw(lats),
            y=draw(lons),
            z=draw(st.floats(-100.0, 100.0)),
            autocontinue=draw(st.booleans()),
        )
        for i in range(n)
    )
    polygons = tuple(
        FencePolygon(
            tuple((draw(lats), draw(lons)) for _ in range(draw(st.integers(3, 8)))),
            draw(st.booleans()),
        )
        for _ in range(draw(st.integers(0, 3)))
    )
    circles = tuple(
        FenceCircle((draw(lats), draw(lons)), draw(st.floats(0.5, 5000.0)), draw(st.booleans()))
        for _ in range(draw(st.integers(0, 3)))
    )
    home = draw(st.one_of(st.none(), st.tuples(lats, lons)))
    return GcsMission(items=items, home_latlon_deg=home, polygons=polygons, circles=circles)


@settings(max_examples=150, deadline=None)
@given(gcs_missions())
def test_any_file_mission_round_trips_over_the_wire(gcs: GcsMission) -> None:
    assert_round_trip(gcs)


i32 = st.integers(-(2**31), 2**31 - 1)


@st.composite
def wire_items(draw: st.DrawFn) -> MissionItem:
    """Any item a vehicle could send back, x/y as item_from_message makes them of an int32."""
    command = draw(st.sampled_from([16, 177, 5000, 5001, 5002, 5003, 5004, 0, 65535]))
    degrees = xy_in_degrees(command, MAV_MISSION_TYPE_MISSION)
    x, y = draw(i32), draw(i32)
    return MissionItem(
        seq=draw(st.integers(0, 50)),
        frame=draw(st.integers(0, 255)),
        command=command,
        param1=draw(st.floats(allow_nan=True, allow_infinity=True)),
        x=x / 1e7 if degrees else float(x),
        y=y / 1e7 if degrees else float(y),
        z=draw(st.floats(-1e6, 1e6)),
    )


@settings(max_examples=300, deadline=None)
@given(st.lists(wire_items(), max_size=30), st.lists(wire_items(), max_size=30))
def test_anything_a_vehicle_sends_back_converts_or_is_refused_by_name(
    mission: list[MissionItem], fence: list[MissionItem]
) -> None:
    try:
        gcs, notes = wire_to_gcs(mission, fence)
    except FormatError as exc:
        assert exc.problems and all("autopilot fence item" in p for p in exc.problems)
        return
    assert all(isinstance(n, str) for n in notes)
    for p in gcs.polygons:
        assert len(p.vertices_latlon_deg) >= 3
    for c in gcs.circles:
        assert math.isfinite(c.radius_m) and c.radius_m > 0
