"""QGroundControl .plan layouts QGC itself still opens (MissionItem::load), and the ground-
station round trip without loss: a file's items come back as they were."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from helixd.base.plan import MotionMode
from helixd.mission.formats import MissionFormat, load_mission_file, read_gcs, write_mission_file
from helixd.mission.formats.items import FormatError
from helixd.mission.formats.qgc_plan import parse_plan_text
from tests.support.paths import DATA_DIR

GCS = DATA_DIR / "gcs"
ROLL = MotionMode.ROLL


def item(**kw: object) -> dict[str, object]:
    return {"type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": True, **kw}


def plan(*items: dict[str, object]) -> str:
    return json.dumps({"fileType": "Plan", "mission": {"items": list(items)}})


def test_three_item_layouts_read_the_same() -> None:
    new = item(params=[5, 0, 0, None, 47.1, 8.1, 20])
    older = item(params=[5, 0, 0, None], coordinate=[47.1, 8.1, 20])
    oldest = {**item(param1=5, param2=0, param3=0, param4=0, coordinate=[47.1, 8.1, 20]),
              "type": "missionItem"}  # fmt: skip
    got = [parse_plan_text(plan(x), "p.plan").items[0] for x in (new, older, oldest)]
    assert {(g.param1, g.x, g.y, g.z) for g in got} == {(5.0, 47.1, 8.1, 20.0)}


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        (item(params=[0, 0, 0, 0, 1]), "5 values; QGroundControl reads 7, or 4 with"),
        (item(params=[0] * 7, coordinate=[1, 2, 3]), "7 values with a coordinate"),
        (item(params=[0] * 4, coordinate=[1, 2]), "mission.items.0"),
        (item(), "params: missing"),
    ],
)
def test_a_broken_layout_is_one_clear_error(bad: dict[str, object], words: str) -> None:
    with pytest.raises(FormatError) as err:
        parse_plan_text(plan(bad), "p.plan")
    assert any(words in p for p in err.value.problems), err.value.problems


def test_the_older_mission_file_and_a_version_1_fence() -> None:
    old = read_gcs(GCS / "qgc-OldFileFormat.mission")
    assert [it.command for it in old.items] == [22, 18, 18, 16, 16, 21]
    section = read_gcs(GCS / "qgc-SectionTest.plan")  # "polygon": [] (version 1, empty)
    assert section.polygons == () and section.items[3].command == 205
    doc = json.loads((GCS / "qgc-SectionTest.plan").read_text())
    doc["geoFence"]["polygon"] = [[47.63, -122.09], [47.64, -122.09], [47.64, -122.08]]
    fenced = parse_plan_text(json.dumps(doc), "s.plan")
    assert len(fenced.polygons) == 1 and fenced.polygons[0].inclusion


def test_a_landing_pattern_is_skipped_and_a_structure_scan_refused() -> None:
    landing = {"type": "ComplexItem", "complexItemType": "fwLandingPattern"}
    gcs = parse_plan_text(plan(item(params=[0, 0, 0, None, 47.1, 8.1, 0]), landing), "l.plan")
    assert len(gcs.items) == 1 and "skips landing" in gcs.notes[0]
    scan = {"type": "ComplexItem", "complexItemType": "StructureScan"}
    with pytest.raises(FormatError, match="circles a structure at heights"):
        parse_plan_text(plan(scan), "s.plan")


@pytest.mark.parametrize(
    "name",
    [
        "qgc-ArduPilotSITL-ArduRover.plan",
        "qgc-SectionTest.plan",
        "qgc-simple_square.plan",
        "qgc-OldFileFormat.mission",
        "ap-DriveMission-rover1.txt",
        "ap-CameraMission-rover-camera-mission.txt",
        "ap-Sprayer-sprayer-mission.txt",
        "qgc-MissionPlanner.waypoints.txt",
    ],
)
def test_a_files_items_survive_yaml_and_back(name: str, tmp_path: Path) -> None:
    """file → helixd YAML → .plan: every item with its command, frame, parameters (NaN kept
    as unset), place, altitude and autocontinue; .waypoints → YAML → .waypoints likewise."""
    src = GCS / name
    first = read_gcs(src)
    msn = load_mission_file(src, mode=ROLL).mission
    write_mission_file(msn, tmp_path / "m.yaml")
    again = load_mission_file(tmp_path / "m.yaml").mission
    assert again == msn
    out = tmp_path / ("m.waypoints" if src.suffix == ".txt" else "m.plan")
    assert write_mission_file(again, out) in (MissionFormat.PLAN, MissionFormat.WAYPOINTS)
    back = read_gcs(out)
    kept = [it for it in first.items]

    def same(a: float, b: float) -> bool:
        return (math.isnan(a) and math.isnan(b)) or a == pytest.approx(b, abs=1e-7)

    assert len(back.items) == len(kept)
    for a, b in zip(kept, back.items, strict=True):
        assert (a.command, a.frame, a.autocontinue) == (b.command, b.frame, b.autocontinue)
        for f in ("param1", "param2", "param3", "param4", "x", "y", "z"):
            va, vb = getattr(a, f), getattr(b, f)
            if out.suffix == ".waypoints" and math.isnan(va):
                va = 0.0  # the WPL text has no NaN: Mission Planner writes 0
            assert same(va, vb), (a.seq, f, va, vb)
    assert back.home_latlon_deg == pytest.approx(first.home_latlon_deg)
