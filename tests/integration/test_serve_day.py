"""``helixd serve`` for a whole field day against the built-in simulator, over real UDP, on the
simulated clock.

The simulator runs two links: helixd on one, a ground station (system 255, as QGroundControl)
on the other; the simulated autopilot routes between them as ArduPilot does. Missions are
uploaded with the mission protocol, commands go to helixd's own id, the start switch is the
simulator's RC input. Everything is judged from the simulator's side or from what the ground
station receives; the daemon must still be running at the end.
"""

from __future__ import annotations

import json
import re
import signal
from pathlib import Path

from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
)
from tests.support.gcs import QGC_SYSID
from tests.support.harness import secured
from tests.support.loop_gcs import booted, command, upload
from tests.support.loop_mav import LoopMav
from tests.support.serve import HIGH_US, LOW_US, SWITCH_CH
from tests.support.simulated import Steer, moving, simulated_serve

MISSION_A = [(6.0, 0.0), (6.0, -6.0)]  # north/east from the EKF origin (m)
MISSION_B = [(0.0, -12.0), (0.0, 0.0)]
FAR_AWAY = [(6.0, 0.0), (800.0, 0.0)]  # beyond mission.max_range_m (500 m)


def states(log: str) -> list[str]:
    return [
        ln.split("state=")[1].split()[0] for ln in log.splitlines() if "event=serve_state" in ln
    ]


async def day(st: Steer) -> None:
    gcs = st.ground_station(1, QGC_SYSID)
    other = st.ground_station(2, 250)  # a stranger
    st.set_rc(SWITCH_CH, LOW_US)
    await st.line("no mission on the autopilot", 60.0)
    assert not st.snapshot().armed
    # a mission helixd refuses: the GCS is told why, at severity ERROR
    await upload(gcs, FAR_AWAY)
    await st.line("event=serve_mission_refused", 30.0)
    refusal = await gcs.wait_text("helixd: refused", 20.0)
    # the first of its whole lines names the waypoint; the log has the rest
    assert refusal.startswith("helixd: refused: item 2:"), refusal
    assert len(refusal) <= 50 and not refusal.endswith(" "), refusal
    assert await command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_DENIED
    # the fixed mission: checked, then started by the switch
    await upload(gcs, MISSION_A)
    await st.line("event=serve_state state=ready", 30.0)
    await booted(st, gcs)
    assert not st.snapshot().armed  # checked, never moved on its own
    st.set_rc(SWITCH_CH, HIGH_US)
    await st.until(moving, 40.0)
    # busy while flying; a stranger is denied
    busy = await command(gcs, MAV_CMD_MISSION_START, 0, 0)
    assert busy == MAV_RESULT_TEMPORARILY_REJECTED
    assert await command(other, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_DENIED
    await paused_by_the_switch(st, gcs)
    # continue: from the interrupted leg, not from the start
    st.set_rc(SWITCH_CH, HIGH_US)
    await st.line("event=run_resumed", 30.0)
    await st.line("event=serve_state state=completed", 90.0)
    done_a = st.mark()
    await st.until(secured, 10.0)
    # the second mission, started from the GCS
    mark = st.mark()
    await upload(gcs, MISSION_B)
    await st.line("event=serve_state state=ready", 30.0, after=mark)
    assert await command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
    await st.until(moving, 40.0)
    # the autopilot's current item follows the rover (the GCS highlights it)
    await st.until(lambda s: s.mission_current_seq == 1, 10.0)
    # the pilot takes over (HOLD from the GCS): the service is left faulted
    assert await gcs.command(MAV_CMD_DO_SET_MODE, 1, 4) == MAV_RESULT_ACCEPTED
    await st.line("event=serve_state state=faulted", 30.0)
    await st.until(secured, 10.0)
    # start again: continues where it stopped, and completes
    assert await command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
    await st.until(lambda s: s.mission_current_seq == 2, 60.0)
    await st.line("event=serve_state state=completed", 90.0, after=done_a)
    assert states(st.console.text()).count("completed") == 2
    assert not st.flight_done()  # never exited
    st.signal(signal.SIGTERM)


async def paused_by_the_switch(st: Steer, gcs: LoopMav) -> None:
    """The switch low mid-leg: stopped, released, HOLD; the GCS told it is a pause, short and
    whole, and the interrupted item still shown."""
    st.set_rc(SWITCH_CH, LOW_US)
    await st.line("event=serve_state state=paused", 30.0)
    await st.until(secured, 10.0)
    assert st.snapshot().mode == "HOLD"
    # the GCS is told it is a pause, not a fault; the interrupted item stays shown
    # although ArduPilot resets its mission on the disarm
    assert "pausing: start switch low" in await gcs.wait_text("helixd: pausing", 10.0)
    assert not any("FAULT" in text for text in gcs.texts), gcs.texts
    # short and whole: no result line, no exit code, no internal cause name
    said = await gcs.wait_text("helixd: paused", 10.0)
    assert re.fullmatch(r"helixd: paused: \d/\d waypoints", said), said
    assert not any("exit" in t or "RESULT" in t for t in gcs.texts), gcs.texts
    log = st.console.text()
    assert "level=warning event=fallback" not in log
    assert "event=paused" in log
    await st.until(lambda s: s.mission_current_seq == 1, 10.0)


def test_a_field_day(tmp_path: Path) -> None:
    served = simulated_serve(tmp_path, day, links=3)  # helixd, the ground station, a stranger
    assert served.code == 0, served.log[-3000:]
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    assert len(runs) == 4, runs  # A, A continued, B, B continued: one directory per flight
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [False, True, False, True]
    assert summaries[1]["resumed_from"] is not None and summaries[3]["resumed_from"] is not None
    state = json.loads((tmp_path / "runs" / "serve-state.json").read_text())
    assert state["state"] == "completed" and state["run_dir"] is None
