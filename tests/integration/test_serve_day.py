"""``helixd serve`` for a whole field day against the built-in simulator, over real UDP.

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
from tests.support.daemon import DaemonProc
from tests.support.gcs import QGC_SYSID, command, upload
from tests.support.harness import MavClient, running_sim_links, secured
from tests.support.serve import HIGH_US, LOW_US, SPEEDUP, SWITCH_CH, moving, serve_proc

MISSION_A = [(6.0, 0.0), (6.0, -6.0)]  # north/east from the EKF origin (m)
MISSION_B = [(0.0, -12.0), (0.0, 0.0)]
FAR_AWAY = [(6.0, 0.0), (800.0, 0.0)]  # beyond mission.max_range_m (500 m)


def states(d: DaemonProc) -> list[str]:
    return [ln.split("state=")[1].split()[0] for ln in d.lines if "event=serve_state" in ln]


def test_a_field_day(tmp_path: Path) -> None:
    links = ["udpin:127.0.0.1:0"] * 3  # helixd, the ground station, a stranger
    with running_sim_links(links, speedup=SPEEDUP) as server:
        helixd_url, gcs_url, other_url = (f"udpout:127.0.0.1:{p}" for p in server.local_ports)
        server.set_rc(SWITCH_CH, LOW_US)
        d = serve_proc(tmp_path, helixd_url)
        d.start_pump()
        try:
            with (
                MavClient(gcs_url, sysid=QGC_SYSID) as gcs,
                MavClient(other_url, sysid=250) as other,
            ):
                d.wait_line("no mission on the autopilot", 60.0)
                assert not server.snapshot().armed
                # a mission helixd refuses: the GCS is told why, at severity ERROR
                upload(gcs, FAR_AWAY)
                d.wait_line("event=serve_mission_refused", 30.0)
                refusal = gcs.wait_text("helixd: refused", 20.0)
                # the first of its whole lines names the waypoint; the log has the rest
                assert refusal.startswith("helixd: refused: item 2:"), refusal
                assert len(refusal) <= 50 and not refusal.endswith(" "), refusal
                assert command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_DENIED
                # the fixed mission: checked, then started by the switch
                upload(gcs, MISSION_A)
                d.wait_line("event=serve_state state=ready", 30.0)
                assert not server.snapshot().armed  # checked, never moved on its own
                server.set_rc(SWITCH_CH, HIGH_US)
                server.wait_for(moving, 40.0)
                # busy while flying; a stranger is denied
                assert command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_TEMPORARILY_REJECTED
                assert command(other, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_DENIED
                # pause by the switch mid-leg: stopped, released, HOLD
                server.set_rc(SWITCH_CH, LOW_US)
                d.wait_line("event=serve_state state=paused", 30.0)
                server.wait_for(secured, 10.0)
                paused_at = server.snapshot()
                assert paused_at.mode == "HOLD"
                # the GCS is told it is a pause, not a fault; the interrupted item stays shown
                # although ArduPilot resets its mission on the disarm
                assert "pausing: start switch low" in gcs.wait_text("helixd: pausing", 10.0)
                assert not any("FAULT" in text for text in gcs.texts), gcs.texts
                # short and whole: no result line, no exit code, no internal cause name
                said = gcs.wait_text("helixd: paused", 10.0)
                assert re.fullmatch(r"helixd: paused: \d/\d waypoints", said), said
                assert not any("exit" in t or "RESULT" in t for t in gcs.texts), gcs.texts
                assert "level=warning event=fallback" not in d.log_text()
                assert "event=paused" in d.log_text()
                server.wait_for(lambda s: s.mission_current_seq == 1, 10.0)
                # continue: from the interrupted leg, not from the start
                server.set_rc(SWITCH_CH, HIGH_US)
                d.wait_line("event=run_resumed", 30.0)
                d.wait_line("event=serve_state state=completed", 90.0)
                done_a = d.mark()
                server.wait_for(secured, 10.0)
                # the second mission, started from the GCS
                mark = d.mark()
                upload(gcs, MISSION_B)
                d.wait_line("event=serve_state state=ready", 30.0, after=mark)
                assert command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
                server.wait_for(moving, 40.0)
                # the autopilot's current item follows the rover (the GCS highlights it)
                server.wait_for(lambda s: s.mission_current_seq == 1, 10.0)
                # the pilot takes over (HOLD from the GCS): the service is left faulted
                assert gcs.command(MAV_CMD_DO_SET_MODE, 1, 4) == MAV_RESULT_ACCEPTED
                d.wait_line("event=serve_state state=faulted", 30.0)
                server.wait_for(secured, 10.0)
                # start again: continues where it stopped, and completes
                assert command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
                server.wait_for(lambda s: s.mission_current_seq == 2, 60.0)
                d.wait_line("event=serve_state state=completed", 90.0, after=done_a)
                assert states(d).count("completed") == 2, states(d)
                assert d.ended() is None  # never exited
            d.signal(signal.SIGTERM)
            assert d.wait_exit(30.0) == 0
        finally:
            d.kill()
            (tmp_path / "serve.log").write_text(d.log_text(), encoding="utf-8")  # for a failure
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    assert len(runs) == 4, runs  # A, A continued, B, B continued: one directory per flight
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [False, True, False, True]
    assert summaries[1]["resumed_from"] is not None and summaries[3]["resumed_from"] is not None
    state = json.loads((tmp_path / "runs" / "serve-state.json").read_text())
    assert state["state"] == "completed" and state["run_dir"] is None
