"""A plan uploaded the moment ``helixd serve`` has read the autopilot's (empty) mission, before
the autopilot's first MISSION_CURRENT: the count that message carries is the first the service
sees, so it cannot tell a change from it; the service reads the mission once more and is
ready with the uploaded plan. On the simulated clock the upload lands in that window every
time (on the wall clock a test hit it only under load). Then, as a crew's day goes on: a
same-size re-upload is flown, a plan that fails the checks is refused with the rover in HOLD,
and the next Start Mission after a good upload starts."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from helixd.sim.sim_config import SimConfig
from tests.support.loop_gcs import booted, said, simulated_crew, start_mission, upload
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

CONFIG: dict[str, Any] = {
    "startup": {"start_switch_channel": None},
    "link": {"own_id_watch_s": 0.5},
    "serve": {"mission_poll_s": 3600.0},  # no periodic read: only the signs of an upload
}
PLAN_A = [(10.0, 0.0), (10.0, -8.0), (0.0, -8.0)]
PLAN_B = [(n, e + 3.0) for n, e in PLAN_A]  # the same plan moved 3 m east
PLAN_FAR = [(10.0, 0.0), (10.0, -8.0), (600.0, 0.0)]  # past mission.max_range_m (500 m)
# the autopilot streams nothing but HEARTBEAT while it boots; then MISSION_CURRENT at 5 Hz and
# one read of the mission
READY_MAX_S = SimConfig().boot_duration_s + 1.0


def test_an_upload_before_the_first_mission_current_is_read(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> float:
        await st.line("no mission on the autopilot", 60.0)
        assert st.snapshot().booting  # the autopilot has sent no MISSION_CURRENT yet
        await upload(gcs, PLAN_A)
        uploaded_s = st.now_s()
        await st.line("event=serve_state state=ready", 30.0)
        ready_s = st.now_s() - uploaded_s

        await upload(gcs, PLAN_B)  # the same count: nothing tells the service
        await booted(st, gcs)
        mark = st.mark()
        await start_mission(gcs)
        flying = await st.line("event=serve_state state=flying", 10.0, after=mark)
        assert 'detail="the new plan ' in flying, flying
        await st.until(moving, 20.0)
        await st.line("event=serve_state state=completed", 120.0, after=mark)

        await upload(gcs, PLAN_FAR)
        mark = st.mark()
        await start_mission(gcs)
        await st.line("event=serve_start_refused", 15.0, after=mark)
        await st.until(lambda s: s.mode == "HOLD" and not any(s.overrides_active), 10.0)
        await said(gcs, "max_range_m", 10.0)

        await upload(gcs, PLAN_A)  # fixed: the next Start Mission starts
        mark = st.mark()
        await start_mission(gcs)
        await st.line("event=serve_state state=flying", 10.0, after=mark)
        await st.until(moving, 20.0)
        return ready_s

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    (ready_s,) = served.steered
    print(f"\nupload before the first MISSION_CURRENT → ready: {ready_s:.2f} s")
    assert ready_s <= READY_MAX_S, ready_s
