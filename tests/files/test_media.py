"""Media map files: the GeoJSON reader, its refusals (one line naming file and feature), fuzz."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.media import MediaFrame, Medium
from helixd.files.media import (
    MAX_FEATURES,
    MediaMapError,
    media_map_from_kml,
    media_map_from_obj,
    media_map_from_text,
    read_media_map,
)
from tests.support.paths import REPO_ROOT

SRC = "m.geojson"
SQUARE_LONLAT = [
    [-113.5263, 53.5233],
    [-113.5260, 53.5233],
    [-113.5260, 53.5235],
    [-113.5263, 53.5235],
    [-113.5263, 53.5233],
]


def feature(medium: Any, coords: Any, kind: str = "Polygon") -> dict[str, Any]:
    return {
        "type": "Feature",
        "properties": {"medium": medium, "name": "x"},
        "geometry": {"type": kind, "coordinates": coords},
    }


def collection(*features: Any, **top: Any) -> dict[str, Any]:
    return {"type": "FeatureCollection", **top, "features": list(features)}


def refusal(raw: Any) -> list[str]:
    with pytest.raises(MediaMapError) as exc:
        media_map_from_obj(raw, SRC)
    for line in exc.value.problems:
        assert line.startswith(f"{SRC}: ") and "\n" not in line
    return exc.value.problems


def test_a_global_map_reads_lat_lon_from_lon_lat_positions() -> None:
    hole = [
        [-113.52620, 53.52335],
        [-113.52615, 53.52335],
        [-113.52615, 53.52340],
        [-113.52620, 53.52335],
    ]
    m = media_map_from_obj(
        collection(
            feature("water", [SQUARE_LONLAT, hole]),
            feature("mud", [[SQUARE_LONLAT]], "MultiPolygon"),
            default_medium="grass",
        ),
        SRC,
    )
    assert m.frame is MediaFrame.GLOBAL and m.needs_origin
    assert m.default_medium is Medium.GRASS
    assert [a.medium for a in m.areas] == [Medium.WATER, Medium.MUD]
    assert [a.feature_index for a in m.areas] == [0, 1]
    assert m.areas[0].outer[0] == (53.5233, -113.5263)  # (lat, lon), not closed
    assert len(m.areas[0].outer) == 4 and len(m.areas[0].holes) == 1


def test_a_local_map_reads_east_north_metres() -> None:
    ring = [[-5, 0], [5, 0], [5, 20], [-5, 20], [-5, 0]]  # [east_m, north_m]
    m = media_map_from_obj(collection(feature("sand", [ring]), frame="local_ned"), SRC)
    assert m.frame is MediaFrame.LOCAL_NED and not m.needs_origin
    assert m.areas[0].outer[2] == (20.0, 5.0)  # (north_m, east_m)
    ne = m.to_ne()
    assert ne.medium_at(10.0, 0.0) is Medium.SAND
    assert ne.medium_at(10.0, 6.0) is Medium.HARD  # the fallback: the file names no default


def test_the_shipped_pond_map_reads_and_places_around_the_simulators_origin() -> None:
    m = read_media_map(REPO_ROOT / "config/maps/pond-media.geojson")
    ne = m.to_ne((53.52325, -113.52632), fallback=Medium.SAND)
    assert ne.medium_at(0.0, 0.0) is Medium.HARD  # the south bank: the file's default
    assert ne.medium_at(4.0, 10.0) is Medium.MUD
    assert ne.medium_at(25.0, 10.0) is Medium.WATER
    assert ne.medium_at(32.0, 5.0) is Medium.HARD  # the berm island
    assert ne.medium_at(19.5, 0.0) is Medium.HARD  # the pontoon


@pytest.mark.parametrize(
    ("raw", "expected"),
    [
        ([], "expected a GeoJSON FeatureCollection"),
        ({"type": "Feature"}, "expected a GeoJSON FeatureCollection, got 'Feature'"),
        (collection(colour="blue"), "unknown top-level member 'colour'"),
        (collection(frame="utm"), "frame: 'utm'"),
        (collection(default_medium="lava"), "default_medium: 'lava'"),
        ({"type": "FeatureCollection", "features": {}}, "features: expected a list"),
        (collection(), "no features and no default_medium"),
        (collection(3), "features.0: expected a GeoJSON Feature"),
        (collection(feature("lava", [SQUARE_LONLAT])), "features.0.properties.medium: 'lava'"),
        (collection(feature(None, [SQUARE_LONLAT])), "features.0.properties.medium: None"),
        (collection(feature("WATER", [SQUARE_LONLAT])), "features.0.properties.medium"),
        (
            collection({**feature("mud", [SQUARE_LONLAT]), "properties": None}),
            "features.0.properties",
        ),
        (collection(feature("mud", [[0, 0]], "Point")), "features.0.geometry.type: 'Point'"),
        (collection({**feature("mud", []), "geometry": None}), "features.0.geometry: expected"),
        (
            collection(feature("mud", [])),
            "features.0.geometry.coordinates: expected a list of rings",
        ),
        (collection(feature("mud", [], "MultiPolygon")), "non-empty list of polygons"),
        (
            collection(feature("mud", [SQUARE_LONLAT[:-1]])),
            "coordinates.0: the ring is not closed",
        ),
        (
            collection(feature("mud", [SQUARE_LONLAT[:2] + SQUARE_LONLAT[:1]])),
            "at least 4 positions",
        ),
        (
            collection(feature("mud", [[[0, 0], [0.0001, 0], [0.0002, 0], [0, 0]]])),
            "degenerate or collinear",
        ),
        (
            collection(feature("mud", [[[-200, 0], [1, 0], [1, 1], [-200, 0]]])),
            "coordinates.0.0: [lon, lat]",
        ),
        (
            collection(feature("mud", [[[0, 0], ["1", 0], [1, 1], [0, 0]]])),
            "coordinates.0.1: expected a position",
        ),
        (
            collection(feature("mud", [[[0, 0], [1, 0, 0, 0], [1, 1], [0, 0]]])),
            "coordinates.0.1",
        ),
        (collection(feature("mud", [[[0, 0], [True, 0], [1, 1], [0, 0]]])), "coordinates.0.1"),
        (
            collection(
                feature("mud", [[[0, 0], [0.01, 0], [0.01, 0.01], [0, 0]]]),
                feature("mud", [[[10, 0], [10.01, 0], [10.01, 0.01], [10, 0]]]),
            ),
            "features.1.geometry.coordinates.0: a vertex",
        ),
        (
            collection(feature("mud", [[[0, 0], [2e5, 0], [0, 5], [0, 0]]]), frame="local_ned"),
            "beyond ±100000 m",
        ),
        (
            collection(
                feature("mud", [SQUARE_LONLAT]),
                crs={"type": "name", "properties": {"name": "EPSG:3857"}},
            ),
            "crs:",
        ),
        (
            collection(
                feature("mud", [SQUARE_LONLAT]),
                frame="local_ned",
                crs={"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}},
            ),
            "crs:",
        ),
        (collection(*([feature("mud", [SQUARE_LONLAT])] * (MAX_FEATURES + 1))), "at most 1000"),
    ],
)
def test_each_refusal_is_one_line_naming_the_file_and_the_feature(raw: Any, expected: str) -> None:
    problems = refusal(raw)
    assert any(expected in line for line in problems), problems


def test_every_bad_feature_is_named_not_only_the_first() -> None:
    good = feature("mud", [SQUARE_LONLAT])
    problems = refusal(collection(good, feature("lava", []), good, feature("mud", [[]])))
    assert [p.split(":")[1].strip().split(".")[0:2] for p in problems] == [
        ["features", "1"],
        ["features", "3"],
    ]


def test_a_wgs84_crs_member_is_accepted() -> None:
    crs = {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}}
    assert media_map_from_obj(collection(feature("mud", [SQUARE_LONLAT]), crs=crs), SRC).areas


def test_text_and_file_refusals(tmp_path: Path) -> None:
    for text, expected in [
        ('{"type": "FeatureCollection", "features": [], "features": []}', "duplicate key"),
        ('{"type": NaN}', "NaN is not a number"),
        ("[" * 100 + "]" * 100, "nested deeper"),
        ("{", "not valid JSON"),
    ]:
        with pytest.raises(MediaMapError) as exc:
            media_map_from_text(text, SRC)
        assert exc.value.message.startswith(SRC) and expected in exc.value.message
    for name, expected in [("a.shp", "unknown media map file type"), ("b.geojson", "not found")]:
        with pytest.raises(MediaMapError) as exc:
            read_media_map(tmp_path / name)
        assert expected in exc.value.message
    bom = tmp_path / "bom.geojson"
    bom.write_text("\ufeff" + json.dumps(collection(feature("mud", [SQUARE_LONLAT]))), "utf-8")
    assert read_media_map(bom).areas[0].medium is Medium.MUD


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=8), inner, max_size=5)
    ),
    max_leaves=30,
)
POSITION = st.lists(
    st.floats(-200, 200) | st.integers(-200, 200) | st.text(max_size=2), min_size=0, max_size=4
)
FEATURE = st.fixed_dictionaries(
    {
        "type": st.sampled_from(["Feature", "feature", "Polygon"]),
        "properties": st.fixed_dictionaries({"medium": st.sampled_from([*Medium, "lava", 3, None])})
        | JSON,
        "geometry": st.fixed_dictionaries(
            {
                "type": st.sampled_from(["Polygon", "MultiPolygon", "Point"]),
                "coordinates": st.lists(st.lists(POSITION, max_size=6), max_size=3) | JSON,
            }
        )
        | JSON,
    }
)


@settings(max_examples=300, deadline=None)
@given(
    st.fixed_dictionaries(
        {
            "type": st.sampled_from(["FeatureCollection", "Feature"]),
            "features": st.lists(FEATURE | JSON, max_size=4),
        },
        optional={
            "frame": st.sampled_from(["global", "local_ned", "x"]),
            "default_medium": st.sampled_from([*Medium, "x"]),
        },
    )
    | JSON
)
def test_fuzz_the_reader_reads_or_refuses_in_lines_never_crashes(raw: Any) -> None:
    try:
        m = media_map_from_obj(raw, SRC)
    except MediaMapError as exc:
        assert all(p.startswith(f"{SRC}: ") and "\n" not in p for p in exc.problems)
        return
    ne = m.to_ne((0.0, 0.0))
    for area in m.areas:
        assert len(area.outer) >= 3
        n, e = ne.areas[0].outer_ne[0]
        assert ne.medium_at(n, e) in Medium


@settings(max_examples=200, deadline=None)
@given(st.text(max_size=200) | st.binary(max_size=200).map(lambda b: b.decode("latin-1")))
def test_fuzz_text_never_crashes(text: str) -> None:
    try:
        media_map_from_text(text, SRC)
    except MediaMapError as exc:
        assert all(p.startswith(f"{SRC}") and "\n" not in p for p in exc.problems)


def kml(*placemarks: str) -> str:
    body = "".join(placemarks)
    return f'<?xml version="1.0"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document>{body}</Document></kml>'


def placemark(medium_xml: str, *polygons: str) -> str:
    return f"<Placemark><name>x</name>{medium_xml}<MultiGeometry>{''.join(polygons)}</MultiGeometry></Placemark>"  # noqa: E501


def polygon(*rings: str) -> str:
    outer, *holes = rings
    inner = "".join(
        f"<innerBoundaryIs><LinearRing><coordinates>{h}</coordinates></LinearRing></innerBoundaryIs>"
        for h in holes
    )
    return f"<Polygon><outerBoundaryIs><LinearRing><coordinates>{outer}</coordinates></LinearRing></outerBoundaryIs>{inner}</Polygon>"  # noqa: E501


RING = " ".join(f"{lon},{lat},0" for lon, lat in SQUARE_LONLAT)
HOLE = "-113.5262,53.52335 -113.52615,53.52335 -113.52615,53.5234 -113.5262,53.52335"
DATA = '<ExtendedData><Data name="medium"><value>water</value></Data></ExtendedData>'
SIMPLE = '<ExtendedData><SchemaData schemaUrl="#s"><SimpleData name="medium">mud</SimpleData></SchemaData></ExtendedData>'  # noqa: E501


def test_a_kml_map_reads_placemarks_with_their_medium(tmp_path: Path) -> None:
    path = tmp_path / "pond.kml"
    path.write_text(
        kml(placemark(DATA, polygon(RING, HOLE), polygon(RING)), placemark(SIMPLE, polygon(RING))),
        "utf-8",
    )
    m = read_media_map(path)
    assert m.frame is MediaFrame.GLOBAL
    assert [(a.medium, a.feature_index, len(a.holes)) for a in m.areas] == [
        (Medium.WATER, 0, 1),
        (Medium.WATER, 0, 0),
        (Medium.MUD, 1, 0),
    ]
    assert m.areas[0].outer[0] == (53.5233, -113.5263)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ('<!DOCTYPE kml [<!ENTITY a "b">]><kml/>', "DOCTYPE/ENTITY declarations"),
        ("<kml><Placemark>", "not valid XML"),
        (kml(), "no features and no default_medium"),
        (kml(placemark("", polygon(RING))), "Placemark 0 ExtendedData medium: None"),
        (kml(placemark(DATA.replace("water", "lava"), polygon(RING))), "medium: 'lava'"),
        (kml(placemark(DATA)), "Placemark 0 Polygon: expected a non-empty list"),
        (
            kml(placemark(DATA, polygon(RING)), placemark(DATA, polygon("1,2 x,y 3,4 1,2"))),
            "Placemark 1 Polygon.0.0.1: expected a position",
        ),
        (kml(placemark(DATA, polygon(RING.rsplit(" ", 1)[0]))), "the ring is not closed"),
    ],
)
def test_kml_refusals_name_the_placemark(text: str, expected: str) -> None:
    with pytest.raises(MediaMapError) as exc:
        media_map_from_kml(text, SRC)
    assert all(p.startswith(f"{SRC}: ") for p in exc.value.problems)
    assert any(expected in p for p in exc.value.problems), exc.value.problems


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet='<>/=" ,.-0123456789abcdefkmlPolygonPlacemarkcoordinates', max_size=300))
def test_fuzz_kml_text_never_crashes(text: str) -> None:
    try:
        media_map_from_kml(text, SRC)
    except MediaMapError as exc:
        assert all(p.startswith(SRC) and "\n" not in p for p in exc.problems)


@pytest.mark.parametrize(
    ("ring", "at"),
    [
        # a water ring once accepted as "OK" (its signed area is not zero)
        ([[0, 10], [20, 40], [20, 10], [0, 20], [0, 10]], "[east_m, north_m] [5, 17.5]"),
        # a symmetric bow-tie: refused only as "area 0 m² below 1.0 m²" before
        ([[0, 0], [10, 10], [10, 0], [0, 10], [0, 0]], "[east_m, north_m] [5, 5]"),
    ],
)
def test_a_self_intersecting_polygon_is_refused_saying_so_and_where(
    ring: list[list[float]], at: str
) -> None:
    problems = refusal(collection(feature("water", [ring]), frame="local_ned"))
    assert len(problems) == 1
    assert "features.0.geometry.coordinates: self-intersecting at " + at in problems[0]
    assert "Self-intersection" in problems[0]  # shapely's explain_validity, quoted


def test_a_hole_crossing_its_outer_ring_is_refused_as_self_intersecting() -> None:
    outer = [[0, 0], [20, 0], [20, 20], [0, 20], [0, 0]]
    hole = [[10, 5], [30, 5], [30, 15], [10, 15], [10, 5]]
    problems = refusal(collection(feature("water", [outer, hole]), frame="local_ned"))
    assert "self-intersecting at [east_m, north_m]" in problems[0]


def test_a_self_intersecting_lat_lon_polygon_names_the_place_in_lon_lat() -> None:
    a, b = SQUARE_LONLAT[0], SQUARE_LONLAT[2]
    bow = [a, b, [b[0], a[1]], [a[0], b[1]], a]
    problems = refusal(collection(feature("mud", [bow])))
    assert "self-intersecting at [lon, lat] [-113.52615, 53.5234]" in problems[0]


def test_the_shipped_media_maps_are_not_self_intersecting() -> None:
    for path in sorted((REPO_ROOT / "config" / "maps").glob("*media*.geojson")):
        assert read_media_map(path).areas
