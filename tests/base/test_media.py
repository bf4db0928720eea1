"""The media lookup: inside, outside, holes, boundaries, overlaps, placing lat/lon maps."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.frames import ne_to_latlon
from helixd.base.media import (
    MediaArea,
    MediaFrame,
    MediaMap,
    Medium,
    RingIndex,
    media_along,
    on_ring,
)
from helixd.base.polygon import point_in_polygon

SQUARE = ((0.0, 0.0), (0.0, 10.0), (10.0, 10.0), (10.0, 0.0))  # (north_m, east_m)
HOLE = ((4.0, 4.0), (4.0, 6.0), (6.0, 6.0), (6.0, 4.0))


def local(*areas: MediaArea, default: Medium | None = None) -> MediaMap:
    return MediaMap(MediaFrame.LOCAL_NED, areas, default)


def test_inside_and_outside() -> None:
    ne = local(MediaArea(Medium.WATER, SQUARE)).to_ne(fallback=Medium.GRASS)
    assert ne.medium_at(5.0, 5.0) is Medium.WATER
    assert ne.medium_at(-0.01, 5.0) is Medium.GRASS
    assert ne.medium_at(5.0, 10.01) is Medium.GRASS
    assert ne.medium_at(float("nan"), 5.0) is Medium.GRASS


def test_the_files_default_beats_the_callers_fallback() -> None:
    ne = local(MediaArea(Medium.WATER, SQUARE), default=Medium.SAND).to_ne(fallback=Medium.GRASS)
    assert ne.medium_at(50.0, 50.0) is Medium.SAND


@pytest.mark.parametrize(
    "point", [(0.0, 0.0), (0.0, 5.0), (10.0, 10.0), (5.0, 10.0), (10.0, 3.0), (3.0, 0.0)]
)
def test_the_boundary_is_inside(point: tuple[float, float]) -> None:
    ne = local(MediaArea(Medium.WATER, SQUARE)).to_ne()
    assert ne.medium_at(*point) is Medium.WATER


def test_a_hole_is_outside_its_edge_inside() -> None:
    ne = local(MediaArea(Medium.WATER, SQUARE, (HOLE,))).to_ne(fallback=Medium.HARD)
    assert ne.medium_at(5.0, 5.0) is Medium.HARD
    assert ne.medium_at(4.0, 5.0) is Medium.WATER  # on the hole's edge
    assert ne.medium_at(3.9, 5.0) is Medium.WATER


def test_the_later_area_wins_where_areas_overlap() -> None:
    island = ((3.0, 3.0), (3.0, 7.0), (7.0, 7.0), (7.0, 3.0))
    ne = local(MediaArea(Medium.WATER, SQUARE), MediaArea(Medium.MUD, island)).to_ne()
    assert ne.medium_at(5.0, 5.0) is Medium.MUD
    assert ne.medium_at(1.0, 1.0) is Medium.WATER
    assert ne.medium_at(3.0, 5.0) is Medium.MUD  # the later area's boundary
    flipped = local(MediaArea(Medium.MUD, island), MediaArea(Medium.WATER, SQUARE)).to_ne()
    assert flipped.medium_at(5.0, 5.0) is Medium.WATER
    area = ne.area_at(5.0, 5.0)
    assert area is not None and area.medium is Medium.MUD


def test_a_concave_area() -> None:
    ell = ((0.0, 0.0), (0.0, 10.0), (2.0, 10.0), (2.0, 2.0), (10.0, 2.0), (10.0, 0.0))
    ne = local(MediaArea(Medium.SAND, ell)).to_ne()
    assert ne.medium_at(1.0, 8.0) is Medium.SAND
    assert ne.medium_at(8.0, 1.0) is Medium.SAND
    assert ne.medium_at(8.0, 8.0) is Medium.HARD


def test_a_global_map_is_placed_in_the_ekf_frame_around_the_origin() -> None:
    origin = (53.52325, -113.52632)
    ring = tuple(ne_to_latlon(n, e, *origin) for n, e in SQUARE)
    m = MediaMap(MediaFrame.GLOBAL, (MediaArea(Medium.WATER, ring),))
    with pytest.raises(ValueError, match="need an origin"):
        m.to_ne()
    ne = m.to_ne(origin)
    assert ne.areas[0].outer_ne[2] == pytest.approx((10.0, 10.0), abs=1e-6)
    assert ne.medium_at(9.99, 9.99) is Medium.WATER
    assert ne.medium_at(10.01, 5.0) is Medium.HARD


def test_a_leg_is_cut_where_the_medium_changes() -> None:
    island = ((4.0, 4.0), (4.0, 6.0), (6.0, 6.0), (6.0, 4.0))
    ne = local(MediaArea(Medium.WATER, SQUARE), MediaArea(Medium.MUD, island)).to_ne()
    runs = media_along(ne, (5.0, -5.0), (5.0, 15.0))  # west to east across the pond
    assert [r.medium for r in runs] == [
        Medium.HARD,
        Medium.WATER,
        Medium.MUD,
        Medium.WATER,
        Medium.HARD,
    ]
    assert [r.start_ne[1] for r in runs] == pytest.approx([-5.0, 0.0, 4.0, 6.0, 10.0])
    assert runs[0].start_ne == (5.0, -5.0) and runs[-1].end_ne == (5.0, 15.0)
    assert runs[0].start_fraction == 0.0 and runs[-1].end_fraction == 1.0
    assert sum(r.length_m for r in runs) == pytest.approx(20.0)
    for before, after in itertools.pairwise(runs):
        assert before.end_fraction == after.start_fraction


def test_legs_inside_one_medium_along_an_edge_and_of_no_length() -> None:
    ne = local(MediaArea(Medium.WATER, SQUARE)).to_ne()
    (inside,) = media_along(ne, (1.0, 1.0), (9.0, 9.0))
    assert inside.medium is Medium.WATER and inside.length_m == pytest.approx(8 * 2**0.5)
    (edge,) = media_along(ne, (0.0, 2.0), (0.0, 8.0))  # along the south edge: in the area
    assert edge.medium is Medium.WATER
    along = media_along(ne, (0.0, -2.0), (0.0, 12.0))
    assert [(r.medium, r.start_ne[1]) for r in along] == [
        (Medium.HARD, -2.0),
        (Medium.WATER, 0.0),
        (Medium.HARD, pytest.approx(10.0)),
    ]
    (point,) = media_along(ne, (5.0, 5.0), (5.0, 5.0))
    assert point.medium is Medium.WATER and point.length_m == 0.0


@settings(max_examples=200, deadline=None)
@given(
    st.tuples(st.floats(-20, 20), st.floats(-20, 20)),
    st.tuples(st.floats(-20, 20), st.floats(-20, 20)),
)
def test_runs_agree_with_the_point_lookup(a: tuple[float, float], b: tuple[float, float]) -> None:
    island = ((3.0, 3.0), (3.0, 7.0), (7.0, 7.0), (7.0, 3.0))
    ne = local(MediaArea(Medium.WATER, SQUARE, (HOLE,)), MediaArea(Medium.MUD, island)).to_ne()
    runs = media_along(ne, a, b)
    assert runs[0].start_fraction == 0.0 and runs[-1].end_fraction == 1.0
    if math.dist(a, b) < 1e-9:  # a leg shorter than 1 nm is a point: the medium at its start
        assert [r.medium for r in runs] == [ne.medium_at(*a)]
        return
    rings = [ring for area in ne.areas for ring in (area.outer_ne, *area.holes_ne)]
    for r in runs:
        mid = ((r.start_ne[0] + r.end_ne[0]) / 2, (r.start_ne[1] + r.end_ne[1]) / 2)
        # the middle of a run is in its medium, unless the leg only touches a corner there
        assert ne.medium_at(*mid) is r.medium or any(on_ring(*mid, ring) for ring in rings)
    for before, after in itertools.pairwise(runs):
        assert before.medium is not after.medium


@settings(max_examples=300, deadline=None)
@given(st.floats(-5, 15), st.floats(-5, 15))
def test_lookup_matches_even_odd_away_from_edges(north_m: float, east_m: float) -> None:
    island = ((3.0, 3.0), (3.0, 7.0), (7.0, 7.0), (7.0, 3.0))
    ne = local(MediaArea(Medium.WATER, SQUARE), MediaArea(Medium.MUD, island)).to_ne()
    if min(abs(north_m - v) for v in (0, 3, 7, 10)) < 1e-6:
        return
    if min(abs(east_m - v) for v in (0, 3, 7, 10)) < 1e-6:
        return
    expected = (
        Medium.MUD
        if point_in_polygon(north_m, east_m, island)
        else Medium.WATER
        if point_in_polygon(north_m, east_m, SQUARE)
        else Medium.HARD
    )
    assert ne.medium_at(north_m, east_m) is expected


def star(points: int, seed: float) -> tuple[tuple[float, float], ...]:
    """A spiky, concave ring of 2·points vertices (radius 10 m and 3..9 m alternating)."""
    out = []
    for i in range(2 * points):
        r = 10.0 if i % 2 == 0 else 3.0 + 6.0 * abs(math.sin(seed * (i + 1)))
        a = math.pi * i / points + seed
        out.append((r * math.cos(a), r * math.sin(a)))
    return tuple(out)


@settings(max_examples=300, deadline=None)
@given(
    st.integers(3, 400),
    st.floats(0.01, 3.0),
    st.floats(-12, 12),
    st.floats(-12, 12),
)
def test_the_east_index_answers_as_the_whole_ring(
    points: int, seed: float, north_m: float, east_m: float
) -> None:
    ring = star(points, seed)
    index = RingIndex(ring)
    assert index.locate(north_m, east_m) == (
        point_in_polygon(north_m, east_m, ring),
        on_ring(north_m, east_m, ring),
    )
    for vertex in ring[:: max(1, len(ring) // 7)]:  # vertices are on the ring
        assert index.locate(*vertex)[1]


def test_a_ring_of_long_edges_answers_as_the_whole_ring() -> None:
    """Every edge of a zigzag spans the whole east range: the index falls back to few bins
    (hostile rings stay small) and still answers right."""
    zigzag = tuple((i * 0.5, 0.0 if i % 2 == 0 else 100.0) for i in range(400))
    index = RingIndex(zigzag)
    for n in (0.1, 33.3, 99.9, 150.0):
        for e in (0.0, 0.2, 50.0, 99.99, 100.0, 101.0):
            expected = (point_in_polygon(n, e, zigzag), on_ring(n, e, zigzag))
            assert index.locate(n, e) == expected
