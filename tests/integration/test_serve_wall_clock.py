"""``helixd serve`` on the wall clock, as the rover runs it: a separate process over real UDP
against the simulator at 5×, a ground station's Start Mission, Pause and Continue (MAVLink
commands to helixd), and the mission completed. The rest of the serve tests fly the same code
on the simulated clock (tests.support.simulated); this one keeps the real clock proven."""

from __future__ import annotations

import json
import signal
from pathlib import Path

from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from tests.support.gcs import command, upload
from tests.support.harness import secured
from tests.support.serve import moving, serving_crew

NO_SWITCH = {"startup": {"start_switch_channel": None}}
MISSION = [(6.0, 0.0), (6.0, -6.0)]  # north/east from the EKF origin (m)


def test_start_pause_continue_on_the_wall_clock(tmp_path: Path) -> None:
    with serving_crew(tmp_path, NO_SWITCH) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        upload(gcs, MISSION)
        d.wait_line("event=serve_state state=ready", 30.0)
        assert command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        server.wait_for(moving, 40.0)
        assert command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_ACCEPTED
        d.wait_line("event=serve_state state=paused", 30.0)
        server.wait_for(secured, 10.0)
        assert command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 1) == MAV_RESULT_ACCEPTED
        d.wait_line("event=run_resumed", 30.0)
        d.wait_line("event=serve_state state=completed", 90.0)
        server.wait_for(secured, 10.0)
        assert d.ended() is None
        d.signal(signal.SIGTERM)
        assert d.wait_exit(30.0) == 0
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [False, True]
    assert summaries[1]["resumed_from"] is not None
