"""helixd.serve.service: the service itself, beside the built-in simulator on the simulated
clock, a ground station on the simulator's second link (tests.support.loop_gcs): what it
answers before there is anything to fly, and a pause asked from the ground station carried
to the flight with who asked, into the run's summary and the state file."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from helixd.mav.constants import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
)
from helixd.serve.options import STATE_FILE_NAME
from tests.support.gcs import QGC_SYSID
from tests.support.harness import secured
from tests.support.loop_gcs import booted, command, said, simulated_crew, upload
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

NO_SWITCH: dict[str, Any] = {"startup": {"start_switch_channel": None}}
MISSION = [(15.0, 0.0), (15.0, -8.0)]  # north/east from the EKF origin (m)


def test_before_a_mission_every_start_is_denied_and_the_crew_told_why(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> list[int]:
        await st.line('state=idle hx_state=1 detail="no mission on the autopilot"', 60.0)
        results = [
            await command(gcs, MAV_CMD_MISSION_START, 1, 0),
            await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 0),  # nothing flies
            await command(gcs, MAV_CMD_DO_CHANGE_SPEED, 1, 0.5),
        ]
        await said(gcs, "cannot start: no mission on the autopilot", 5.0)
        await said(gcs, "pause: not flying", 5.0)
        stranger = st.ground_station(1, 250)  # not one of serve.gcs_system_ids
        results.append(await command(stranger, MAV_CMD_MISSION_START, 1, 0))
        return results

    served = simulated_crew(tmp_path, NO_SWITCH, crew)
    assert served.code == 0, served.log[-3000:]
    assert served.steered[0] == [MAV_RESULT_DENIED] * 4
    assert "system 250 is not a ground station of this rover" in served.log
    assert "event=serve_flight_start" not in served.log
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())


def test_a_pause_from_the_ground_station_ends_the_flight_as_the_crews_with_who_asked(
    tmp_path: Path,
) -> None:
    """DO_PAUSE_CONTINUE 0 to helixd: the flight ends paused (not a fault), its summary
    names the reason and the sender, and the state file keeps it for a continue."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, MISSION)
        await st.line("event=serve_state state=ready", 30.0)
        await booted(st, gcs)
        assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        await st.until(moving, 30.0)
        mark = st.mark()
        assert await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_ACCEPTED
        await st.line("event=serve_state state=paused", 30.0, after=mark)
        await st.until(secured, 10.0)

    served = simulated_crew(tmp_path, NO_SWITCH, crew)
    assert served.code == 0, served.log[-3000:]
    (run_dir,) = [p for p in (tmp_path / "runs").iterdir() if p.is_dir()]
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert summary["completed"] is False
    assert summary["fault"] == f"paused: pause from the ground station (system {QGC_SYSID})"
    state = json.loads((tmp_path / "runs" / STATE_FILE_NAME).read_text(encoding="utf-8"))
    assert state["state"] == "paused" and state["run_dir"] == str(run_dir.resolve())
