"""The pond's depth through the wire: the simulator's sonar (DISTANCE_SENSOR) and payload
value (NAMED_VALUE_FLOAT), asked for by helixd and recorded in payload.csv where they were
taken, on the simulated clock."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaFrame, MediaMap, Medium
from helixd.files.bathymetry import Bathymetry
from helixd.sim.sim_config import SimConfig
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration

M_PER_DEG = 111_318.845


def sloping_bottom() -> Bathymetry:
    """1.0 m deep at the EKF origin, 5 cm deeper per metre north (nodes every 2 m from 10 m
    south-west of the origin to 60 m north)."""
    sim = SimConfig()
    lat0, lon0 = sim.origin_lat_deg, sim.origin_lon_deg
    rows = [[round(1.0 + 0.05 * (-10.0 + 2.0 * i), 3)] * 11 for i in range(36)]
    return Bathymetry.model_validate(
        {
            "format": "helixd-bathymetry/1",
            "south_west": {
                "lat_deg": lat0 - 10.0 / M_PER_DEG,
                "lon_deg": lon0 - 10.0 / (M_PER_DEG * math.cos(math.radians(lat0))),
            },
            "cell_m": 2.0,
            "depth_m": rows,
        }
    )


def test_the_depth_is_recorded_where_it_was_measured(tmp_path: Path) -> None:
    water = tmp_path / "water.geojson"
    water.write_text(
        json.dumps(
            {"type": "FeatureCollection", "frame": "local_ned", "default_medium": "water",
             "features": []}
        ),
        encoding="utf-8",
    )  # fmt: skip
    mission = tmp_path / "transect.yaml"
    mission.write_text(
        json.dumps(
            {"name": "transect", "mode": "scroll", "frame": "local_ned", "media_map": str(water),
             "waypoints": [{"north": 30.0, "east": 0.0}]}
        ),
        encoding="utf-8",
    )  # fmt: skip
    flown = simulated_flight(
        tmp_path,
        mission,
        noise="none",
        seed=3,
        media=MediaMap(MediaFrame.LOCAL_NED, (), Medium.WATER),
        bathymetry=sloping_bottom(),
        sonar={"noise_m": 0.0, "dropout": 0.0},
    )
    assert flown.code == ExitCode.OK, flown.log[-3000:]
    path = flown.run_dir() / "payload.csv"
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    depth = [r for r in rows if r["quantity"] == "depth_m"]
    assert {r["message"] for r in depth} == {"DISTANCE_SENSOR"}
    times = [float(r["t_boot_s"]) for r in depth]
    assert times == sorted(times)
    # asked at link.payload_rate_hz (5 Hz) over the whole link's life
    span = times[-1] - times[0]
    assert len(depth) == pytest.approx(5.0 * span, rel=0.05)
    moving = [r for r in depth if 2.0 < float(r["north_m"]) < 28.0]
    assert len(moving) > 50
    for r in moving:
        north = float(r["north_m"])
        # the sonar's depth at the true place = the bottom's at the recorded (interpolated) pose
        assert float(r["value"]) == pytest.approx(1.0 + 0.05 * north, abs=0.01)
        assert math.isfinite(float(r["lat_deg"])) and math.isfinite(float(r["lon_deg"]))
        assert r["medium"] == "water" and r["mode"] == "MANUAL" and r["quality_pct"] == "0"
    temps = [float(r["value"]) for r in rows if r["quantity"] == "nv_wtemp"]
    assert temps and all(13.0 < t < 18.0 for t in temps)
    assert "payload_log_closed" in (flown.run_dir() / "events.jsonl").read_text()
