"""A plan re-uploaded from the ground station with as many items as the one before: ArduPilot
tells only the uploading link "Flight plan received" (the simulator too), and MISSION_CURRENT's
count does not change, so ``helixd serve`` learns of it at the start. The start flies the new
plan when it passes the checks and says which; a new plan that fails them is refused with the
reason on the crew's screen and the rover in HOLD, and the next Start Mission starts.

The first plan is uploaded the moment the service has read the autopilot's empty mission,
while the autopilot still boots and has sent no MISSION_CURRENT: the first count the service
sees has nothing to compare with, so it reads the mission once more. On the simulated clock
(tests.support.simulated) each of these moments falls the same way every run; the ground
station is scripted as QGroundControl's Start Mission (tests.support.loop_gcs)."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from helixd.mav.constants import MAV_CMD_MISSION_START, MAV_RESULT_ACCEPTED
from helixd.sim.sim_config import SimConfig
from tests.support.daemon import deep_merge
from tests.support.harness import guard_installed
from tests.support.loop_gcs import (
    CREW_CONFIG,
    booted,
    said,
    set_mode,
    simulated_crew,
    start_mission,
    upload,
)
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

# no start switch; the idle service does not re-read the mission by itself during the test
CONFIG = deep_merge(CREW_CONFIG, {"serve": {"mission_poll_s": 3600.0}})
GUARDED = guard_installed(1.0)
PLAN_A = [(10.0, 0.0), (10.0, -8.0), (0.0, -8.0)]
PLAN_B = [(n, e + 3.0) for n, e in PLAN_A]  # the same plan moved 3 m east
PLAN_FAR = [(10.0, 0.0), (10.0, -8.0), (600.0, 0.0)]  # past mission.max_range_m (500 m)
# an upload while the autopilot boots → ready: it streams nothing but HEARTBEAT until booted,
# then MISSION_CURRENT at 5 Hz, and one read of the mission
READY_MAX_S = SimConfig().boot_duration_s + 1.0
# the crew's Start Mission after a refusal → flying: the first mode report after it says AUTO
# (MISSION_CURRENT at link.telemetry_rate_hz 5 Hz, HEARTBEAT 1 Hz: ≤ 1 s), then a tick (0.1 s),
# a mission read and its check. Before the fix it never started.
START_AFTER_REFUSAL_S = 1.5


def plan_named(line: str) -> str:
    """The plan a serve_state line names: ``plan 1a2b3c``."""
    found = re.search(r"plan [0-9a-f]{6}", line)
    assert found is not None, line
    return found.group(0)


def near(ne: tuple[float, float], within_m: float) -> Any:
    return lambda s: math.hypot(s.north_m - ne[0], s.east_m - ne[1]) <= within_m


async def first_upload_while_booting(st: Steer, gcs: LoopMav) -> str:
    """Plan A the moment the service found no mission, the autopilot still booting; the plan
    the ready line names."""
    await st.line("no mission on the autopilot", 60.0)
    assert st.snapshot().booting  # no MISSION_CURRENT sent yet
    await upload(gcs, PLAN_A)
    uploaded_s = st.now_s()
    ready = await st.line("event=serve_state state=ready", 30.0)
    ready_s = st.now_s() - uploaded_s
    print(f"\nupload while the autopilot boots → ready: {ready_s:.2f} s")
    assert ready_s <= READY_MAX_S, ready_s
    return plan_named(ready)


async def reupload_flown(st: Steer, gcs: LoopMav) -> None:
    """Plan B, the same size: nothing tells helixd; the start flies it and says so."""
    await upload(gcs, PLAN_B)
    await booted(st, gcs)
    mark = st.mark()
    t0 = st.now_s()
    await start_mission(gcs)
    await st.line("event=auto_start", 10.0, after=mark)
    flying = await st.line("event=serve_state state=flying", 10.0, after=mark)
    assert 'detail="the new plan ' in flying and ': 3 waypoints"' in flying, flying
    await st.until(moving, 20.0)
    print(f"Start Mission after a re-upload → moving: {st.now_s() - t0:.3f} s")
    await said(gcs, "flying: the new plan ", 10.0)
    assert "start refused" not in st.console.text()
    # plan B's first waypoint is reached: it is the plan flown, not A
    trace = await st.record_until(near(PLAN_B[0], 0.6), 90.0)
    closest_a = min(math.hypot(s.north_m - 10.0, s.east_m) for s in trace)
    assert closest_a > 2.0, closest_a
    await st.line("event=serve_state state=completed", 120.0, after=mark)


def test_a_same_size_reupload_is_flown_and_a_bad_one_leaves_the_rover_in_hold(
    tmp_path: Path,
) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        plan_a = await first_upload_while_booting(st, gcs)
        await reupload_flown(st, gcs)

        # a same-size plan that fails the checks: refused, said, the rover left in HOLD
        await upload(gcs, PLAN_FAR)
        mark = st.mark()
        await start_mission(gcs)
        refused = await st.line("event=serve_start_refused", 15.0, after=mark)
        await st.until(lambda s: s.mode == "HOLD", 10.0)
        await said(gcs, "start refused: new plan failed its checks", 10.0)
        await said(gcs, "max_range_m", 10.0)  # the reason, from the verdict
        snap = st.snapshot()
        assert snap.speed_mps < 0.1 and not any(snap.overrides_active[:4]), snap

        # fixed and uploaded again (the same size) at once, before a report showed helixd the
        # HOLD: the next Start Mission starts, and flies the fixed plan
        mark = st.mark()
        await upload(gcs, PLAN_A)
        assert await gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        t0 = st.now_s()
        flying = await st.line("event=serve_state state=flying", START_AFTER_REFUSAL_S, mark)
        started_s = st.now_s() - t0
        assert f'detail="the new {plan_a}: 3 waypoints"' in flying, flying
        await st.until(moving, 20.0)
        print(
            f"Start Mission after a refusal → flying {started_s:.3f} s, moving "
            f"{st.now_s() - t0:.3f} s"
        )
        # nothing drove between (no flight to a place of the start sequence's GUIDED), and the
        # AUTO held before the HOLD's acknowledgement started nothing (no second refusal)
        lines = st.console.lines
        between = lines[lines.index(refused) :]
        assert not [ln for ln in between if "event=goto_start" in ln], between
        assert sum("event=serve_start_refused" in ln for ln in between) == 1, between
        await st.until(near(PLAN_A[0], 0.6), 90.0)  # plan A's first waypoint

    served = simulated_crew(tmp_path, CONFIG, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]


def test_an_rtl_press_is_one_or_two_texts(tmp_path: Path) -> None:
    """The crew's RTL mid-mission: the flight hands over and helixd drives home; the message
    pane shows one or two helixd texts for it, not the steps of two flights."""

    async def crew(st: Steer, gcs: LoopMav) -> list[str]:
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, PLAN_A)
        await st.line("event=serve_state state=ready", 30.0)
        await booted(st, gcs)
        await start_mission(gcs)
        await st.until(lambda s: s.north_m > 6.0, 60.0)
        await said(gcs, "flying: auto by", 10.0)  # the start's texts read
        said_before = len(gcs.texts)
        mark = st.mark()
        await set_mode(gcs, "RTL")
        await st.line("event=goto_start", 10.0, after=mark)
        await st.line("event=phase_start phase=fly", 10.0, after=st.mark())
        await st.until(moving, 20.0)
        assert await gcs.recv("NO_SUCH_MESSAGE", 3.0) is None  # the press's burst all read
        return [t for t in gcs.texts[said_before:] if t.startswith("helixd: ")]

    served = simulated_crew(tmp_path, CONFIG, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]
    (burst,) = served.steered
    print("\nRTL press said:", burst)
    assert 1 <= len(burst) <= 2, burst


def test_a_completed_mission_can_stay_armed_in_hold(tmp_path: Path) -> None:
    """serve.disarm_when_complete false: the rover ends the mission armed in HOLD, as
    ArduPilot's AUTO does, so Go to location needs no new arm."""
    armed_cfg = {**CONFIG, "serve": {**CONFIG["serve"], "disarm_when_complete": False}}

    async def crew(st: Steer, gcs: LoopMav) -> str:
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, [(4.0, 0.0)])
        await st.line("event=serve_state state=ready", 30.0)
        await booted(st, gcs)
        await start_mission(gcs)
        await st.line("event=serve_state state=completed", 90.0)
        snap = await st.until(lambda s: s.mode == "HOLD", 10.0)
        assert snap.armed and not any(snap.overrides_active[:4])
        return await st.line("event=vehicle_secured", 5.0)

    served = simulated_crew(tmp_path, armed_cfg, crew, **GUARDED)
    assert served.code == 0, served.log[-3000:]
    (secured_line,) = served.steered
    assert "disarmed=false" in secured_line
