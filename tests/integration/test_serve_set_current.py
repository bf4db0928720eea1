"""Set current waypoint mid-leg from the ground station: the new leg starts where the rover is,
as ArduPilot's ``AR_WPNav::set_desired_location`` starts an interrupted leg from the stopping
point, and never runs along the skipped item's line. Judged on the simulator's true track."""

from __future__ import annotations

import math
from pathlib import Path

from helixd.mav.constants import MAV_CMD_DO_SET_MISSION_CURRENT, MAV_RESULT_ACCEPTED
from helixd.sim.snapshot import SimSnapshot
from tests.integration.test_serve_crew_modes import CONFIG
from tests.support.harness import guard_installed
from tests.support.loop_gcs import booted, simulated_crew, start_mission, upload
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer

PLAN = [(15.0, 0.0), (15.0, 10.0), (0.0, 10.0), (-5.0, 10.0)]  # items 1..4, north/east (m)
SKIPPED = PLAN[2]  # item 3
TARGET = PLAN[3]  # item 4
SKIPPED_CLEARANCE_MIN_M = 1.2  # the straight line from the switch passes ≥ 1.4 m from item 3
LINE_ERROR_MAX_M = 0.8


def off_line(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """Distance of ``p`` from the segment a→b (m)."""
    ax, ay, bx, by, px, py = *a, *b, *p
    dx, dy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(px - (ax + t * dx), py - (ay + t * dy))


def on_leg_to_item_2(s: SimSnapshot) -> bool:
    return s.north_m > 13.5 and s.east_m > 1.5


def at_target(s: SimSnapshot) -> bool:
    return math.hypot(s.north_m - TARGET[0], s.east_m - TARGET[1]) <= 0.5


def test_set_current_mid_leg_drives_from_where_the_rover_is(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> tuple[float, float]:
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, PLAN)
        await st.line("event=serve_state state=ready", 30.0)
        await booted(st, gcs)
        await start_mission(gcs)
        switch = await st.until(on_leg_to_item_2, 90.0)
        mark = st.mark()
        assert await gcs.command(MAV_CMD_DO_SET_MISSION_CURRENT, 4) == MAV_RESULT_ACCEPTED
        await st.line("event=auto_start item=4", 10.0, after=mark)
        after = await st.record_until(at_target, 90.0)
        start = (switch.north_m, switch.east_m)
        clearance = min(math.hypot(s.north_m - SKIPPED[0], s.east_m - SKIPPED[1]) for s in after)
        worst = max(off_line((s.north_m, s.east_m), start, TARGET) for s in after)
        return clearance, worst

    served = simulated_crew(tmp_path, CONFIG, crew, **guard_installed(1.0))
    assert served.code == 0, served.log[-3000:]
    ((clearance, worst),) = served.steered
    print(f"\nitem 3 passed at {clearance:.2f} m; off the straight line at most {worst:.2f} m")
    assert clearance >= SKIPPED_CLEARANCE_MIN_M, clearance
    assert worst <= LINE_ERROR_MAX_M, worst
