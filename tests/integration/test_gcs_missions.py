"""A QGroundControl .plan flown by the real CLI against the simulator over UDP, then exported."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import latlon_to_ne
from helixd.sim.sim_config import SimConfig
from tests.support.harness import secured
from tests.support.paths import DATA_DIR
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration

PLAN = DATA_DIR / "sim_square.plan"
SIM_ORIGIN = (SimConfig().origin_lat_deg, SimConfig().origin_lon_deg)  # the sim's EKF origin


def test_plan_file_flies_and_exports(tmp_path: Path) -> None:
    cfg = {"mission": {"ground_station_mode": "roll"}}
    flown = simulated_flight(tmp_path, PLAN, config=cfg, terrain="hard", noise="low", seed=4)
    code, log, run_dir, snap = flown.code, flown.log, flown.run_dir(), flown.snapshot
    assert code == ExitCode.OK, log[-3000:]
    s = json.loads((run_dir / "summary.json").read_text())
    assert s["completed"] is True and s["fault"] is None
    assert s["waypoints_reached"] == s["waypoints_total"] == 3
    assert s["origin_latlon_deg"] == pytest.approx(list(SIM_ORIGIN))
    assert all(a["error_m"] <= 1.0 for a in s["arrivals"])
    assert secured(snap) and not snap.armed
    # what the simulator saw: the rover ended at the last .plan waypoint (N 0, E 8 from origin)
    assert math.hypot(snap.north_m - 0.0, snap.east_m - 8.0) < 1.5
    # the run directory keeps what was flown as helixd YAML
    assert "frame: global" in (run_dir / "mission.yaml").read_text()

    out = tmp_path / "track.geojson"
    res = subprocess.run(
        [sys.executable, "-m", "helixd", "export", str(run_dir), "--geojson", "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert res.returncode == 0, res.stderr
    doc = json.loads(out.read_text())
    kinds = {f["properties"]["kind"]: f for f in doc["features"]}
    planned = kinds["planned"]["geometry"]["coordinates"]
    plan_doc = json.loads(PLAN.read_text())
    assert [[p[1], p[0]] for p in planned] == [
        it["params"][4:6] for it in plan_doc["mission"]["items"]
    ]
    lon, lat = kinds["flown"]["geometry"]["coordinates"][-1]
    n, e = latlon_to_ne(lat, lon, *SIM_ORIGIN)
    assert math.hypot(n - snap.est_north_m, e - snap.est_east_m) < 0.5  # the EKF's pose


def test_run_plan_with_the_embedded_simulator(tmp_path: Path) -> None:
    """`helixd run --mission X.plan --sim --mode roll`, as an operator would type it."""
    res = subprocess.run(
        [
            sys.executable, "-m", "helixd", "run", "--mission", str(PLAN), "--sim",
            "--sim-speedup", "5", "--mode", "roll", "--run-dir", str(tmp_path / "runs"),
        ],
        capture_output=True,
        text=True,
        timeout=400,  # a hang guard: a loaded machine lowers the speed-up (sim/pace.py)
        check=False,
        cwd=tmp_path,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr[-3000:]
    assert "helixd: RESULT ok — 3/3 waypoints" in res.stderr
    (run_dir,) = (tmp_path / "runs").iterdir()
    s = json.loads((run_dir / "summary.json").read_text())
    assert s["completed"] is True and s["mode"] == "roll"
