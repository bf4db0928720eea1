"""``helixd serve``'s mission time limit counts driving time only, and each flight has its
own ``link.tlog``.

The real service against the built-in simulator on the simulated clock with a scripted ground
station (system 255), as in test_serve_crew_modes.py: ``safety.mission_time_limit_s`` is set
to 30 s, a mission of about 16 s is paused in HOLD for longer than that, then continued in
AUTO, and it completes; then a Go-to-location flight holds at its place for longer than the
limit and is let go in MANUAL. Neither is a ``mission_time`` fault, though both flights last
longer than the limit in autopilot time (what the limit counted before). Each flight's run
directory holds a non-empty ``link.tlog`` that pymavlink reads, with that flight's traffic
only.
"""

from __future__ import annotations

from pathlib import Path

from helixd.base.run_files import TLOG_FILE
from helixd.sim.firmware.modes import MODE_NUMBERS
from tests.integration.test_serve_crew_modes import CONFIG, driving, overriding_neutral
from tests.integration.test_serve_goto import ARRIVAL_M, armed_in_manual, go_to_location, near
from tests.support.harness import deep_merge, guard_installed, overrides_released
from tests.support.loop_gcs import (
    heartbeat_shows,
    set_mode,
    simulated_crew,
    upload,
    upload_and_start,
)
from tests.support.loop_mav import LoopMav
from tests.support.mavmsgs import read_tlog
from tests.support.serve import flight_summaries
from tests.support.simulated import Steer

LIMIT_S = 30.0  # the mission below is estimated at about 16 s
HELD_S = LIMIT_S + 10.0  # simulated time held for the crew, each flight: over the limit
TIME_LIMITED = deep_merge(CONFIG, {"safety": {"mission_time_limit_s": LIMIT_S}})
MISSION = [(8.0, 0.0)]  # north/east from the EKF origin (m)
PLACE_NE = (8.0, 4.0)


async def held_for_the_crew(st: Steer, mode: str) -> None:
    """``HELD_S`` of simulated time held at neutral by helixd's overrides, armed, in ``mode``."""
    t0 = st.snapshot().sim_time_s
    trace = await st.record_until(lambda s: s.sim_time_s >= t0 + HELD_S, 60.0)
    later = [s for s in trace if s.sim_time_s >= t0 + 0.5]
    assert later and all(overriding_neutral(s) and s.armed and s.mode == mode for s in later)


def test_time_held_for_the_crew_is_not_counted_and_each_flight_has_its_tlog(
    tmp_path: Path,
) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        # QGC's Plan view: Upload; Start Mission (APMFirmwarePlugin::startMission)
        await upload_and_start(st, gcs, lambda: upload(gcs, MISSION))

        # Pause (HOLD) for longer than the whole limit, then Continue (AUTO)
        await set_mode(gcs, "HOLD")
        await st.until(overriding_neutral, 5.0)
        await held_for_the_crew(st, "HOLD")
        await set_mode(gcs, "AUTO")
        await st.until(driving, 10.0)
        assert await gcs.wait_text("Mission Complete", 120.0) == "Mission Complete"
        await st.line("event=serve_state state=completed", 60.0)

        # Go to location, held there for longer than the limit, then MANUAL lets go
        await st.until(lambda s: not s.armed, 30.0)  # a completed mission ends disarmed
        await set_mode(gcs, "MANUAL")
        await heartbeat_shows(gcs, lambda m: m.custom_mode == MODE_NUMBERS["MANUAL"])
        await armed_in_manual(st, gcs)
        mark = st.mark()
        await go_to_location(gcs, *PLACE_NE)
        await st.until(near(PLACE_NE, ARRIVAL_M), 90.0)
        await st.line("event=goto_arrived", 30.0, after=mark)
        await held_for_the_crew(st, "GUIDED")
        await set_mode(gcs, "MANUAL")
        await st.until(overrides_released, 5.0)
        await st.line("event=serve_flight_end", 10.0, after=mark)

    served = simulated_crew(tmp_path, TIME_LIMITED, crew, **guard_installed(1.0))
    assert served.code == 0, served.log[-3000:]
    assert "cause=mission_time" not in served.log
    assert "event=fallback" not in served.log

    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    summaries = flight_summaries(tmp_path)
    assert summaries[0]["completed"], summaries[0]
    assert summaries[1]["fault"].startswith("released: mode MANUAL"), summaries[1]
    # each flight lasted longer than the limit on the autopilot's clock, which it counts
    assert all(s["duration_s"] > LIMIT_S for s in summaries), summaries

    # a link.tlog per flight, read back by pymavlink: the autopilot's messages and helixd's
    # overrides, the first flight's all before the second's
    spans = []
    for run in runs:
        msgs = read_tlog(run / TLOG_FILE)
        kinds = {m.get_type() for m in msgs}
        assert {"HEARTBEAT", "LOCAL_POSITION_NED", "RC_CHANNELS_OVERRIDE"} <= kinds, (run, kinds)
        stamps = [m._timestamp for m in msgs]
        spans.append((min(stamps), max(stamps)))
    assert spans[0][1] < spans[1][0], spans
