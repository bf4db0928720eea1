"""The mode follows the medium on the built-in simulator with media by place (on the simulated
clock): a crossing rolls the bank, turns on it and scrolls the water; mud the map does not show
is noticed and scrolled."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium
from helixd.recorder.rows import read_flight_columns
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration


def band(medium: Medium, north0: float, north1: float) -> MediaArea:
    return MediaArea(medium, ((north0, -30.0), (north0, 30.0), (north1, 30.0), (north1, -30.0)))


def geojson(path: Path, *areas: tuple[str, float, float]) -> Path:
    """A local_ned map of bands across the course ([east, north] positions)."""
    features = [
        {"type": "Feature", "properties": {"medium": m},
         "geometry": {"type": "Polygon", "coordinates": [[
             [-30, n0], [30, n0], [30, n1], [-30, n1], [-30, n0]]]}}
        for m, n0, n1 in areas
    ]  # fmt: skip
    data = {"type": "FeatureCollection", "frame": "local_ned", "default_medium": "hard",
            "features": features}  # fmt: skip
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def mission(path: Path, media: Path, north_m: float) -> Path:
    data = {"name": "amphibious", "mode": "scroll", "frame": "local_ned",
            "media_map": str(media), "waypoints": [{"north": north_m, "east": 0.0}]}  # fmt: skip
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def modes_in_order(c: dict[str, np.ndarray]) -> list[str]:
    out: list[str] = []
    for m in c["motion_mode"]:
        if not out or out[-1] != m:
            out.append(str(m))
    return out


def test_a_crossing_rolls_the_banks_and_scrolls_the_water(tmp_path: Path) -> None:
    helixd_map = geojson(tmp_path / "water.geojson", ("water", 10.0, 30.0))
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.WATER, 10.0, 30.0),), Medium.HARD)
    path = mission(tmp_path / "crossing.yaml", helixd_map, 40.0)
    flown = simulated_flight(tmp_path, path, media=world, noise="low", seed=6)
    code, log, run_dir = flown.code, flown.log, flown.run_dir()
    assert code == ExitCode.OK, log[-3000:]
    assert log.count("event=media_transition") == 2, log[-3000:]
    c = read_flight_columns(run_dir / "flight.csv")
    assert modes_in_order(c) == ["roll", "scroll", "roll"]
    scrolled = c["motion_mode"] == "scroll"  # the water (10..30 m north) in scroll, turned on land
    assert float(np.min(c["north_m"][scrolled])) == pytest.approx(9.0, abs=0.6)
    assert float(np.max(c["north_m"][scrolled])) == pytest.approx(31.0, abs=0.6)
    assert "ground_changed" not in log  # the map was right
    reached = [
        json.loads(line).get("index")
        for line in (run_dir / "events.jsonl").read_text(encoding="utf-8").splitlines()
        if '"waypoint_reached"' in line
    ]
    assert reached == [None, None, 0]  # the map's two stops are not the mission's (--resume)
    # the stops are counted as via points, and the changes of mode numbered as the operator's
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert (summary["via_points_reached"], summary["via_points_total"]) == (2, 2)
    assert "1/1 waypoints (+2/2 via points)" in flown.result, flown.result
    changes = [
        json.loads(line)
        for line in (run_dir / "events.jsonl").read_text(encoding="utf-8").splitlines()
        if '"media_transition"' in line
    ]
    assert [(e["waypoint"], e["stop"]) for e in changes] == [("via → 1/1", "media")] * 2


def test_mud_the_map_does_not_show_is_noticed_and_scrolled(tmp_path: Path) -> None:
    helixd_map = geojson(tmp_path / "bank.geojson", ("grass", 50.0, 60.0))  # hard, says the map
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.MUD, 10.0, 20.0),), Medium.HARD)
    path = mission(tmp_path / "bank.yaml", helixd_map, 30.0)
    flown = simulated_flight(tmp_path, path, media=world, noise="low", seed=6)
    code, log, run_dir = flown.code, flown.log, flown.run_dir()
    assert code == ExitCode.OK, log[-3000:]
    soft = [ln for ln in log.splitlines() if "event=ground_changed soft=true" in ln]
    assert len(soft) == 1, log[-3000:]
    north = float(soft[0].split("north_m=")[1].split()[0])
    assert 10.0 < north < 12.0  # noticed within 2 m of entering the mud
    assert "event=ground_changed soft=false" in log  # and back to roll past it
    c = read_flight_columns(run_dir / "flight.csv")
    assert modes_in_order(c) == ["roll", "scroll", "roll"]


def test_a_leg_pinned_to_roll_across_water_changes_mode_once_each_way(tmp_path: Path) -> None:
    """The ground check switches the pinned ROLL to SCROLL where it bogs down, and back to
    roll only past the water the map shows: no flipping to and fro in the pond."""
    helixd_map = geojson(tmp_path / "water.geojson", ("water", 10.0, 30.0))
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.WATER, 10.0, 30.0),), Medium.HARD)
    path = mission(tmp_path / "pinned.yaml", helixd_map, 40.0)
    data = json.loads(path.read_text(encoding="utf-8"))
    data["waypoints"][0]["mode"] = "roll"
    path.write_text(json.dumps(data), encoding="utf-8")
    flown = simulated_flight(tmp_path, path, media=world, noise="low", seed=6)
    code, log, run_dir = flown.code, flown.log, flown.run_dir()
    assert code == ExitCode.OK, log[-3000:]
    changes = [ln for ln in log.splitlines() if "event=ground_changed" in ln]
    assert [("soft=true" in ln) for ln in changes] == [True, False], "\n".join(changes)
    firm_north = float(changes[1].split("north_m=")[1].split()[0])
    assert firm_north > 30.0  # back to roll only once out of the map's water
    c = read_flight_columns(run_dir / "flight.csv")
    assert modes_in_order(c) == ["roll", "scroll", "roll"]


def test_rolling_into_water_without_a_map_is_a_stall_within_seconds(tmp_path: Path) -> None:
    """No media map for helixd: ROLL runs into the water, crawls at a few cm/s, and the stall
    watch calls it stuck within seconds of delivering under a tenth of the command."""
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.WATER, 10.0, 30.0),), Medium.HARD)
    path = tmp_path / "roll.yaml"
    data = {"name": "roll", "mode": "roll", "frame": "local_ned",
            "waypoints": [{"north": 40.0, "east": 0.0}]}  # fmt: skip
    path.write_text(json.dumps(data), encoding="utf-8")
    flown = simulated_flight(tmp_path, path, media=world, noise="low", seed=6)
    code, log, run_dir = flown.code, flown.log, flown.run_dir()
    assert code == ExitCode.FAULT, log[-3000:]
    assert "fault stall" in flown.result and "stall.crawl_fraction" in flown.result, flown.result
    c = read_flight_columns(run_dir / "flight.csv")
    wet = c["north_m"] > 9.5  # its front scrolls (about 0.5 m ahead of its centre) afloat
    assert np.any(wet)
    in_water_s = float(c["t_boot_s"][-1] - c["t_boot_s"][np.argmax(wet)])
    assert in_water_s < 20.0, (in_water_s, float(c["north_m"][-1]))  # 6.3 s when written
