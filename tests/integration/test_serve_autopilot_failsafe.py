"""ArduPilot's own failsafe during a flight the crew started in AUTO (``helixd serve``): the
mode it sets is ArduPilot's, not the crew's Pause. helixd ends the flight with the fall-back
and names the failsafe, as it does for a flight it drives in MANUAL (README, "Safety").

Found by the soak (tools/soak.py --seed 201 --days 1 --day-hours 0.1): a fence breach in a
flight of AUTO set HOLD; helixd held the scrolls as for a Pause, reported nothing, and the
crew's next AUTO would have driven on out of the fence.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.integration.test_serve_crew_modes import CONFIG, MISSION
from tests.support.harness import guard_installed, secured
from tests.support.loop_gcs import simulated_crew, upload, upload_and_start
from tests.support.loop_mav import LoopMav
from tests.support.serve import flight_summaries
from tests.support.simulated import Steer

pytestmark = pytest.mark.integration


@pytest.mark.parametrize(
    ("fault", "params", "cause"),
    [
        ("fence_breach", {"FENCE_ENABLE": 1.0, "FENCE_ACTION": 2.0}, "autopilot_fence"),
        ("battery_low", {"BATT_FS_LOW_ACT": 2.0}, "autopilot_battery"),
    ],
)
def test_a_failsafe_in_a_flight_of_auto_is_named_and_ends_it(
    tmp_path: Path, fault: str, params: dict[str, float], cause: str
) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        await upload_and_start(st, gcs, lambda: upload(gcs, MISSION))
        mark = st.mark()
        st.inject(fault)
        await st.line(f"event=fallback cause={cause}", 5.0, after=mark)
        await st.line("event=serve_state state=faulted", 5.0, after=mark)
        await st.until(secured, 5.0)

    sim: dict[str, Any] = {**guard_installed(1.0), "params": params}
    served = simulated_crew(tmp_path, CONFIG, crew, **sim)
    assert served.code == 0, served.log[-3000:]
    (summary,) = flight_summaries(tmp_path)
    assert summary["fault"].startswith(cause), summary
