"""``helixd run --sim --map``: the embedded simulator knows the map's walls.

Run as the operator types it, on the simulated clock (the CLI's ``main`` in this process, so
the test can hold the embedded simulator the CLI starts and read its history). With planning
the straight leg that crosses the wall is flown around it without a contact; with planning
disabled the rover runs into the wall, the simulator stops it there, and helixd's stall
watchdog secures it (scrolls neutral, overrides released, HOLD) — proven from the simulator's
side.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from PIL import Image

import helixd.cli.simulated
from helixd.base.exitcodes import ExitCode
from helixd.cli.app import main
from helixd.plant.collisions import SimObstacles, distance_m
from helixd.sim.server import SimServer
from helixd.sim.sim_config import SimConfig
from helixd.sim.snapshot import SimSnapshot
from tests.support.harness import BASE_CONFIG, Trace, secured

pytestmark = pytest.mark.integration


def _write_map(tmp_path: Path) -> Path:
    """20 m × 20 m at 0.1 m from north -2, east -10; a wall at north 8..9, east -3..3."""
    px = np.full((200, 200), 254, dtype=np.uint8)  # [row from the south, col from the west]
    px[100:110, 70:130] = 0
    Image.fromarray(px[::-1], mode="L").save(tmp_path / "wall.pgm")
    path = tmp_path / "wall.yaml"
    path.write_text(
        "image: wall.pgm\nresolution: 0.1\norigin: [-10.0, -2.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n",
        encoding="utf-8",
    )
    return path


def _fly(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    planning: dict[str, Any],
    until_disarmed: bool,
    mission_args: list[str] | None = None,
) -> tuple[int, Trace, SimServer]:
    """``helixd run --sim --sim-clock simulated`` with ``mission_args`` (default: a local_ned
    mission across the map's wall, with ``--map``); the simulator's whole trace, which ends
    secured (and disarmed, if asked)."""
    if mission_args is None:
        mission = tmp_path / "across.yaml"
        mission.write_text(
            "name: across\nmode: roll\nframe: local_ned\nwaypoints:\n- north: 16.0\n  east: 0.0\n",
            encoding="utf-8",
        )
        mission_args = ["--mission", str(mission), "--map", str(_write_map(tmp_path))]
    cfg_path = tmp_path / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump({**BASE_CONFIG, "planning": planning}), encoding="utf-8")
    servers: list[SimServer] = []
    samples: list[tuple[float, SimSnapshot]] = []

    class Recorded(SimServer):  # the CLI's own simulator, its every snapshot kept
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            super().__init__(*args, **kwargs)
            servers.append(self)
            self.snapshot_listeners.append(lambda snap: samples.append((snap.sim_time_s, snap)))

    monkeypatch.setattr(helixd.cli.simulated, "SimServer", Recorded)
    with pytest.raises(SystemExit) as exited:
        main(
            [
                "run", "--sim", "--sim-clock", "simulated", "--sim-noise", "low", "--sim-seed", "4",
                *mission_args,
                "--config", str(cfg_path), "--run-dir", str(tmp_path / "runs"),
            ]
        )  # fmt: skip
    assert servers and samples
    end = samples[-1][1]
    assert secured(end) and not (until_disarmed and end.armed), end.describe()
    return int(exited.value.code or 0), Trace(samples), servers[0]


def test_run_sim_map_flies_around_the_wall_without_contact(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    code, trace, server = _fly(tmp_path, monkeypatch, {}, until_disarmed=True)
    assert code == ExitCode.OK
    assert server.history.entries("contact") == []
    obstacles = server.config.obstacles
    assert obstacles.raster is not None  # the simulator really had the map
    assert min(distance_m(obstacles, s.north_m, s.east_m) for _, s in trace.samples) >= (
        obstacles.contact_radius_m
    )
    wall = SimObstacles(polygons_ne_m=(((8.0, -3.0), (8.0, 3.0), (9.0, 3.0), (9.0, -3.0)),))
    closest = min(distance_m(wall, s.north_m, s.east_m) for _, s in trace.samples)
    final = trace.samples[-1][1]
    print(f"closest approach to the map wall: {closest:.3f} m (body radius 0.429 m)")
    assert closest >= obstacles.contact_radius_m
    assert math.hypot(final.north_m - 16.0, final.east_m) <= 1.0
    # the straight line really crosses the wall: the rover went round it
    assert max(abs(s.east_m) for _, s in trace.samples) > 3.0


def test_run_sim_map_without_planning_hits_the_wall_and_is_secured(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    code, trace, server = _fly(tmp_path, monkeypatch, {"enabled": False}, until_disarmed=False)
    contacts = server.history.entries("contact")
    assert len(contacts) >= 1
    assert 7.0 < float(contacts[0].details["north_m"]) < 8.0  # stopped by the wall
    assert code == ExitCode.FAULT
    assert secured(trace.samples[-1][1])


# -- a .plan's own exclusion zone, the first leg from the rover ---------------------------------

WALL_NE = ((9.0, -4.0), (9.0, 4.0), (11.0, 4.0), (11.0, -4.0))


def _wall_plan(tmp_path: Path) -> list[str]:
    """A QGC .plan around the simulator's EKF origin: waypoint 0 at north 20 m beyond an
    exclusion polygon (north 9..11, east -4..4) that lies across the rover's way from the
    origin, waypoint 1 at (20, 8); a keep-in polygon around it all."""
    import json

    from helixd.base.frames import ne_to_latlon

    sim = SimConfig()

    def ll(n: float, e: float) -> list[float]:
        return list(ne_to_latlon(n, e, sim.origin_lat_deg, sim.origin_lon_deg))

    items = [
        {
            "autoContinue": True, "command": 16, "doJumpId": i + 1, "frame": 3,
            "params": [0, 0, 0, None, *ll(n, e), 0], "type": "SimpleItem",
        }
        for i, (n, e) in enumerate([(20.0, 0.0), (20.0, 8.0)])
    ]  # fmt: skip
    keep_in = [(-10.0, -15.0), (-10.0, 15.0), (30.0, 15.0), (30.0, -15.0)]
    doc = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {
            "version": 2, "firmwareType": 3, "vehicleType": 10, "cruiseSpeed": 0.6,
            "hoverSpeed": 5, "globalPlanAltitudeMode": 1, "items": items,
            "plannedHomePosition": [*ll(0.0, 0.0), 0],
        },
        "geoFence": {
            "version": 2,
            "circles": [],
            "polygons": [
                {"inclusion": True, "polygon": [ll(*v) for v in keep_in], "version": 1},
                {"inclusion": False, "polygon": [ll(*v) for v in WALL_NE], "version": 1},
            ],
        },
        "rallyPoints": {"version": 2, "points": []},
    }  # fmt: skip
    path = tmp_path / "wall.plan"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return ["--mission", str(path), "--mode", "roll"]


def test_run_sim_plan_routes_around_its_exclusion_zone_from_the_rovers_pose(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The .plan's exclusion polygon is solid in the embedded simulator; the rover starts at
    the EKF origin, south of it, and the first leg is re-planned from there at preflight."""
    code, trace, server = _fly(tmp_path, monkeypatch, {}, True, _wall_plan(tmp_path))
    assert code == ExitCode.OK
    assert server.history.entries("contact") == []
    wall = SimObstacles(polygons_ne_m=(WALL_NE,))
    closest = min(distance_m(wall, s.north_m, s.east_m) for _, s in trace.samples)
    print(f"closest approach to the .plan's exclusion polygon: {closest:.3f} m")
    assert closest >= 0.429
    final = trace.samples[-1][1]
    assert math.hypot(final.north_m - 20.0, final.east_m - 8.0) <= 1.0


def test_run_sim_plan_without_planning_hits_the_exclusion_and_is_secured(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    code, trace, server = _fly(
        tmp_path, monkeypatch, {"enabled": False}, False, _wall_plan(tmp_path)
    )
    contacts = server.history.entries("contact")
    assert len(contacts) >= 1 and float(contacts[0].details["north_m"]) < 9.0
    assert code == ExitCode.FAULT
    assert secured(trace.samples[-1][1])
