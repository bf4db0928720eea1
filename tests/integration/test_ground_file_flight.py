"""A flight over a ground helixd has never seen: ``run --sim --sim-ground FILE`` on the
simulated clock, real CLI, real UDP. The file's hard ground rolls at half the no-slip speed
(the built-in table: 0.95); helixd is told nothing, completes the mission, and its slip
estimate finds the file's fraction, not the table's."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from helixd.recorder.rows import read_flight_columns
from tests.support.paths import REPO_ROOT

pytestmark = pytest.mark.integration

ROLL_FRACTION = 0.5  # the site's hard ground (the built-in table says 0.95)
MISSION = {
    "name": "site",
    "mode": "roll",
    "frame": "start",
    "waypoints": [{"x": 12.0, "y": 0.0}, {"x": 12.0, "y": 6.0}],
}


def test_a_flight_over_a_ground_helixd_never_saw_completes_and_learns_it(
    tmp_path: Path,
) -> None:
    ground = tmp_path / "site-ground.yaml"
    ground.write_text(f"hard:\n  roll_efficiency: {ROLL_FRACTION}\n  yaw_efficiency: 0.6\n")
    mission = tmp_path / "site.yaml"
    mission.write_text(yaml.safe_dump(MISSION), encoding="utf-8")
    root = tmp_path / "runs"
    cmd = [
        sys.executable, "-m", "helixd", "run", "--sim", "--sim-clock", "simulated",
        "--sim-noise", "low", "--sim-seed", "7", "--sim-ground", str(ground),
        "--mission", str(mission), "--config", str(REPO_ROOT / "config" / "helixd.yaml"),
        "--run-dir", str(root), "--log-level", "warning",
    ]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "helixd: RESULT ok — 2/2 waypoints" in proc.stderr
    (csv,) = root.glob("*/flight.csv")
    c = read_flight_columns(csv)
    steady = (c["nav_state"] == "track") & (c["vx_cmd_mps"] >= 0.3)
    assert steady.sum() > 50
    learnt = float(np.nanmedian(c["slip_vx_frac"][steady][-50:]))
    print(f"slip estimate on the site's hard ground: {learnt:.3f} (file {ROLL_FRACTION})")
    assert learnt == pytest.approx(ROLL_FRACTION, abs=0.08)
