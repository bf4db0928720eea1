"""ArduPilot's own failsafe setting HOLD mid-mission ends the run as a fault named after it,
not as a pilot's takeover: the daemon flies against the simulator, the simulator's failsafe
fires as ArduPilot Rover's does (its text or FENCE_STATUS, then the mode), and the exit code,
summary.json and RESULT line name the cause. The time from the injection to the scrolls at
neutral and released, on the simulator's truth, is measured and printed.

Before: both ended ``stopped pilot_takeover: mode changed to HOLD``, exit 5."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.harness import overrides_released, scrolls_neutral
from tests.support.simulated import Steer, moving, simulated_flight

pytestmark = pytest.mark.integration

# detection is one control tick after the HEARTBEAT with HOLD; then the fall-back's 0.5 s
# (exactly, on the simulated clock)
STOPPED_WITHIN_S = 0.2 + 0.5


def fly_into(tmp_path: Path, fault: str, params: dict[str, float]) -> tuple[int, str, Any, float]:

    async def failsafe(st: Steer) -> float:
        await st.until(moving, 40.0)
        t0 = st.now_s()
        st.inject(fault)
        await st.until(lambda s: scrolls_neutral(s) and overrides_released(s), 10.0)
        return st.now_s() - t0

    flown = simulated_flight(tmp_path, "square", during=failsafe, params=params)
    code, log, stopped = flown.code, flown.log, flown.steered
    summary = json.loads((flown.run_dir() / "summary.json").read_text())
    print(f"{fault}: scrolls neutral and released {stopped:.3f} s after the injection")
    return code, log, summary, stopped


def test_battery_failsafe_is_named(tmp_path: Path) -> None:
    code, log, summary, stopped = fly_into(tmp_path, "battery_low", {"BATT_FS_LOW_ACT": 2.0})
    assert code == ExitCode.FAULT, log[-3000:]
    assert summary["fault"] == (
        "autopilot_battery: ArduPilot's battery failsafe set HOLD "
        '("Battery 1 is low 10.50V used 1234 mAh")'
    )
    assert summary["exit_code"] == ExitCode.FAULT and summary["completed"] is False
    assert "helixd: RESULT fault autopilot_battery: ArduPilot's battery failsafe" in log
    assert "pilot_takeover" not in log
    assert stopped <= STOPPED_WITHIN_S


def test_fence_failsafe_is_named(tmp_path: Path) -> None:
    params = {"FENCE_ENABLE": 1.0, "FENCE_ACTION": 2.0}
    code, log, summary, stopped = fly_into(tmp_path, "fence_breach", params)
    assert code == ExitCode.FAULT, log[-3000:]
    assert summary["fault"].startswith("autopilot_fence: ArduPilot's fence failsafe set HOLD")
    assert "helixd: RESULT fault autopilot_fence:" in log
    assert "pilot_takeover" not in log
    assert stopped <= STOPPED_WITHIN_S
