"""``hx_state`` through a pause of a flight in the autopilot's AUTO: the
crew's HOLD pauses the flight (it goes on, held at neutral), and the service's state word
says so — NAMED_VALUE_INT ``hx_state`` 5 (paused) at once, 4 (flying) again when AUTO
continues it — as the README's list of states promises. On the simulated clock."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from helixd.serve.core import ServeState
from helixd.serve.status import HX_STATE_NAME
from tests.support.harness import guard_installed, scrolls_neutral
from tests.support.loop_gcs import CREW_CONFIG, set_mode, simulated_crew, upload, upload_and_start
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

MISSION = [(15.0, 0.0), (15.0, -8.0)]  # north/east from the EKF origin (m)
TOLD_WITHIN_S = 0.5  # hx_state is sent on the change, not at the next period (0.5 s here)


def _hx_state(m: Any) -> int | None:
    """The value of helixd's NAMED_VALUE_INT hx_state (None: another message)."""
    name = m.name if isinstance(m.name, str) else m.name.decode()
    return int(m.value) if m.get_srcSystem() == 247 and name == HX_STATE_NAME.decode() else None


def test_a_pause_in_hold_reads_hx_state_5_and_continue_4(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> tuple[float, float]:
        await upload_and_start(st, gcs, lambda: upload(gcs, MISSION))
        await gcs.expect("NAMED_VALUE_INT", 5.0, lambda m: _hx_state(m) == ServeState.FLYING)
        gcs.drain()
        t_pause = await set_mode(gcs, "HOLD")  # QGroundControl's Pause (Rover: Hold)
        await gcs.expect("NAMED_VALUE_INT", 5.0, lambda m: _hx_state(m) == ServeState.PAUSED)
        paused_s = st.now_s() - t_pause
        await st.line("event=serve_state state=paused hx_state=5", 5.0)
        await st.until(scrolls_neutral, 5.0)
        # still paused a period later: the periodic hx_state says 5, not 4
        t_late = st.now_s() + 1.0
        late = await gcs.expect(
            "NAMED_VALUE_INT", 5.0, lambda m: _hx_state(m) is not None and st.now_s() > t_late
        )
        assert _hx_state(late) == ServeState.PAUSED, late
        gcs.drain()
        t_continue = await set_mode(gcs, "AUTO")  # Continue
        await gcs.expect("NAMED_VALUE_INT", 5.0, lambda m: _hx_state(m) == ServeState.FLYING)
        flying_s = st.now_s() - t_continue
        await st.until(moving, 10.0)
        return paused_s, flying_s

    served = simulated_crew(tmp_path, CREW_CONFIG, crew, **guard_installed(1.0))
    assert served.code == 0, served.log[-3000:]
    ((paused_s, flying_s),) = served.steered
    print(f"\nHOLD → hx_state 5: {paused_s:.3f} s; AUTO → hx_state 4: {flying_s:.3f} s")
    # the mode is seen within 0.5 s (MISSION_CURRENT's mission_mode), told at once
    assert paused_s <= 2 * TOLD_WITHIN_S and flying_s <= 2 * TOLD_WITHIN_S, (paused_s, flying_s)
    assert "state=flying hx_state=4" in served.log.split("state=paused hx_state=5", 1)[1]
