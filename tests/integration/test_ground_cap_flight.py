"""Never command what the ground cannot deliver (on the simulated clock): a site whose hard
ground rolls only 0.55 of the no-slip speed, which the crew's profile knows (a pin); with
``media.modes: learned`` and a small margin the cap of hard ground in ROLL is
0.15 · 0.55 · v_full ≈ 0.265 m/s, below the mission's 0.6 m/s. The built-in simulator flies it:
every speed helixd commands is at most the cap, the run completes, and the estimate (which
flies the same cap) is within 5 % of the autopilot's time."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaFrame, MediaMap, Medium
from helixd.base.plan import MotionMode
from helixd.config.vehicle import VehicleConfig
from helixd.control.ground_cap import full_speed_mps
from helixd.plant.ground import TerrainTable
from helixd.recorder.ground_profile import GroundProfile, write_profile
from helixd.recorder.rows import read_flight_columns
from tests.integration.test_amphibious_flight import band, geojson
from tests.support.simulated import simulated_flights

pytestmark = pytest.mark.integration

HARD_ROLL = 0.55  # the site's truth (the table: 0.95)
MARGIN = 0.15
CAP_MPS = MARGIN * HARD_ROLL * full_speed_mps(VehicleConfig())  # ≈ 0.265 m/s


def test_the_speed_commanded_stays_under_the_grounds_cap_and_the_run_completes(
    tmp_path: Path,
) -> None:
    assert pytest.approx(0.2653, abs=1e-3) == CAP_MPS
    # the map: hard ground, a mud band far beyond the course (a map is what carries the cap)
    helixd_map = geojson(tmp_path / "site.geojson", ("mud", 100.0, 110.0))
    world = MediaMap(MediaFrame.LOCAL_NED, (band(Medium.MUD, 100.0, 110.0),), Medium.HARD)
    truth = TerrainTable.model_validate({"hard": {"roll_efficiency": HARD_ROLL}})
    profile = tmp_path / "state" / "ground-profile.yaml"
    profile.parent.mkdir()
    write_profile(profile, GroundProfile(pins={(Medium.HARD, MotionMode.ROLL, "roll"): HARD_ROLL}))
    data = {"name": "capped", "mode": "roll", "frame": "local_ned", "speed_mps": 0.6,
            "media_map": str(helixd_map), "waypoints": [{"north": 25.0, "east": 0.0}]}  # fmt: skip
    mission = tmp_path / "capped.yaml"
    mission.write_text(json.dumps(data), encoding="utf-8")
    cfg = {
        "ground": {"profile_file": str(profile), "speed_cap_margin": MARGIN},
        # the check would take 0.55 for soft ground and scroll: the map is the truth here
        "media": {"modes": "learned", "detect": False},
    }
    (flown,) = simulated_flights(
        tmp_path, [(mission, None)], cfg, media=world, terrains=truth, noise="low", seed=3
    )
    assert flown.code == ExitCode.OK, flown.log[-3000:]
    c = read_flight_columns(flown.run_dir() / "flight.csv")
    commanded = np.hypot(c["vx_cmd_mps"], c["vy_cmd_mps"])
    assert set(c["medium"]) == {"hard"}
    assert float(np.max(commanded)) <= CAP_MPS + 1e-5  # (the record: 5 decimals)
    assert float(np.max(commanded)) == pytest.approx(CAP_MPS, abs=0.01)  # flown at the cap
    summary = json.loads((flown.run_dir() / "summary.json").read_text(encoding="utf-8"))
    assert summary["completed"]
    time_s, estimated_s = summary["duration_s"], summary["estimated_s"]
    print(f"cap {CAP_MPS:.3f} m/s: flown {time_s:.1f} s, estimated {estimated_s:.1f} s")
    assert time_s > 25.0 / 0.3  # not the 0.6 m/s the mission asks for (≈ 45 s)
    assert math.isclose(estimated_s, time_s, rel_tol=0.05)
