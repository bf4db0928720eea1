"""The media lookup: inside, outside, holes, boundaries, overlaps, placing lat/lon maps."""

from __future__ import annotations

import pytest

from helixd.base.frames import ne_to_latlon
from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium

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
