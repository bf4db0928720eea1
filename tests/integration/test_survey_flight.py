"""A survey written by `helixd mission survey`, flown by the real CLI against the simulator:
the time flown is the navigator's estimate (the field engineer's survey: 461 s estimated,
546 s flown, under a time limit built on the 461 s), and well inside the mission's own limit."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MotionMode
from helixd.commands.survey_mission import survey_mission
from helixd.config.root import HelixdConfig
from helixd.mission.formats import write_mission_file
from helixd.mission.formats.areas import read_area
from tests.support.paths import DATA_DIR
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration


def test_a_survey_flies_in_its_estimated_time(tmp_path: Path) -> None:
    got = survey_mission(
        read_area(DATA_DIR / "pond_survey.plan"),
        HelixdConfig(),
        name="pond-survey",
        mode=MotionMode.ROLL,
        spacing_m=3.0,
        angle_deg=0.0,
        margin_m=25.0,  # the simulator's rover starts 20 m off the pond: inside the fence
        inset_m=None,
        time_factor=1.5,
    )
    mission = tmp_path / "survey.yaml"
    write_mission_file(got.mission, mission)
    flown = simulated_flight(tmp_path, mission, seed=5)
    code, log, run_dir = flown.code, flown.log, flown.run_dir()
    assert code == ExitCode.OK, log[-3000:]
    s = json.loads((run_dir / "summary.json").read_text())
    print(f"survey: estimated {s['estimated_s']:.1f} s at preflight, flown {s['duration_s']:.1f} s")
    assert s["estimated_s"] == pytest.approx(s["duration_s"], rel=0.10)
    assert s["duration_s"] < 0.6 * got.time_limit_s  # the limit has room for slip and pauses
    assert (s["waypoints_reached"], s["waypoints_total"]) == (16, 16)
