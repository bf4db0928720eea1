"""Ground-station mission files: QGroundControl .plan and WPL 110 .waypoints, read, converted,
written; every file treated as hostile."""

from __future__ import annotations

import contextlib
import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from helixd.base.frames import latlon_to_ne
from helixd.base.plan import MotionMode
from helixd.files.models import ConfigFileError
from helixd.mission.formats import (
    MissionFormat,
    load_mission_file,
    plan_fence_ne,
    read_gcs,
    write_mission_file,
)
from helixd.mission.formats.items import FormatError, items_to_mission
from helixd.mission.formats.qgc_plan import parse_plan_text
from helixd.mission.formats.wpl import parse_wpl_text
from helixd.mission.model import Mission
from tests.support.paths import DATA_DIR

DATA = DATA_DIR
PLAN = DATA / "pond_survey.plan"
WPL = DATA / "square.waypoints"
SCROLL = MotionMode.SCROLL


# -- the QGroundControl .plan with a Survey -----------------------------------------------------


def test_plan_commands_are_kept_in_order_not_refused() -> None:
    """The camera triggers the Survey holds and the closing RTL are mission entries now, in
    their places (item numbers as QGC uploads them: 1..8)."""
    msn = load_mission_file(PLAN, mode=SCROLL).mission
    names = [wp.name for wp in msn.waypoints]
    assert names == [
        "NAV_WAYPOINT",
        "NAV_WAYPOINT",
        "DO_SET_CAM_TRIGG_DIST",
        "NAV_WAYPOINT",
        "NAV_WAYPOINT",
        "NAV_WAYPOINT",
        "DO_SET_CAM_TRIGG_DIST",
        "NAV_RETURN_TO_LAUNCH",
    ]
    assert msn.waypoints[2].param(0) > 0 and msn.waypoints[6].param(0) == 0.0
    assert msn.home == (53.52325, -113.52611)


def test_plan_survey_waypoints_and_fence() -> None:
    loaded = load_mission_file(PLAN, mode=SCROLL)
    msn = loaded.mission
    assert loaded.format is MissionFormat.PLAN
    assert msn.frame.value == "global" and msn.mode is SCROLL and msn.name == "pond_survey"
    # the SimpleItem, then the four transect ends the Survey item holds
    assert msn.points() == [
        (53.5233, -113.52605),
        (53.52335, -113.526),
        (53.52335, -113.5257),
        (53.52344, -113.5257),
        (53.52344, -113.526),
    ]
    # the one inclusion polygon becomes the mission's keep-in fence
    assert msn.geofence_polygon[0] == (53.523, -113.5265)
    gcs = loaded.gcs
    assert gcs is not None and gcs.home_latlon_deg == (53.52325, -113.52611)
    assert len(gcs.survey_polygons) == 1


def test_plan_fence_as_local_obstacles() -> None:
    origin = (53.52325, -113.52611)
    fence = plan_fence_ne(PLAN, origin)
    assert len(fence.inclusion_polygons) == 1 and len(fence.exclusion_polygons) == 1
    assert len(fence.exclusion_circles) == 1 and not fence.inclusion_circles
    circle = fence.exclusion_circles[0]
    assert circle.radius_m == 6.0
    n, e = latlon_to_ne(53.5236, -113.5258, *origin)
    assert circle.centre_ne_m == pytest.approx((n, e))
    hole = fence.exclusion_polygons[0]
    assert hole[0] == pytest.approx(latlon_to_ne(53.5238, -113.526, *origin))


def test_an_inclusion_circle_becomes_the_fence() -> None:
    doc = json.loads(PLAN.read_text())
    doc["geoFence"]["polygons"] = []
    doc["geoFence"]["circles"] = [
        {"circle": {"center": [53.5234, -113.5259], "radius": 60}, "inclusion": True}
    ]
    gcs = parse_plan_text(json.dumps(doc), "c.plan")
    msn = items_to_mission(gcs, name="c", mode=SCROLL).mission
    assert len(msn.geofence_polygon) == 64
    for lat, lon in msn.geofence_polygon:
        n, e = latlon_to_ne(lat, lon, 53.5234, -113.5259)
        assert math.hypot(n, e) == pytest.approx(60.0, abs=1e-6)


def test_keep_outs_of_the_plan_are_refused() -> None:
    doc = json.loads(PLAN.read_text())
    # the exclusion circle moved onto the survey's second transect end (item 4)
    doc["geoFence"]["circles"][0]["circle"]["center"] = [53.52335, -113.5257]
    # the exclusion polygon moved across the leg item 5 → item 6 (lat 53.52344, lon -113.5257
    # → -113.526), between its ends
    doc["geoFence"]["polygons"][1]["polygon"] = [
        [53.52340, -113.52590],
        [53.52340, -113.52585],
        [53.52350, -113.52585],
        [53.52350, -113.52590],
    ]
    gcs = parse_plan_text(json.dumps(doc), "k.plan")
    with pytest.raises(FormatError) as err:
        items_to_mission(gcs, name="k", mode=SCROLL, source="k.plan")
    assert err.value.problems == [
        "k.plan: leg item 5 → item 6 crosses the geofence's exclusion polygon 0 "
        "(helixd flies straight legs)",
        "k.plan: item 4 (mission.items.1 survey item 2): inside the geofence's exclusion "
        "circle 0 (6 m)",
    ]


# -- Mission Planner .waypoints --------------------------------------------------------------------


def test_waypoints_home_row_is_not_flown_and_items_are_numbered() -> None:
    loaded = load_mission_file(WPL, mode=MotionMode.ROLL)
    assert loaded.mission.points()[0] == (53.5233, -113.52605)  # row 1, not home (row 0)
    assert len(loaded.mission.points()) == 4
    speed = loaded.mission.waypoints[2]  # item 3 (line 5): the DO_CHANGE_SPEED, kept
    assert speed.name == "DO_CHANGE_SPEED" and speed.param(1) == 0.5
    gcs = read_gcs(WPL)
    assert gcs.home_latlon_deg == (53.52325, -113.52611)


def test_windows_line_ends_and_bom(tmp_path: Path) -> None:
    """Mission Planner on Windows: CRLF line ends, sometimes a UTF-8 BOM."""
    f = tmp_path / "mp.waypoints"
    f.write_bytes(b"\xef\xbb\xbf" + WPL.read_text().replace("\n", "\r\n").encode())
    a = load_mission_file(f, mode=SCROLL).mission
    b = load_mission_file(WPL, mode=SCROLL).mission
    assert a.points() == b.points()
    p = tmp_path / "bom.plan"
    p.write_bytes(b"\xef\xbb\xbf" + PLAN.read_bytes())
    assert load_mission_file(p, mode=SCROLL).mission.points()


def test_no_mode_no_flight() -> None:
    with pytest.raises(ConfigFileError, match="--mode"):
        load_mission_file(WPL)


# -- round trips through convert ---------------------------------------------------------------


@pytest.mark.parametrize("chain", [(".plan",), (".waypoints",), (".plan", ".waypoints", ".yaml")])
def test_round_trip(tmp_path: Path, chain: tuple[str, ...]) -> None:
    start = load_mission_file(PLAN, mode=SCROLL).mission
    msn = start
    for k, suffix in enumerate((*chain, ".yaml")):
        out = tmp_path / f"step{k}{suffix}"
        write_mission_file(msn, out)
        msn = load_mission_file(out, mode=SCROLL).mission
    for (a, b), (c, d) in zip(start.points(), msn.points(), strict=True):
        assert a == pytest.approx(c, abs=1e-8) and b == pytest.approx(d, abs=1e-8)
    if ".waypoints" not in chain:
        assert msn.geofence_polygon == start.geofence_polygon


def test_yaml_round_trip_is_exact(tmp_path: Path) -> None:
    start = load_mission_file(PLAN, mode=SCROLL).mission
    start = start.model_copy(update={"time_limit_s": 9000.0, "speed_mps": 0.5})
    write_mission_file(start, tmp_path / "a.yaml")
    assert load_mission_file(tmp_path / "a.yaml").mission == start


def test_written_plan_is_what_qgc_reads(tmp_path: Path) -> None:
    msn = load_mission_file(WPL, mode=SCROLL).mission
    write_mission_file(msn, tmp_path / "a.plan")
    doc = json.loads((tmp_path / "a.plan").read_text())
    assert doc["fileType"] == "Plan" and doc["mission"]["vehicleType"] == 10
    items = doc["mission"]["items"]
    assert [it["doJumpId"] for it in items] == [1, 2, 3, 4, 5]
    assert items[0]["params"][3] == 0.0  # yaw as Mission Planner wrote it (kept, not made up)
    assert items[0]["params"][4:6] == [53.5233, -113.52605]
    # the DO_CHANGE_SPEED as Mission Planner wrote it: type 1, 0.5 m/s, throttle -1
    assert items[2]["command"] == 178 and items[2]["params"][:3] == [1.0, 0.5, -1.0]
    assert items[2]["frame"] == 3


def test_local_missions_cannot_go_on_a_map(tmp_path: Path) -> None:
    msn = Mission.model_validate(
        {"name": "s", "mode": "roll", "frame": "start", "waypoints": [{"x": 1, "y": 0}]}
    )
    with pytest.raises(FormatError, match="only global"):
        write_mission_file(msn, tmp_path / "s.plan")


# -- hostile files -----------------------------------------------------------------------------


def plan_text(lat: object = 53.5233, extra: str = "") -> str:
    doc = json.loads(PLAN.read_text())
    doc["mission"]["items"][0]["params"][4] = lat
    return json.dumps(doc) + extra


@pytest.mark.parametrize(
    ("text", "words"),
    [
        (plan_text().replace("53.5233", "NaN", 1), "NaN is not a number"),
        (plan_text().replace("53.5233", "1e999", 1), "overflows to infinity"),
        (plan_text().replace("53.5233", "Infinity", 1), "Infinity is not a number"),
        (plan_text(lat="53.5"), "mission.items.0.SimpleItem.params.4"),
        (plan_text(lat=True), "mission.items.0.SimpleItem.params.4"),
        (plan_text(lat=95.0), "off the Earth"),
        (plan_text().replace("[53.523, -113.5265]", "[0, 0]", 1), "(0, 0)"),
        ('{"fileType": "Plan", "fileType": "Plan"}', "duplicate key 'fileType'"),
        ("[" * 100_000 + "]" * 100_000, "nested deeper than 24"),
        ("{not json", "not valid JSON at line 1"),
        ("[]", "expected a JSON object"),
        ('{"fileType": "Mission"}', "fileType"),
        ('{"fileType": "Plan", "mission": {"items": [{"type": "Odd"}]}}', "mission.items.0"),
        ("1" * 5000, "not a usable .plan"),
    ],
)
def test_hostile_plan_is_one_clear_error(text: str, words: str) -> None:
    with pytest.raises(FormatError) as err:
        gcs = parse_plan_text(text, "x.plan")
        items_to_mission(gcs, name="x", mode=SCROLL, source="x.plan")
    assert any(words in p for p in err.value.problems), err.value.problems
    assert all(p.startswith("x.plan") for p in err.value.problems)
    assert all(len(p) <= 400 for p in err.value.problems)


def test_plan_with_a_crossed_fence_is_refused() -> None:
    doc = json.loads(PLAN.read_text())
    poly = doc["geoFence"]["polygons"][0]["polygon"]
    poly[1], poly[2] = poly[2], poly[1]
    with pytest.raises(FormatError, match=r"x\.plan: geofence_polygon: edges 0-1 and 2-3 cross"):
        gcs = parse_plan_text(json.dumps(doc), "x.plan")
        items_to_mission(gcs, name="x", mode=SCROLL, source="x.plan")


def test_plan_survey_without_items_is_refused() -> None:
    doc = json.loads(PLAN.read_text())
    del doc["mission"]["items"][1]["TransectStyleComplexItem"]["Items"]
    del doc["mission"]["items"][1]["TransectStyleComplexItem"]["VisualTransectPoints"]
    with pytest.raises(FormatError, match=r"mission.items.1: ComplexItem 'survey' holds no"):
        parse_plan_text(json.dumps(doc), "x.plan")


def test_plan_survey_without_items_flies_its_transect_points() -> None:
    doc = json.loads(PLAN.read_text())
    transect = doc["mission"]["items"][1]["TransectStyleComplexItem"]
    del transect["Items"]
    gcs = parse_plan_text(json.dumps(doc), "x.plan")
    points = [(it.x, it.y) for it in gcs.items if it.command == 16][1:]
    assert points == [tuple(p) for p in transect["VisualTransectPoints"]]
    assert any("VisualTransectPoints" in n for n in gcs.notes)


WPL_ROW = "1\t0\t3\t16\t0\t0\t0\t0\t53.5233\t-113.52605\t0\t1"
WPL_HOME = "0\t1\t0\t16\t0\t0\t0\t0\t53.52325\t-113.52611\t0\t1"


@pytest.mark.parametrize(
    ("rows", "words"),
    [
        ([WPL_ROW.replace("53.5233", "nan")], "line 3: x 'nan' is not a finite number"),
        ([WPL_ROW.replace("53.5233", "inf")], "line 3: x 'inf' is not a finite number"),
        ([WPL_ROW.replace("53.5233", "95")], "line 3: latitude/longitude (95.0"),
        ([WPL_ROW.replace("\t1", "", 1)], "line 3: 11 values"),
        ([WPL_ROW.replace("16", "sixteen", 1)], "line 3: command 'sixteen'"),
        ([WPL_ROW.replace("\t3\t", "\t300\t", 1)], "line 3: frame 300 is above 255"),
        ([WPL_ROW.replace("1", "7", 1)], "line 3: index 7, expected 1"),
        ([WPL_ROW.replace("53.5233", "1" * 500)], "line 3: x '1111"),
    ],
)
def test_hostile_waypoints_is_one_clear_error(rows: list[str], words: str) -> None:
    text = "\n".join(["QGC WPL 110", WPL_HOME, *rows]) + "\n"
    with pytest.raises(FormatError) as err:
        parse_wpl_text(text, "x.waypoints")
    assert any(words in p for p in err.value.problems), err.value.problems


def test_waypoints_header_is_required() -> None:
    with pytest.raises(FormatError, match="line 1: expected the header 'QGC WPL 110'"):
        parse_wpl_text("QGC WPL 100\n", "x.waypoints")
    with pytest.raises(FormatError, match="empty file"):
        parse_wpl_text("", "x.waypoints")


def test_huge_and_binary_files_are_refused(tmp_path: Path) -> None:
    big = tmp_path / "big.plan"
    with big.open("wb") as fh:
        fh.truncate(17 * 1024 * 1024)
    with pytest.raises(ConfigFileError, match="larger than 16 MB"):
        load_mission_file(big, mode=SCROLL)
    binary = tmp_path / "bin.waypoints"
    binary.write_bytes(b"QGC WPL 110\n\xff\xfe")
    with pytest.raises(ConfigFileError, match="not UTF-8"):
        load_mission_file(binary, mode=SCROLL)


def test_other_suffixes_are_helixd_yaml_as_before(tmp_path: Path) -> None:
    legacy = tmp_path / "mission"
    legacy.write_text("name: m\nmode: roll\nwaypoints: [{x: 1, y: 0}]\n")
    assert load_mission_file(legacy).format is MissionFormat.YAML
    txt = tmp_path / "m.txt"
    txt.write_text(legacy.read_text())
    assert load_mission_file(txt).format is MissionFormat.YAML
    txt.write_text(WPL.read_text())
    assert load_mission_file(txt, mode=SCROLL).format is (MissionFormat.WAYPOINTS)
    with pytest.raises(ConfigFileError, match="not valid YAML"):
        bad = tmp_path / "x.kml"
        bad.write_text("<kml>: [")
        load_mission_file(bad, mode=SCROLL)


# -- fuzz ----------------------------------------------------------------------------------------

json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers() | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=8) | st.dictionaries(st.text(max_size=12), inner),
    max_leaves=40,
)


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
@given(json_values)
def test_fuzz_plan_json_never_escapes(value: object) -> None:
    with contextlib.suppress(FormatError):
        gcs = parse_plan_text(json.dumps(value), "f.plan")
        items_to_mission(gcs, name="f", mode=SCROLL)


@settings(max_examples=300)
@given(
    st.lists(
        st.sampled_from(["16", "0", "1", "3", "nan", "-1e400", "53.5", "x", "", "\t", " "]),
        max_size=30,
    )
)
def test_fuzz_plan_items_never_escape(tokens: list[str]) -> None:
    doc = json.loads(PLAN.read_text())
    doc["mission"]["items"][0]["params"] = tokens[:7]
    with contextlib.suppress(FormatError):
        gcs = parse_plan_text(json.dumps(doc), "f.plan")
        items_to_mission(gcs, name="f", mode=SCROLL)


@settings(max_examples=300)
@given(st.lists(st.text(alphabet="0123456789.-eEinfa\t \n", max_size=60), max_size=6))
def test_fuzz_waypoints_never_escape(rows: list[str]) -> None:
    text = "\n".join(["QGC WPL 110", WPL_HOME, *rows])
    try:
        gcs = parse_wpl_text(text, "f.waypoints")
    except FormatError:
        return
    for it in gcs.items:
        assert all(math.isfinite(v) for v in (it.param1, it.x, it.y, it.z))
