"""Hostile telemetry must never move the rover (see README.md, safety, and docs/architecture.md).

The daemon's real code drives the simulator over UDP on the simulated clock; the simulator is
made to send NaN / ±inf / absurd pose values or a backwards ``time_boot_ms``
(``helixd.sim.faults``). Everything is asserted from the simulator's side (what the autopilot
saw), exactly in simulated seconds, with ``t_bad`` = the time the fault was injected
(mid-mission; the first bad frame follows within a pose period, 0.02 s) or the first snapshot
showing the vehicle armed (from arming):

1. no scroll output away from neutral (±10 µs) later than ``t_bad`` + one pose period + one
   control step (the flight loop's tick without poses, 0.05 s) — from arming, none at all;
2. HOLD, every override released and scrolls neutral within pose_stale_s (0.5 s: how long a
   pose may be invalid before the ``pose_invalid`` watchdog falls back) + 0.5 s (fall-back
   deadline) of ``t_bad``;
3. exit code 4, a ``fallback`` event with ``cause=pose_invalid``, the summary's fault naming it;
4. the rover did not turn (before the fix: −416° at the full yaw rate).
"""

from __future__ import annotations

import json
import signal
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.sim.snapshot import SimSnapshot
from tests.support import harness
from tests.support.harness import Trace
from tests.support.simulated import Steer, moving, simulated_flight

pytestmark = pytest.mark.integration

STALE_S = 0.5  # safety.pose_stale_s (default): invalid this long → pose_invalid fall-back
FIRST_STEP_S = 0.05  # flight loop tick without poses: min(0.05, pose_stale_s / 4)
# the first bad frame follows the injection by up to one pose period (link.pose_rate_hz 50)
POSE_PERIOD_S = 0.02
# From arming, the pose is judged once the autopilot's HEARTBEAT (1 Hz) confirms the arm:
# measured 0.215 s after the arm on the simulated clock; the wall-clock suite's slack (0.25 s)
# had been covering it. Not a driven step: nothing is commanded before the confirmation.
ARM_CONFIRM_S = 0.25
FALLBACK_S = 0.5  # stopped, released and HOLD within 0.5 s of detection
MAX_TURN_DEG = 10.0  # rotation allowed after the first bad frame (one control step of coasting)


def summary(run_dir: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((run_dir / "summary.json").read_text())
    return data


def check(
    trace: Trace, t_bad: float, drive_allowance_s: float, what: str, confirm_s: float = 0.0
) -> None:
    driven = trace.driven_after(t_bad + drive_allowance_s)
    late = trace.driven_after(t_bad)
    last_driven = max((t for t, _ in late), default=t_bad) - t_bad
    secured_s = trace.first(harness.secured, t_bad) - t_bad
    turned = trace.yaw_change_deg(t_bad)
    print(
        f"{what}: last non-neutral output {last_driven:.3f} s after the first bad frame, "
        f"secured after {secured_s:.3f} s, turned {turned:.1f} deg"
    )
    assert not driven, f"scrolls driven after the first control step: {driven[:5]}"
    assert secured_s <= confirm_s + STALE_S + FALLBACK_S
    assert turned <= MAX_TURN_DEG


def check_outcome(code: int, log: str, run_dir: Path) -> None:
    assert code == ExitCode.FAULT, log[-3000:]
    assert "event=fallback" in log and "cause=pose_invalid" in log, log[-3000:]
    s = summary(run_dir)
    assert s["completed"] is False
    assert s["fault"].startswith("pose_invalid")


def mid_mission(tmp_path: Path, fault: str, **kwargs: Any) -> tuple[Trace, float, str]:
    async def bad(st: Steer) -> float:
        await st.until(moving, 40.0)
        t_bad = st.now_s()
        st.inject(fault, duration_s=3.0, **kwargs)
        await st.until(harness.secured, STALE_S + FALLBACK_S + 10.0)
        return t_bad

    flown = simulated_flight(tmp_path, "square", during=bad)
    check_outcome(flown.code, flown.log, flown.run_dir())
    return flown.trace, flown.steered, flown.log


def test_nan_position_mid_mission(tmp_path: Path) -> None:
    trace, t_bad, log = mid_mission(tmp_path, "nan_position")
    check(trace, t_bad, POSE_PERIOD_S + FIRST_STEP_S, "nan_position")
    assert "LOCAL_POSITION_NED position x (north) is nan" in log
    assert log.count("event=pose_telemetry_rejected") == 1  # once per burst, not per frame


def test_nan_yaw_mid_mission(tmp_path: Path) -> None:
    trace, t_bad, log = mid_mission(tmp_path, "nan_yaw")
    check(trace, t_bad, POSE_PERIOD_S + FIRST_STEP_S, "nan_yaw")
    assert "ATTITUDE yaw is nan" in log


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_inf_yaw_mid_mission(tmp_path: Path, sign: float) -> None:
    # was: ValueError "math domain error" in control/angles.py → exit 1
    trace, t_bad, log = mid_mission(tmp_path, "inf_yaw", sign=sign)
    check(trace, t_bad, POSE_PERIOD_S + FIRST_STEP_S, f"inf_yaw sign {sign:+.0f}")
    assert "ATTITUDE yaw is " + ("inf" if sign > 0 else "-inf") in log
    assert "math domain error" not in log


def test_absurd_position_mid_mission(tmp_path: Path) -> None:
    trace, t_bad, log = mid_mission(tmp_path, "absurd_position", distance_m=1e9)
    check(trace, t_bad, POSE_PERIOD_S + FIRST_STEP_S, "absurd_position")
    assert "beyond" in log


def test_time_backwards_mid_mission(tmp_path: Path) -> None:
    # A 0.9 s backstep is below the 1 s reboot threshold: every pose is out of order until
    # the clock catches up 0.9 s later, longer than the stale limit: the pose_invalid
    # watchdog must fire.
    trace, t_bad, log = mid_mission(tmp_path, "time_backwards", step_s=0.9)
    check(trace, t_bad, POSE_PERIOD_S + FIRST_STEP_S, "time_backwards")
    assert "older than the last" in log
    assert "autopilot_rebooted" not in log


def test_nan_position_from_arming(tmp_path: Path) -> None:
    """NaN poses from the moment of arming: no start pose may be taken from them, nothing
    may be driven at all; the daemon falls back as soon as the pose has been invalid for the
    stale limit."""

    async def from_arming(st: Steer) -> None:
        # no duration: a fault's duration runs from its injection, not from arming
        st.inject("nan_position", armed_only=True)
        await st.until(lambda s: s.armed, 60.0)
        held = await st.until(harness.secured, 60.0)  # the sim boots into MANUAL
        assert "nan_position" in held.faults_active

    flown = simulated_flight(tmp_path, "square", during=from_arming)
    trace, code, log, run_dir = flown.trace, flown.code, flown.log, flown.run_dir()
    t_armed = trace.first(lambda s: s.armed)
    check(trace, t_armed, 0.0, "nan_position from arming", confirm_s=ARM_CONFIRM_S)
    check_outcome(code, log, run_dir)
    assert "no valid start pose" in log
    assert "phase=fly" not in log  # the mission never started


def test_short_glitch_is_ridden_out_in_neutral(tmp_path: Path) -> None:
    """Invalid pose telemetry for less than the stale limit is not a fault: the scrolls go
    neutral within one control step, and the mission goes on once valid poses return."""

    async def glitch(st: Steer) -> tuple[float, SimSnapshot]:
        await st.until(moving, 40.0)
        t_bad = st.now_s()
        st.inject("nan_yaw", duration_s=0.15)
        await st.until(harness.scrolls_neutral, 2.0)
        neutral_s = st.now_s() - t_bad
        await st.until(lambda s: "nan_yaw" not in s.faults_active, 5.0)
        resumed = await st.until(lambda s: not harness.scrolls_neutral(s) and s.armed, 5.0)
        st.signal(signal.SIGINT)
        return neutral_s, resumed

    flown = simulated_flight(tmp_path, "square", during=glitch)
    (neutral_s, resumed), code, log = flown.steered, flown.code, flown.log
    print(f"nan_yaw glitch: neutral {neutral_s:.3f} s after injection, then resumed")
    assert neutral_s <= POSE_PERIOD_S + FIRST_STEP_S
    assert resumed.mode == "MANUAL"
    assert code == ExitCode.OPERATOR_STOP, log[-3000:]
    assert "cause=pose_invalid" not in log
    assert "event=pose_telemetry_rejected" in log and "event=pose_telemetry_valid_again" in log


def test_invalid_pose_at_preflight_refuses_to_start(tmp_path: Path) -> None:
    """Pose telemetry rejected before arming: no start pose, preflight refuses (exit 3),
    nothing is armed or driven."""

    async def bad_from_the_start(st: Steer) -> None:
        st.inject("nan_yaw")

    flown = simulated_flight(tmp_path, "square", during=bad_from_the_start)
    code, log, snap = flown.code, flown.log, flown.snapshot
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    assert "pose telemetry rejected" in log and "ATTITUDE yaw is nan" in log
    assert not snap.armed and harness.scrolls_neutral(snap)
    assert "phase=arm" not in log
