"""``helixd serve``: a mission with commands started again in AUTO from the autopilot's current
item after the crew took over in MANUAL, as ArduPilot runs it from there (AP_Mission::resume →
set_current_cmd: the walk from that item, the DO items before it not run, a DO_JUMP after it
still jumping back).

The scripted ground station sends what QGroundControl sends (see test_serve_crew_modes.py);
everything is judged on the simulator's truth, the service's log and the run directories.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_RESULT_ACCEPTED,
)
from tests.integration.test_serve_crew_modes import CONFIG, driving
from tests.support.gcs import do_item, waypoint
from tests.support.loop_gcs import (
    let_go_in_manual,
    set_mode,
    simulated_crew,
    upload_and_start,
    upload_items,
)
from tests.support.loop_mav import LoopMav
from tests.support.serve import flight_summaries
from tests.support.simulated import Steer, moving

SPEED_MPS = 0.4  # DO_CHANGE_SPEED item 2
# items 1..5: WP, DO_CHANGE_SPEED, WP, WP, DO_JUMP to item 2 once: flown 1, 3, 4, 3, 4
ITEMS = [
    waypoint(0, 0.0, 0.0),
    waypoint(1, 10.0, 0.0),
    do_item(2, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1.0, SPEED_MPS, -1.0),
    waypoint(3, 10.0, -8.0),
    waypoint(4, 0.0, -8.0),
    do_item(5, mavlink.MAV_CMD_DO_JUMP, 2.0, 1.0),
]


async def start_mission(st: Steer, gcs: LoopMav) -> None:
    """Upload ITEMS and press Start Mission on a disarmed rover."""
    await upload_and_start(st, gcs, lambda: upload_items(gcs, ITEMS))


def mission_flights(summaries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The summaries of the mission's flights. Start Mission's switch from GUIDED to AUTO
    can publish AUTO's first place before the HEARTBEAT names AUTO: helixd may then start a
    flight to it labelled GUIDED and hand it over to AUTO at once (a README limit); that
    flight, which drove nothing of the mission, is left out."""
    return [s for s in summaries if not str(s.get("fault") or "").startswith("handover")]


async def autopilot_item(gcs: LoopMav, seq: int, timeout_s: float = 60.0) -> None:
    await gcs.expect(
        "MISSION_CURRENT", timeout_s, lambda m: m.get_srcSystem() == 1 and m.seq == seq
    )


def test_auto_again_after_manual_flies_a_commands_mission_from_the_current_item(
    tmp_path: Path,
) -> None:

    async def crew(st: Steer, gcs: LoopMav) -> str:
        await start_mission(st, gcs)
        # item 1 reached: the autopilot's current item is 3, on the first lap
        await autopilot_item(gcs, 3)
        await let_go_in_manual(st, gcs)

        # AUTO again: from item 3, not refused
        mark = st.mark()
        await set_mode(gcs, "AUTO")
        await st.line("event=auto_start item=3", 10.0, after=mark)
        await st.until(driving, 10.0)
        assert await gcs.wait_text("Mission Complete", 180.0) == "Mission Complete"
        done = await gcs.wait_text("helixd: completed", 60.0)
        await st.line("event=serve_state state=completed", 10.0, after=mark)
        return done

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    log, (done,) = served.log, served.steered
    assert "cannot start" not in log
    assert 'kind=step_started item=3 lap="lap 1 of 2" command=NAV_WAYPOINT step=1' in log
    assert 'state=completed hx_state=7 detail="4/4 waypoints as flown, last item 4/5"' in log
    summaries = mission_flights(flight_summaries(tmp_path))
    assert [s["completed"] for s in summaries] == [False, True], summaries
    assert summaries[0]["fault"].startswith("released: mode MANUAL"), summaries[0]
    arrivals = summaries[1]["arrivals"]
    assert [a["number"] for a in arrivals] == [3, 4, 3, 4]  # from item 3, the jump taken once
    # lap 1 at the cruise speed (item 2 before the start is not run), lap 2 after the jump
    # through item 2's DO_CHANGE_SPEED: the same 10 m leg (4 → 3 vs 3 → 4) takes longer
    t = [a["t_boot_s"] for a in arrivals]
    lap1_s, lap2_s = t[1] - t[0], t[2] - t[1]
    print(f"\n{done}; 10 m legs: {lap1_s:.1f} s at cruise, {lap2_s:.1f} s at {SPEED_MPS} m/s")
    assert lap2_s > 1.3 * lap1_s, (lap1_s, lap2_s)


def test_auto_again_on_a_later_lap_keeps_the_autopilots_jump_counters(tmp_path: Path) -> None:
    """Let go on the second lap (the DO_JUMP taken once): ArduPilot's resume keeps its jump
    counters, so AUTO again flies the rest of that lap, item 3 then 4, not two more laps."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await start_mission(st, gcs)
        await autopilot_item(gcs, 3)
        await autopilot_item(gcs, 4, 120.0)
        await autopilot_item(gcs, 3, 120.0)  # after the jump: lap 2
        await let_go_in_manual(st, gcs)

        mark = st.mark()
        await set_mode(gcs, "AUTO")
        await st.line("event=auto_walk_held first_item=1", 10.0, after=mark)
        await st.line("event=auto_start item=3", 10.0, after=mark)
        await st.until(driving, 10.0)
        assert await gcs.wait_text("Mission Complete", 180.0) == "Mission Complete"
        await st.line("event=serve_state state=completed", 60.0, after=mark)

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    log = served.log
    # helixd was let go on item 4 (step 3; or item 3 of lap 2, step 4, had it got there too)
    # while the autopilot had gone on to item 3 of lap 2
    assert re.search(r"event=auto_walk_held first_item=1 step=[34] ", log), log
    started = 'kind=step_started item=3 lap=null command=NAV_WAYPOINT step=1 text="NAV_WAYPOINT'
    assert started in log and "(after DO_JUMP item 5, 1 of 1)" in log
    summaries = mission_flights(flight_summaries(tmp_path))
    assert [s["completed"] for s in summaries] == [False, True], summaries
    assert [a["number"] for a in summaries[1]["arrivals"]] == [3, 4]


def test_set_current_item_in_a_commands_mission_keeps_the_autopilots_jump_counters(
    tmp_path: Path,
) -> None:
    """QGroundControl's set current waypoint (Vehicle::setCurrentMissionSequence:
    DO_SET_MISSION_CURRENT to the autopilot) on lap 2, back to item 1: a move the walk does
    not make, so helixd goes there; set_current_cmd keeps the DO_JUMP taken once of once, so
    ArduPilot and helixd fly one lap from item 1 (1, 3, 4) and complete, not two."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await start_mission(st, gcs)
        await autopilot_item(gcs, 3)
        await autopilot_item(gcs, 4, 120.0)
        await autopilot_item(gcs, 3, 120.0)  # back through the DO_JUMP: the walk's own move
        # the crew clicks once helixd has seen it too (each link has its own 5 Hz
        # MISSION_CURRENT: a click within 0.2 s of the jump would beat helixd's report)
        await st.line("event=autopilot_step item=3 step=4", 10.0)
        mark = st.mark()
        assert await gcs.command(MAV_CMD_DO_SET_MISSION_CURRENT, 1) == MAV_RESULT_ACCEPTED
        await st.line("event=autopilot_item_set item=1 autopilot_step=4", 10.0, after=mark)
        await st.line("event=auto_walk_held first_item=1 step=4 exact=true", 10.0, after=mark)
        await st.line("event=auto_start item=1", 10.0, after=mark)
        await st.until(moving, 10.0)
        assert st.snapshot().mode == "AUTO"  # no HOLD asked between the flights
        assert await gcs.wait_text("Mission Complete", 180.0) == "Mission Complete"
        await st.line("event=serve_state state=completed", 60.0, after=mark)

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    log = served.log
    assert log.count("event=autopilot_item_set") == 1  # the jump back was not taken for one
    summaries = mission_flights(flight_summaries(tmp_path))
    assert [s["completed"] for s in summaries] == [False, True], summaries
    assert summaries[0]["fault"].startswith("item_set: item 1 set"), summaries[0]
    assert [a["number"] for a in summaries[1]["arrivals"]] == [1, 3, 4]


def test_an_item_set_while_the_pilot_drives_keeps_the_counters_too(tmp_path: Path) -> None:
    """MANUAL on lap 2, then the crew sets item 1 (the mission stopped: set_current_cmd keeps
    the counters) and selects AUTO: the walk from item 1 with the jump taken once of once,
    counted where the autopilot's own item was when helixd let go: one lap, 1 3 4."""

    async def crew(st: Steer, gcs: LoopMav) -> None:
        await start_mission(st, gcs)
        await autopilot_item(gcs, 3)
        await autopilot_item(gcs, 4, 120.0)
        await autopilot_item(gcs, 3, 120.0)  # lap 2
        await st.line("event=autopilot_step item=3 step=4", 10.0)  # seen by helixd too
        await let_go_in_manual(st, gcs)
        assert await gcs.command(MAV_CMD_DO_SET_MISSION_CURRENT, 1) == MAV_RESULT_ACCEPTED
        await autopilot_item(gcs, 1, 10.0)
        mark = st.mark()
        await set_mode(gcs, "AUTO")
        await st.line("event=auto_walk_held first_item=1 step=4 exact=true", 10.0, after=mark)
        await st.line("event=auto_start item=1", 10.0, after=mark)
        assert await gcs.wait_text("Mission Complete", 180.0) == "Mission Complete"
        await st.line("event=serve_state state=completed", 60.0, after=mark)

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    summaries = mission_flights(flight_summaries(tmp_path))
    assert [s["completed"] for s in summaries] == [False, True], summaries
    assert [a["number"] for a in summaries[1]["arrivals"]] == [1, 3, 4]


def test_auto_from_a_do_item_left_current_by_a_new_plan_is_one_flight_not_a_loop(
    tmp_path: Path,
) -> None:
    """The autopilot's current item 2 (a waypoint of the first plan) stays current when a
    plan with a DO_CHANGE_SPEED at item 2 is uploaded; AUTO again flies from it: one flight
    that runs item 2 with item 3's step, not flights ended at once as the crew's set current
    and started there again (soak seed 10's hour: 580 in a row)."""
    first = [waypoint(0, 0.0, 0.0), waypoint(1, 4.0, 0.0), waypoint(2, 4.0, -8.0)]
    second = [
        waypoint(0, 0.0, 0.0),
        waypoint(1, 4.0, 0.0),
        do_item(2, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1.0, SPEED_MPS, -1.0),
        waypoint(3, 10.0, -8.0),
    ]

    async def crew(st: Steer, gcs: LoopMav) -> int:
        await upload_and_start(st, gcs, lambda: upload_items(gcs, first))
        await autopilot_item(gcs, 2)
        await let_go_in_manual(st, gcs)  # the flight ends, the autopilot armed in MANUAL
        mark = st.mark()
        await upload_items(gcs, second)
        await st.line("event=serve_mission_checked waypoints=3", 30.0, after=mark)
        go = st.mark()
        await set_mode(gcs, "AUTO")
        await st.line("event=auto_start item=2", 10.0, after=go)
        await st.until(driving, 10.0)
        await st.line("event=serve_state state=completed", 120.0, after=go)
        return go

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    (go,) = served.steered
    after = "\n".join(served.log.splitlines()[go:])
    assert "set: flying there" not in after, after[-3000:]
    assert after.count("event=serve_flight_start") == 1, after[-3000:]
