"""A plan re-uploaded from the ground station with as many items as the one before: ArduPilot
tells only the uploading link "Flight plan received" (the simulator too), and MISSION_CURRENT's
count does not change, so ``helixd serve`` learns of it at the start. The start flies the new
plan when it passes the checks and says which; a new plan that fails them is refused with the
reason on the crew's screen and the rover in HOLD, and the next Start Mission starts.

The ground station is scripted as QGroundControl's Start Mission (tests.support.serve)."""

from __future__ import annotations

import math
import re
import time
from pathlib import Path
from typing import Any

from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_MISSION_START,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.modes import MODE_NUMBERS
from helixd.sim.snapshot import SimSnapshot
from tests.support.gcs import upload
from tests.support.harness import MavClient, guard_installed, record_until
from tests.support.serve import SPEEDUP, heartbeat_shows, moving, serving_crew, set_mode

# no start switch; the idle service does not re-read the mission by itself during the test
CONFIG: dict[str, Any] = {
    "startup": {"start_switch_channel": None},
    "link": {"own_id_watch_s": 0.5},
    "serve": {"mission_poll_s": 3600.0},
}
PLAN_A = [(10.0, 0.0), (10.0, -8.0), (0.0, -8.0)]
PLAN_B = [(n, e + 3.0) for n, e in PLAN_A]  # the same plan moved 3 m east
PLAN_FAR = [(10.0, 0.0), (10.0, -8.0), (600.0, 0.0)]  # past mission.max_range_m (500 m)
# the crew's Start Mission after a refusal → flying (wall s): the first mode report after it
# says AUTO (MISSION_CURRENT at link.telemetry_rate_hz 5 Hz, HEARTBEAT 1 Hz: ≤ 1 s of the
# autopilot's time, 0.2 s at SPEEDUP), then a tick (0.1 s), a mission read and its check
# (≈ 0.1 s); the rest is a loaded machine's slack. Before the fix it never started.
START_AFTER_REFUSAL_S = 2.0


def start_mission(gcs: MavClient, armed: bool = False) -> None:
    """QGroundControl's Start Mission (APMFirmwarePlugin::startMission): on a rover not armed
    GUIDED and armed first; then MAV_CMD_MISSION_START to the autopilot (which enters AUTO)."""
    if armed:
        assert gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        return
    set_mode(gcs, "GUIDED")
    heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["GUIDED"])
    assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    heartbeat_shows(gcs, lambda m: m.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
    assert gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED


def plan_named(line: str) -> str:
    """The plan a serve_state line names: ``plan 1a2b3c``."""
    found = re.search(r"plan [0-9a-f]{6}", line)
    assert found is not None, line
    return found.group(0)


def near(ne: tuple[float, float], within_m: float) -> Any:
    return lambda s: math.hypot(s.north_m - ne[0], s.east_m - ne[1]) <= within_m


def test_a_same_size_reupload_is_flown_and_a_bad_one_leaves_the_rover_in_hold(
    tmp_path: Path,
) -> None:
    with serving_crew(tmp_path, CONFIG, **guard_installed(SPEEDUP)) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        upload(gcs, PLAN_A)
        plan_a = plan_named(d.wait_line("event=serve_state state=ready", 30.0))
        upload(gcs, PLAN_B)  # same count: nothing tells helixd

        mark = d.mark()
        t0 = time.monotonic()
        start_mission(gcs)
        d.wait_line("event=auto_start", 10.0, after=mark)
        flying = d.wait_line("event=serve_state state=flying", 10.0, after=mark)
        assert 'detail="the new plan ' in flying and ': 3 waypoints"' in flying, flying
        server.wait_for(moving, 20.0)
        print(f"\nStart Mission after a re-upload → moving: {time.monotonic() - t0:.3f} s")
        gcs.wait_said("flying: the new plan ", 10.0)
        assert "start refused" not in d.log_text()
        # plan B's first waypoint is reached: it is the plan flown, not A
        trace = record_until(server, near(PLAN_B[0], 0.6), 90.0)
        closest_a = min(math.hypot(s.north_m - 10.0, s.east_m) for _, s in trace.samples)
        assert closest_a > 2.0, closest_a
        d.wait_line("event=serve_state state=completed", 120.0, after=mark)

        # a same-size plan that fails the checks: refused, said, the rover left in HOLD
        upload(gcs, PLAN_FAR)
        mark = d.mark()
        start_mission(gcs)
        refused = d.wait_line("event=serve_start_refused", 15.0, after=mark)
        server.wait_for(lambda s: s.mode == "HOLD", 10.0)
        gcs.wait_said("start refused: new plan failed its checks", 10.0)
        gcs.wait_said("max_range_m", 10.0)  # the reason, from the verdict
        snap: SimSnapshot = server.snapshot()
        assert snap.speed_mps < 0.1 and not any(snap.overrides_active[:4]), snap

        # fixed and uploaded again (the same size) at once, often before any report showed
        # helixd the HOLD: the next Start Mission starts, and flies the fixed plan
        mark = d.mark()
        upload(gcs, PLAN_A)
        start_mission(gcs, armed=True)
        t0 = time.monotonic()
        flying = d.wait_line("event=serve_state state=flying", START_AFTER_REFUSAL_S, after=mark)
        started_s = time.monotonic() - t0
        assert f'detail="the new {plan_a}: 3 waypoints"' in flying, flying
        server.wait_for(moving, 20.0)
        print(
            f"\nStart Mission after a refusal → flying {started_s:.3f} s, moving "
            f"{time.monotonic() - t0:.3f} s"
        )
        # nothing drove between (no flight to a place of the start sequence's GUIDED), and the
        # AUTO held before the HOLD's acknowledgement started nothing (no second refusal)
        lines = d.log_text().splitlines()
        between = lines[lines.index(refused) :]
        assert not [ln for ln in between if "event=goto_start" in ln], between
        assert sum("event=serve_start_refused" in ln for ln in between) == 1, between
        record_until(server, near(PLAN_A[0], 0.6), 90.0)  # plan A's first waypoint


def test_an_rtl_press_is_one_or_two_texts(tmp_path: Path) -> None:
    """The crew's RTL mid-mission: the flight hands over and helixd drives home; the message
    pane shows one or two helixd texts for it, not the steps of two flights."""
    with serving_crew(tmp_path, CONFIG, **guard_installed(SPEEDUP)) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        upload(gcs, PLAN_A)
        d.wait_line("event=serve_state state=ready", 30.0)
        start_mission(gcs)
        server.wait_for(lambda s: s.north_m > 6.0, 60.0)
        gcs.wait_said("flying: auto by", 10.0)  # the start's texts read
        said_before = len(gcs.texts)
        mark = d.mark()
        set_mode(gcs, "RTL")
        d.wait_line("event=goto_start", 10.0, after=mark)
        d.wait_line("event=phase_start phase=fly", 10.0, after=d.mark())
        server.wait_for(moving, 20.0)
        gcs.recv("NO_SUCH_MESSAGE", 3.0)  # every text of the press's burst read
        burst = [t for t in gcs.texts[said_before:] if t.startswith("helixd: ")]
        print("\nRTL press said:", burst)
        assert 1 <= len(burst) <= 2, burst


def test_a_completed_mission_can_stay_armed_in_hold(tmp_path: Path) -> None:
    """serve.disarm_when_complete false: the rover ends the mission armed in HOLD, as
    ArduPilot's AUTO does, so Go to location needs no new arm."""
    armed_cfg = {**CONFIG, "serve": {**CONFIG["serve"], "disarm_when_complete": False}}
    with serving_crew(tmp_path, armed_cfg, **guard_installed(SPEEDUP)) as (server, gcs, d):
        d.wait_line("no mission on the autopilot", 60.0)
        upload(gcs, [(4.0, 0.0)])
        d.wait_line("event=serve_state state=ready", 30.0)
        start_mission(gcs)
        d.wait_line("event=serve_state state=completed", 90.0)
        snap = server.wait_for(lambda s: s.mode == "HOLD", 10.0)
        assert snap.armed and not any(snap.overrides_active[:4])
        assert "disarmed=false" in d.wait_line("event=vehicle_secured", 5.0)
