"""A new plan uploaded while helixd flies the old one in MANUAL (a start through helixd's own
id, or the start switch): the flight goes on with its own plan to its end (a start flies the
new one) and says so once; it no longer sets the autopilot's current item, whose numbers now
name the new plan's items. Before, it set the old plan's next item (3, a waypoint there) on
the new plan, where item 3 is a DO_CHANGE_SPEED that ArduPilot's ``set_current_cmd`` moves
on to the next waypoint: the crew saw item 4 current, an item nobody flew (soak seed 3014,
rule item_order). Judged from the simulator's MISSION_CURRENT."""

from __future__ import annotations

from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import MAV_CMD_MISSION_START, MAV_RESULT_ACCEPTED
from helixd.serve.flights import NEW_PLAN_TEXT
from tests.integration.test_serve_continue_commands import NO_SWITCH
from tests.support.gcs import do_item, waypoint
from tests.support.loop_gcs import command, simulated_crew, upload_items
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

OLD = [  # the plan flown: WP 1, a speed at 2, WP 3, WP 4
    waypoint(0, 0.0, 0.0),
    waypoint(1, 6.0, 0.0),
    do_item(2, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.5, -1.0),
    waypoint(3, 6.0, 6.0),
    waypoint(4, 0.0, 6.0),
]
NEW = [  # uploaded mid-leg to item 1: a speed at 3, as seed 3014's second plan; its count
    # differs (MISSION_CURRENT.total: what helixd's link sees of an upload on another link —
    # ArduPilot says "Flight plan received" only to the uploader, a MISSION_ACK goes to it)
    waypoint(0, 0.0, 0.0),
    waypoint(1, -5.0, -5.0),
    waypoint(2, -8.0, -2.0),
    do_item(3, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.9, -1.0),
    waypoint(4, -2.0, -8.0),
    waypoint(5, -4.0, -9.0),
]


def test_a_new_plan_mid_flight_is_told_and_gets_no_item_of_the_old(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> tuple[list[int], list[str]]:
        await st.line("no mission on the autopilot", 60.0)
        await upload_items(gcs, OLD)
        await st.line("event=serve_state state=ready", 30.0)
        mark = st.mark()
        assert await command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        await st.line("event=mission_current_set seq=1", 30.0, after=mark)
        await st.until(moving, 30.0)
        await upload_items(gcs, NEW)  # mid-leg to item 1
        shown = await st.record_until(lambda s: not s.armed, 180.0)
        await st.line("event=serve_state state=completed", 30.0, after=mark)
        return sorted({s.mission_current_seq for s in shown}), list(gcs.texts)

    served = simulated_crew(tmp_path, NO_SWITCH, crew)
    assert served.code == 0, served.log[-3000:]
    ((shown, texts),) = served.steered
    # the old plan flown whole (items 1, 3, 4: its walk), the new plan's items never set
    assert served.log.count("event=waypoint_reached") == 3, served.log[-3000:]
    assert 4 not in shown and 3 not in shown, shown
    assert served.log.count("event=mission_current_not_set") == 1
    assert texts.count(f"helixd: {NEW_PLAN_TEXT}") == 1, texts
