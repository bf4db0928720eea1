"""A planned path flown by the real CLI against the simulator over UDP, around a solid box.

The same box is a keep-out polygon in the daemon's config (so ``helixd run`` plans around it)
and a solid obstacle in the simulator (so touching it stops the rover). Assertions are made
from the simulator's side: where the rover truly was, and whether it ever touched the box.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.plant.collisions import SimObstacles, distance_m
from tests.support.harness import secured
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration

# a 6 m wide, 2 m deep box across the straight line from the start (0, 0) to (16, 0)
BOX = [[7.0, -3.0], [7.0, 3.0], [9.0, 3.0], [9.0, -3.0]]
SIM_OBSTACLES: dict[str, Any] = {"polygons_ne_m": [BOX]}


def _mission(tmp_path: Path) -> Path:
    path = tmp_path / "across.yaml"
    path.write_text(
        "name: across\nmode: roll\nframe: local_ned\nwaypoints:\n- north: 16.0\n  east: 0.0\n",
        encoding="utf-8",
    )
    return path


def _fly(
    tmp_path: Path, planning: dict[str, Any], until_disarmed: bool
) -> tuple[int, str, Any, list[Any], Any]:
    cfg = {"planning": planning}
    flown = simulated_flight(
        tmp_path, _mission(tmp_path), cfg, noise="low", seed=8, obstacles=SIM_OBSTACLES
    )
    end = flown.trace.samples[-1][1]
    assert secured(end) and not (until_disarmed and end.armed), end.describe()
    contacts = flown.server.history.entries("contact")
    return flown.code, flown.log, flown.trace, contacts, flown.run_dir()


def test_planned_path_goes_around_the_box_without_touching_it(tmp_path: Path) -> None:
    code, log, trace, contacts, run_dir = _fly(
        tmp_path, {"keep_out_polygons_ne_m": [BOX]}, until_disarmed=True
    )
    assert code == ExitCode.OK, log[-3000:]
    assert contacts == []
    obstacles = SimObstacles.model_validate(SIM_OBSTACLES)
    closest = min(distance_m(obstacles, s.north_m, s.east_m) for _, s in trace.samples)
    final = trace.samples[-1][1]
    print(f"closest approach to the box: {closest:.3f} m (body radius 0.429 m)")
    assert closest >= obstacles.contact_radius_m
    assert math.hypot(final.north_m - 16.0, final.east_m) <= 1.0
    summary = json.loads((run_dir / "summary.json").read_text())
    assert summary["completed"] is True
    # the operator's one waypoint, reached through the planner's via points (not counted as
    # waypoints: "1/1 waypoints (+2/2 via points)")
    assert summary["waypoints_reached"] == summary["waypoints_total"] == 1
    assert summary["via_points_reached"] == summary["via_points_total"] >= 1
    # the run records the mission it flew: the planned one, intermediate waypoints included
    flown = (run_dir / "mission.yaml").read_text()
    assert flown.startswith("# Planned by helixd.planning")
    assert flown.count("via: true") == summary["via_points_total"]


def test_unplanned_straight_leg_hits_the_box_and_ends_in_a_fault(tmp_path: Path) -> None:
    """Control: with planning off the straight leg runs into the box. The simulator stops the
    rover there (contact), and — as on ArduPilot in MANUAL, which reports nothing — helixd's
    stall watchdog turns it into a fault: scrolls stopped, overrides released, HOLD."""
    code, log, trace, contacts, _ = _fly(
        tmp_path, {"enabled": False, "keep_out_polygons_ne_m": [BOX]}, until_disarmed=False
    )
    assert len(contacts) >= 1
    assert contacts[0].details["north_m"] < 7.0
    assert code == ExitCode.FAULT, log[-3000:]
    assert "cause=stall" in log
    assert secured(trace.samples[-1][1])
