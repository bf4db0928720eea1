"""A QGroundControl ``.waypoints`` mission with a DO_JUMP and a return, flown by the real CLI
against the simulator: every number the run reports is the mission item as QGroundControl
shows it, never above the item count, and the jump's laps are stated.

Before: three waypoints, a DO_JUMP (repeat 2) and NAV_RETURN_TO_LAUNCH were logged as the
expanded steps (``waypoint=1/7`` … ``8/7``) and ended "8/8 waypoints"."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.harness import secured
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration

HOME = (53.523250, -113.526110)
# three corners of tests/data/square.waypoints (10 m legs): items 1–3, item 4 jumps to item 1
# twice, item 5 returns home
WPL = f"""QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]:.6f}\t{HOME[1]:.6f}\t668.0\t1
1\t0\t3\t16\t0\t0\t0\t0\t53.523300\t-113.526050\t0.0\t1
2\t0\t3\t16\t0\t0\t0\t0\t53.523300\t-113.525900\t0.0\t1
3\t0\t3\t16\t0\t0\t0\t0\t53.523390\t-113.525900\t0.0\t1
4\t0\t3\t177\t1\t2\t0\t0\t0\t0\t0\t1
5\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1
"""
LAPS = ("lap 1 of 3", "lap 2 of 3", "lap 3 of 3")
REACHED = [f"{item}/5 ({lap})" for lap in LAPS for item in (1, 2, 3)] + ["5/5"]
RATIO = re.compile(r"(\d+)/(\d+)")
# the simulator at 10x on mud with 'low' noise, its EKF origin at HOME
ON_MUD_AT_HOME: dict[str, Any] = {
    "speedup": 10.0,
    "terrain": "mud",
    "noise": "low",
    "origin_lat_deg": HOME[0],
    "origin_lon_deg": HOME[1],
}


def test_a_jump_mission_reports_item_numbers_and_laps(tmp_path: Path) -> None:
    path = tmp_path / "laps.waypoints"
    path.write_text(WPL)
    cfg = {"mission": {"ground_station_mode": "omni"}, "safety": {"geofence_radius_m": 200.0}}
    flown = simulated_flight(tmp_path, path, cfg, **ON_MUD_AT_HOME)
    assert flown.code == ExitCode.OK, flown.log[-3000:]
    assert secured(flown.snapshot)
    result, run_dir = flown.result, flown.run_dir()

    events = [json.loads(ln) for ln in (run_dir / "events.jsonl").read_text().splitlines()]
    reached = [e["waypoint"] for e in events if e["event"] == "waypoint_reached"]
    assert reached == REACHED
    progress = [str(e["waypoint"]) for e in events if e.get("waypoint") is not None]
    ratios = [(int(a), int(b)) for text in progress for a, b in RATIO.findall(text)]
    assert ratios and all(1 <= n <= m == 5 for n, m in ratios), progress
    steps = [(e["item"], e.get("lap")) for e in events if e.get("kind") == "step_started"]
    assert steps == [(i, lap) for lap in LAPS for i in (1, 2, 3)] + [(5, None)]

    summary = json.loads((run_dir / "summary.json").read_text())
    assert (summary["waypoints_reached"], summary["waypoints_total"]) == (10, 10)
    assert summary["items_total"] == 5
    assert [a["number"] for a in summary["arrivals"]] == [1, 2, 3] * 3 + [5]
    assert [a["lap"] for a in summary["arrivals"]][3:6] == ["lap 2 of 3"] * 3
    assert "10/10 waypoints as flown (mission items 1–5, DO_JUMP laps each counted)" in result


def test_a_patrol_flies_laps_until_its_time_limit_ends_it(tmp_path: Path) -> None:
    """DO_JUMP repeat -1 (a patrol the crew stops from the ground station) is flown as Rover
    flies it: lap after lap, numbered without a count, until the time limit ends it; the
    result gives no total of laps planned beyond the limit. Before: refused (exit 2)."""
    path = tmp_path / "patrol.waypoints"
    path.write_text(WPL.replace("177\t1\t2\t", "177\t1\t-1\t"))
    cfg = {
        "mission": {"ground_station_mode": "omni"},
        "safety": {"geofence_radius_m": 200.0, "mission_time_limit_s": 120.0},
    }
    flown = simulated_flight(tmp_path, path, cfg, **ON_MUD_AT_HOME)
    code, result, log, run_dir = flown.code, flown.result, flown.log, flown.run_dir()
    assert code == ExitCode.FAULT, log[-3000:]
    assert result.startswith("helixd: RESULT fault mission_time: "), result
    assert "a patrol: DO_JUMP item 4 repeats until stopped" in result, result
    count = result.split(" waypoints as flown")[0].rsplit(" ", 1)[-1]
    assert count.isdigit(), result  # "6 waypoints as flown", no "/96" of planned laps
    events = [json.loads(ln) for ln in (run_dir / "events.jsonl").read_text().splitlines()]
    reached = [e["waypoint"] for e in events if e["event"] == "waypoint_reached"]
    assert reached[:4] == ["1/5 (lap 1)", "2/5 (lap 1)", "3/5 (lap 1)", "1/5 (lap 2)"], reached
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["patrol_item"] == 4 and summary["completed"] is False
