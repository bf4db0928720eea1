"""Set current waypoint from the ground station during a flight helixd drives in MANUAL (a
start through helixd's own id, or the start switch): set current is a command of AUTO (README,
"Set current waypoint"); in MANUAL ArduPilot's mission is not running and
``AP_Mission::set_current_cmd`` only moves its current command. helixd flies its own walk and
shows the item it flies as the autopilot's current again at its next step: the crew's item
shows until then, no item is skipped or flown twice (the soak's seed 102, rule item_order).
Judged from the simulator's MISSION_CURRENT."""

from __future__ import annotations

from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.snapshot import SimSnapshot
from tests.integration.test_serve_continue_commands import NO_SWITCH, step_lines
from tests.support.gcs import do_item, waypoint
from tests.support.loop_gcs import command, simulated_crew, upload_items
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

# items 1..4: WP, DO_CHANGE_SPEED, WP, WP (as seed 102's: a speed at item 2)
ITEMS = [
    waypoint(0, 0.0, 0.0),
    waypoint(1, 8.0, 0.0),
    do_item(2, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.5, -1.0),
    waypoint(3, 8.0, -6.0),
    waypoint(4, 0.0, -6.0),
]
LAST = 4


def test_set_current_in_a_flight_helixd_drives_in_manual_keeps_its_walk(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> list[int]:
        await st.line("no mission on the autopilot", 60.0)
        await upload_items(gcs, ITEMS)
        await st.line("event=serve_state state=ready", 30.0)
        mark = st.mark()
        assert await command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        await st.line("event=mission_current_set seq=1", 30.0, after=mark)
        await st.until(moving, 30.0)
        assert st.snapshot().mode == "MANUAL"
        # QGroundControl's set current to the autopilot: the last item, mid-leg to item 1
        assert await gcs.command(MAV_CMD_DO_SET_MISSION_CURRENT, LAST) == MAV_RESULT_ACCEPTED
        seen = await st.record_until(lambda s: s.mission_current_seq == LAST, 5.0)
        after = await st.record_until(done, 120.0)
        await st.line("event=serve_state state=completed", 30.0, after=mark)
        return distinct([s.mission_current_seq for s in seen + after])

    served = simulated_crew(tmp_path, NO_SWITCH, crew)
    assert served.code == 0, served.log[-3000:]
    (shown,) = served.steered
    # (1,) the crew's 4, then helixd's own 3 after item 1, then 4: its walk, whole, in order
    # (0: ArduPilot resets the mission when disarmed outside AUTO, at the end)
    assert [seq for seq in shown if seq != 0][-3:] == [LAST, 3, LAST], shown
    assert shown[0] in (1, LAST), shown
    assert [(s, i) for s, i, _ in step_lines(served.log)] == [(1, 1), (2, 3), (3, 4)]
    assert served.log.count("event=serve_flight_start") == 1  # no new flight: the same walk


def done(s: SimSnapshot) -> bool:
    return not s.armed


def distinct(seqs: list[int]) -> list[int]:
    out: list[int] = []
    for seq in seqs:
        if not out or out[-1] != seq:
            out.append(seq)
    return out
