"""``helixd serve``: a mission with commands paused and continued through helixd's own id
(DO_PAUSE_CONTINUE 0 / 1 to system 247 component 191), also across a restart of the service,
and MISSION_START to helixd from a later item (param1 k > 1).

The mission (the one of test_serve_auto_from_item.py) has a DO_CHANGE_SPEED just before a
waypoint and a DO_JUMP back to it: ArduPilot's walk flies items 1, 3, 4, 3, 4. Everything is
judged on the service's log, the ground station's STATUSTEXTs and the run directories.
"""

from __future__ import annotations

import json
import re
import signal
from pathlib import Path
from typing import Any

import pytest

from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
)
from tests.integration.test_serve_auto_from_item import ITEMS, SPEED_MPS
from tests.support.gcs import QGC_SYSID
from tests.support.harness import secured
from tests.support.loop_gcs import command, said, simulated_crew, upload, upload_items
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving, simulated_serve

NO_SWITCH: dict[str, Any] = {"startup": {"start_switch_channel": None}}


async def ready(st: Steer, gcs: LoopMav) -> None:
    await st.line("no mission on the autopilot", 60.0)
    await upload_items(gcs, ITEMS)
    await st.line("event=serve_state state=ready", 30.0)


def step_lines(log: str) -> list[tuple[int, int, str]]:
    """(step, item, lap) of every step_started the log holds, in order."""
    pattern = r'kind=step_started item=(\d+) lap=("[^"]*"|null) command=\w+ step=(\d+)'
    return [(int(s), int(i), lap) for i, lap, s in re.findall(pattern, log)]


def run_dirs(tmp_path: Path) -> list[Path]:
    return sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())


@pytest.mark.parametrize("restart", [False, True], ids=["same-service", "service-restarted"])
def test_a_commands_mission_paused_on_its_second_lap_continues_the_rest_of_the_walk(
    tmp_path: Path, restart: bool
) -> None:
    """Paused on the second lap (item 3 after the DO_JUMP, step 4 of 5), then continued (by
    the same service, or by one restarted in between, which reads the interrupted flight
    back from serve-state.json and its run directory): the flight goes on with that lap
    (item 2's DO_CHANGE_SPEED again, items 3 and 4), not with the jump from zero (two laps
    more) nor from item 1."""

    async def go_on(st: Steer, gcs: LoopMav) -> tuple[str, int]:
        assert not st.snapshot().armed
        mark = st.mark()
        assert await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 1) == MAV_RESULT_ACCEPTED
        walk = await st.line("event=serve_continue_walk", 30.0, after=mark)
        await st.line("event=run_resumed", 30.0, after=mark)
        await st.line("event=serve_state state=completed", 180.0, after=mark)
        st.signal(signal.SIGTERM)
        return walk, mark

    async def paused(st: Steer) -> tuple[str, int] | None:
        gcs = st.ground_station(1, QGC_SYSID)
        await ready(st, gcs)
        assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        await st.line('kind=step_started item=3 lap="lap 2 of 2"', 180.0)
        await st.until(moving, 20.0)  # on the leg to item 3 of lap 2
        mark = st.mark()
        assert await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_ACCEPTED
        await st.line("event=serve_state state=paused", 30.0, after=mark)
        await st.until(secured, 10.0)
        if restart:
            st.signal(signal.SIGTERM)
            return None
        return await go_on(st, gcs)

    async def restarted(st: Steer) -> tuple[str, int]:
        gcs = st.ground_station(1, QGC_SYSID)
        await st.line("interrupted: a start continues it", 60.0, after=st.mark())
        return await go_on(st, gcs)

    served = simulated_serve(tmp_path, [paused, restarted] if restart else [paused], NO_SWITCH)
    assert served.codes == [0] * (2 if restart else 1), served.log[-3000:]
    walk, mark = served.steered[-1]
    lines = served.log.splitlines()
    first_log = "\n".join(lines[:mark])
    second_log = "\n".join(lines[mark:])
    assert "cannot continue" not in second_log
    # the walk restarts at item 2 (the DO_CHANGE_SPEED started with item 3), the jump taken
    # once, at the speed in effect before that step (item 2's, from lap 1)
    assert "first_item=2 " in walk and "jumps_taken=[[5,1]]" in walk, walk
    assert f"speed_mps={SPEED_MPS}" in walk, walk
    # the paused flight had started the whole first lap and item 3 of the second
    flown = step_lines(first_log)
    assert [(s, i) for s, i, _ in flown] == [(1, 1), (2, 3), (3, 4), (4, 3)], flown
    # after the continue: exactly the rest of the walk, item 3 again then item 4, lap 2 of 2
    rest = step_lines(second_log)
    assert [(s, i) for s, i, _ in rest] == [(1, 3), (2, 4)], rest
    assert f"event=mission_speed item=2 speed_mps={SPEED_MPS}" in second_log
    first, second = run_dirs(tmp_path)
    summaries = [json.loads((r / "summary.json").read_text()) for r in (first, second)]
    assert [s["completed"] for s in summaries] == [False, True], summaries
    assert summaries[1]["resumed_from"]["path"] == str(first.resolve())
    assert [a["number"] for a in summaries[1]["arrivals"]] == [3, 4]
    inputs = json.loads((second / "inputs.json").read_text())
    assert inputs["walk"] == {
        "first_item": 2,
        "jumps_taken": [[5, 1]],
        "speed_mps": pytest.approx(SPEED_MPS, abs=1e-6),  # a float32 mission parameter
        "reverse": False,
    }
    assert (second / "mission.yaml").read_text() == (first / "mission.yaml").read_text()


def test_mission_start_to_helixd_from_item_three(tmp_path: Path) -> None:
    """MISSION_START param1 3: the walk from item 3 with the jump counters at zero (as
    AP_Mission::start, then set_current_cmd(3)): 3, 4, then the jump through item 2 to 3, 4.
    An item outside the mission is DENIED, with the range told."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await ready(st, gcs)
        assert await command(gcs, MAV_CMD_MISSION_START, 9, 0) == MAV_RESULT_DENIED
        # one STATUSTEXT holds 50 characters: the text comes in lines, each "helixd: "
        await said(
            gcs,
            "MISSION_START param1 (first item) 9 is not in the mission: 0 (continue) or an "
            "item 1..5",
            10.0,
        )
        assert not st.snapshot().armed
        mark = st.mark()
        assert await command(gcs, MAV_CMD_MISSION_START, 3, -1) == MAV_RESULT_ACCEPTED
        await st.line("event=serve_flight_start request=from_item", 10.0, after=mark)
        await st.until(moving, 30.0)
        await st.line("event=serve_state state=completed", 180.0, after=mark)

    served = simulated_crew(tmp_path, NO_SWITCH, crew)
    assert served.code == 0, served.log[-3000:]
    steps = step_lines(served.log)
    assert [(s, i) for s, i, _ in steps] == [(1, 3), (2, 4), (3, 3), (4, 4)], steps
    (run,) = run_dirs(tmp_path)
    summary = json.loads((run / "summary.json").read_text())
    assert summary["completed"] is True
    assert [a["number"] for a in summary["arrivals"]] == [3, 4, 3, 4]
    assert json.loads((run / "inputs.json").read_text())["walk"]["first_item"] == 3


def test_mission_start_to_helixd_from_item_three_of_a_plain_waypoint_mission(
    tmp_path: Path,
) -> None:
    """A mission of waypoints only from item 3: waypoints 1 and 2 are left out, the first leg
    re-enters the leg from waypoint 2 to 3; the reached waypoints keep the mission's numbers."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, [(6.0, 0.0), (6.0, -6.0), (0.0, -6.0), (0.0, -10.0)])
        await st.line("event=serve_state state=ready", 30.0)
        mark = st.mark()
        assert await command(gcs, MAV_CMD_MISSION_START, 3, 4) == MAV_RESULT_ACCEPTED
        await st.line("event=serve_flight_start request=from_item", 10.0, after=mark)
        await st.until(moving, 30.0)
        await st.line("event=serve_state state=completed", 120.0, after=mark)

    served = simulated_crew(tmp_path, NO_SWITCH, crew)
    assert served.code == 0, served.log[-3000:]
    (run,) = run_dirs(tmp_path)
    summary = json.loads((run / "summary.json").read_text())
    assert summary["completed"] is True
    assert [a["number"] for a in summary["arrivals"]] == [3, 4]
    assert 'detail="4/4 waypoints"' in served.log
