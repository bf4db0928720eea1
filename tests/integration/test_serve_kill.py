"""``helixd serve`` killed with -9 mid-flight and started again by systemd (same command, no
option): the flight it cut is closed from its record, told once, and continued by the crew's
continue from its interrupted item — never by the start itself. On the simulated clock; the
kill is modelled in-process (tests.support.kill9: nothing of the killed service reaches the
wire or the disk from the kill on).

The mission (the one of test_serve_auto_from_item.py) has a DO_CHANGE_SPEED just before a
waypoint and a DO_JUMP back to it: ArduPilot's walk flies items 1, 3, 4, 3, 4.
"""

from __future__ import annotations

import io
import json
import signal
from pathlib import Path

from helixd.cli.runs import print_replay
from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from helixd.recorder.closing import KILLED_CAUSE, KILLED_EXIT_CODE
from helixd.sim.snapshot import SimSnapshot
from tests.integration.test_serve_continue_commands import NO_SWITCH, ready, run_dirs, step_lines
from tests.support.gcs import QGC_SYSID
from tests.support.harness import guard_installed, scrolls_neutral
from tests.support.kill9 import KILLED_CODE, RESTART_S
from tests.support.loop_gcs import command, said
from tests.support.simulated import Steer, moving, simulated_serve

GUARD_TIMEOUT_S = 0.5  # guard_installed(1.0): HXG_TIMEOUT
QUIET_S = 20.0  # the restarted service idles this long before the crew's continue


def test_a_flight_killed_on_its_second_lap_is_closed_told_and_continued_from_its_item(
    tmp_path: Path,
) -> None:
    """Killed on the leg to item 3 of the second lap: the scrolls at trim within the guard's
    timeout; the restarted service (no option) closes the cut run (summary: killed, exit
    137, readable by replay), says so once, drives nothing; the crew's continue flies the
    rest of the walk from item 3 (the autopilot's current item from the simulator's truth),
    the jump taken once."""

    async def killed(st: Steer) -> float:
        gcs = st.ground_station(1, QGC_SYSID)
        await ready(st, gcs)
        assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        await st.line('kind=step_started item=3 lap="lap 2 of 2"', 180.0)
        await st.until(moving, 20.0)
        assert st.snapshot().mission_current_seq == 3
        st.kill()
        t_kill = st.now_s()
        await st.until(scrolls_neutral, GUARD_TIMEOUT_S + 0.3)
        return st.now_s() - t_kill

    async def restarted(st: Steer) -> tuple[list[SimSnapshot], int, int, list[str]]:
        gcs = st.ground_station(1, QGC_SYSID)
        mark = st.mark()
        await st.line("event=serve_flight_cut", 30.0)  # logged as the service starts
        await said(gcs, "the last flight was cut; a start continues it", 30.0)
        await st.line("interrupted: a start continues it", 60.0, after=mark)
        t_quiet = st.now_s() + QUIET_S
        quiet = await st.record_until(lambda _: st.now_s() >= t_quiet, QUIET_S + 5.0)
        go = st.mark()
        assert await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 1) == MAV_RESULT_ACCEPTED
        first = await st.until(moving, 30.0)
        await st.line("event=serve_state state=completed", 240.0, after=go)
        texts = list(gcs.texts)
        st.signal(signal.SIGTERM)
        return quiet, first.mission_current_seq, go, texts

    served = simulated_serve(tmp_path, [killed, restarted], NO_SWITCH, **guard_installed(1.0))
    assert served.codes == [KILLED_CODE, 0], served.log[-3000:]
    trim_s = served.steered[0]
    quiet, first_item, go, texts = served.steered[1]
    print(
        f"\nkill → scrolls at trim {trim_s:.3f} s (helixd-guard's HXG_TIMEOUT {GUARD_TIMEOUT_S} s)"
    )
    assert trim_s <= GUARD_TIMEOUT_S + 0.3, trim_s
    # never driven by the start itself: the rover stood until the crew's continue
    assert quiet and not any(moving(s) for s in quiet)
    assert all(s.armed for s in quiet)  # left armed, as the killed service left it
    assert first_item == 3, first_item  # the interrupted item, on the autopilot
    cut_said = [t for t in texts if "flight was cut" in t]
    assert len(cut_said) == 1, texts
    log = served.log
    assert log.count("event=serve_flight_cut") == 1
    lines = log.splitlines()
    rest = step_lines("\n".join(lines[go:]))
    assert [(s, i) for s, i, _ in rest] == [(1, 3), (2, 4)], rest
    first, second = run_dirs(tmp_path)
    cut = json.loads((first / "summary.json").read_text())
    assert cut["completed"] is False and cut["exit_code"] == KILLED_EXIT_CODE, cut
    assert cut["fault"].startswith(f"{KILLED_CAUSE}:"), cut
    assert [a["number"] for a in cut["arrivals"]] == [1, 3, 4], cut["arrivals"]
    assert cut["rows"] > 0 and cut["path_length_m"] > 1.0, cut
    replay = io.StringIO()
    print_replay(first, tty=False, out=replay)
    assert "killed" in replay.getvalue()
    done = json.loads((second / "summary.json").read_text())
    assert done["completed"] is True and done["resumed_from"]["path"] == str(first.resolve())
    state = json.loads((tmp_path / "runs" / "serve-state.json").read_text())
    assert state["open_run_dir"] is None and state["run_dir"] is None, state
    assert RESTART_S > 0.0
