"""Every fault mid-mission ends with scrolls neutral, overrides released and HOLD — as the
autopilot (simulator) sees it — within 0.5 s of detection, and the documented exit code.
``kill -9`` of the daemon, which can do nothing itself, is caught by helixd-guard on the
autopilot: scrolls at trim and HOLD within its timeout, for both backends."""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.sim.server import SimServer
from helixd.sim.snapshot import HistoryEntry, SimSnapshot
from tests.support.harness import (
    NEUTRAL_US,
    overrides_released,
    record_until,
    scrolls_neutral,
    secured,
    sim_and_daemon,
    wait_moving,
)
from tests.support.simulated import Steer, moving, simulated_flight

pytestmark = pytest.mark.integration


FALLBACK_S = 0.5  # stopped, released and HOLD within 0.5 s of detection
HEARTBEAT_PERIOD_S = 1.0  # ArduPilot's HEARTBEAT: the autopilot's mode is read from it
# A loaded 2-core CI box adds scheduling latency to both processes; measured values are
# printed, the bound asserted is the requirement plus this allowance (0.5 s: a 2x slower,
# busy machine; the exact bounds are asserted on the autopilot's clock in the same test)
SCHEDULING_SLACK_S = 0.5


def summary(run_dir: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((run_dir / "summary.json").read_text())
    return data


def check_fallback(
    tmp_path: Path,
    inject: str,
    detection_s: float,
    exit_code: ExitCode,
    cause: str,
    config: dict[str, Any] | None = None,
    **kwargs: Any,
) -> float:
    """Fly the square on the simulated clock, ``inject`` once it moves: secured within the
    detection budget and the fall-back bound, counted exactly in simulated seconds."""

    async def fault(st: Steer) -> float:
        await st.until(moving, 40.0)
        t0 = st.now_s()
        if inject.startswith("signal:"):
            st.signal(signal.Signals[inject.split(":", 1)[1]])
        elif inject.startswith("rc:"):
            channel, pwm = (int(v) for v in inject.split(":")[1:])
            st.set_rc(channel, pwm)
        else:
            st.inject(inject, **kwargs)
        await st.until(secured, detection_s + 10.0)
        return st.now_s() - t0

    flown = simulated_flight(tmp_path, "square", config, during=fault)
    elapsed, log = flown.steered, flown.log
    print(f"{inject}: secured {elapsed:.3f} s after injection (detection budget {detection_s} s)")
    assert flown.code == exit_code, log[-3000:]
    assert elapsed <= detection_s + FALLBACK_S
    assert "event=fallback" in log and f"cause={cause}" in log
    s = summary(flown.run_dir())
    assert s["completed"] is False
    assert s["fault"].startswith(cause)
    # the outcome names its cause as a FaultCause: a reader parses no text
    assert flown.outcome.cause is not None and flown.outcome.cause.value == cause
    return float(elapsed)


def test_sigint_mid_mission(tmp_path: Path) -> None:
    check_fallback(tmp_path, "signal:SIGINT", 0.1, ExitCode.OPERATOR_STOP, "signal")


def test_ctrl_c_is_an_operator_stop_and_disarms_what_it_armed(tmp_path: Path) -> None:
    """Regression: after Ctrl-C the log said `phase=fly ok=true` and the rover was left armed
    in HOLD. The fly phase ends not ok (cause signal), the run is an operator stop (exit 5,
    not completed), and the autopilot — not the daemon's word — shows HOLD and disarmed."""

    async def ctrl_c(st: Steer) -> SimSnapshot:
        await st.until(moving, 40.0)
        st.signal(signal.SIGINT)
        return await st.until(lambda s: secured(s) and not s.armed, 10.0)

    flown = simulated_flight(tmp_path, "square", during=ctrl_c)
    code, after, log, run_dir = flown.code, flown.steered, flown.log, flown.run_dir()
    assert code == ExitCode.OPERATOR_STOP, log[-3000:]
    assert after.mode == "HOLD" and not after.armed
    assert "event=phase_end phase=fly ok=false cause=signal" in log
    assert "event=phase_end phase=fly ok=true" not in log
    assert "disarmed=true" in log
    s = summary(run_dir)
    assert s["completed"] is False and s["exit_code"] == ExitCode.OPERATOR_STOP
    assert s["fault"].startswith("signal")


def test_sigterm_mid_mission(tmp_path: Path) -> None:
    check_fallback(tmp_path, "signal:SIGTERM", 0.1, ExitCode.OPERATOR_STOP, "signal")


def test_pilot_takeover_by_mode_switch(tmp_path: Path) -> None:
    # The pilot flips the mode switch to HOLD. HOLD alone does not stop a passthrough output
    # with an override active: helixd must notice, stop its scrolls and release. The mode
    # shows in the autopilot's HEARTBEAT, 1 Hz: detection is up to one period plus a control
    # tick (the wall clock's 0.2 s + slack held only where the flip fell just before a
    # HEARTBEAT; on the simulated clock the phase is exact: 1.17 s measured)
    check_fallback(
        tmp_path,
        "pilot_takeover",
        HEARTBEAT_PERIOD_S + 0.2,
        ExitCode.OPERATOR_STOP,
        "pilot_takeover",
    )


def test_pilot_takeover_by_rc_switch(tmp_path: Path) -> None:
    cfg = {"safety": {"takeover": {"switch_channel": 7, "switch_threshold_us": 1700}}}
    check_fallback(tmp_path, "rc:7:1900", 0.2, ExitCode.OPERATOR_STOP, "pilot_takeover", cfg)


def test_pilot_takeover_by_stick_deflection(tmp_path: Path) -> None:
    # Sticks on channels helixd does not override (5, 6) are visible in RC_CHANNELS.
    cfg = {"safety": {"takeover": {"stick_channels": [5, 6], "stick_deflection_us": 150}}}
    check_fallback(tmp_path, "rc:6:1750", 0.2, ExitCode.OPERATOR_STOP, "pilot_takeover", cfg)


def test_autopilot_link_lost(tmp_path: Path) -> None:
    # Both directions drop for 3 s: the daemon detects it as a stale pose (0.5 s) before the
    # HEARTBEAT timeout (2 s); its neutral/release cannot get through, so the autopilot's
    # RC_OVERRIDE_TIME (3 s) hands the outputs back to the pilot; the HOLD request, re-sent
    # until acknowledged, lands when the link returns.
    override_time_s = 3.0

    async def cut(st: Steer) -> tuple[float, float]:
        await st.until(moving, 40.0)
        t0 = st.now_s()
        st.inject("link_drop", duration_s=3.0)
        await st.until(lambda s: overrides_released(s) and scrolls_neutral(s), 5.0)
        released = st.now_s() - t0
        await st.until(secured, 10.0)
        return released, st.now_s() - t0

    flown = simulated_flight(tmp_path, "square", during=cut)
    (released, held), code, log = flown.steered, flown.code, flown.log
    print(f"link_drop: outputs back to the pilot after {released:.3f} s, HOLD after {held:.3f} s")
    assert released <= override_time_s + FALLBACK_S
    assert held <= 3.0 + FALLBACK_S  # as soon as the link is back
    assert code == ExitCode.FAULT
    # every message stopped: the link is named, once, not the pose or the GPS it starved,
    # and the HOLD requests it could not carry are one summary, not a warning each
    assert "phase=fly ok=false cause=link_lost" in log, log
    assert "cause=pose_stale" not in log and "cause=gps_lost" not in log
    assert "event=command_timeout" not in log
    fallback = [ln for ln in log.splitlines() if "event=fallback" in ln]
    assert len(fallback) == 1 and fallback[0].count("HOLD request") <= 1, fallback


def test_pose_stale(tmp_path: Path) -> None:
    check_fallback(tmp_path, "stale_pose", 0.5, ExitCode.FAULT, "pose_stale", duration_s=30.0)


def test_ekf_unhealthy(tmp_path: Path) -> None:
    check_fallback(tmp_path, "ekf_unhealthy", 0.3, ExitCode.FAULT, "ekf_unhealthy", duration_s=30.0)


def test_geofence(tmp_path: Path) -> None:
    # check and preflight refuse a mission that leaves the fence, so the fence is crossed by a
    # GPS jump: the square's far corner is 14.1 m from the start, the fence 15 m, the jump 30 m.
    # A jump the EKF took without raising its variance: else the EKF watchdog, checked before
    # the fence, names it whenever its report and the jumped pose are read in one tick.
    check_fallback(
        tmp_path,
        "gps_jump",
        0.1,
        ExitCode.FAULT,
        "geofence",
        {"safety": {"geofence_radius_m": 15.0}},
        distance_m=30.0,
        bearing_deg=180.0,
        variance=0.0,
    )


def test_mission_time_limit(tmp_path: Path) -> None:
    # The square's estimate is 83.4 s (check refuses a smaller limit). The scrolls dig in (the
    # stall watchdog is set out of the way), so the limit, on the autopilot clock, fires first.
    cfg = {"safety": {"mission_time_limit_s": 84.0, "stall": {"duration_s": 120.0}}}

    async def dig_in(st: Steer) -> None:
        await st.until(moving, 40.0)
        st.inject("stall", duration_s=600.0)
        await st.until(secured, 84.0 + 10.0)

    flown = simulated_flight(tmp_path, "square", cfg, during=dig_in)
    code, log = flown.code, flown.log
    assert code == ExitCode.FAULT and "cause=mission_time" in log, log[-3000:]


def test_stall_dig_in(tmp_path: Path) -> None:
    cfg = {"safety": {"stall": {"duration_s": 1.0}}}
    check_fallback(tmp_path, "stall", 1.0 + 0.3, ExitCode.FAULT, "stall", cfg, duration_s=60.0)


def test_rc_signal_loss(tmp_path: Path) -> None:
    # The receiver sends its failsafe frame, throttle below FS_THR_VALUE on ArduPilot's throttle
    # channel (RCMAP_THROTTLE 5 in the Helix setup), which helixd does not override: Rover's
    # radio failsafe starts at once, SYS_STATUS says the receiver is unhealthy, helixd stops
    # (before ArduPilot's own FS_TIMEOUT of 1.5 s).
    check_fallback(
        tmp_path, "rc_loss", 0.3, ExitCode.FAULT, "rc_lost", duration_s=60.0, kind="failsafe_values"
    )


def test_rc_signal_loss_with_stop_on_rc_loss_off_drives_on_and_says_so(tmp_path: Path) -> None:
    """``safety.stop_on_rc_loss: false`` and ArduPilot's failsafe action none (FS_ACTION 0):
    the mission goes on without a safety pilot and the ground station is told once."""
    cfg = {"safety": {"stop_on_rc_loss": False}}

    async def radio_lost(st: Steer) -> None:
        await st.until(moving, 40.0)
        st.inject("rc_loss", kind="failsafe_values")

    flown = simulated_flight(tmp_path, "square", cfg, radio_lost, params={"FS_ACTION": 0})
    code, log, run_dir = flown.code, flown.log, flown.run_dir()
    assert code == ExitCode.OK, log[-3000:]
    assert log.count("event=rc_lost_driving_on") == 1, log[-3000:]
    assert summary(run_dir)["completed"] is True


def test_autopilot_reboot(tmp_path: Path) -> None:

    async def reboot(st: Steer) -> None:
        await st.until(moving, 40.0)
        st.inject("reboot")

    flown = simulated_flight(tmp_path, "square", during=reboot)
    code, log, snap = flown.code, flown.log, flown.snapshot
    # After a reboot nothing of ours may be left: no override, no arming.
    assert code == ExitCode.FAULT, log[-3000:]
    assert not snap.armed
    assert overrides_released(snap)
    assert "event=fallback" in log


# --- kill -9 and helixd-guard -------------------------------------------------------------------

GUARD_TIMEOUT_S = 0.5  # HXG_TIMEOUT's default
GUARD_PERIOD_S = 0.05  # the script runs every 50 ms …
LOOP_S = 0.02  # … here in the first 50 Hz main loop after that; RC: the override shows one later
SERVO_OUTPUTS = {f"SERVO{n}_FUNCTION": 0 for n in range(1, 5)}


def last_change(server: SimServer, channels: range, after_sim_s: float) -> HistoryEntry | None:
    """The last ``output`` event of ``channels`` after ``after_sim_s`` (simulated time)."""
    changes = [
        e
        for e in server.history.entries("output")
        if e.sim_time_s > after_sim_s and int(str(e.details["channel"])) in channels
    ]
    return changes[-1] if changes else None


@pytest.mark.parametrize("backend", ["rc_override", "servo"])
def test_kill9_helixd_guard_stops_the_scrolls_and_holds(tmp_path: Path, backend: str) -> None:
    """At speed-up 1 with the defaults (5 Hz HEARTBEAT, HXG_TIMEOUT 0.5 s): while helixd
    flies the guard never acts; after kill -9 it holds outputs 1..4 at trim and asks for HOLD
    within its timeout of helixd's last message, and keeps them there past RC_OVERRIDE_TIME."""
    cfg = {"actuation": {"backend": backend}}
    sim: dict[str, Any] = {"speedup": 1.0, "guard_installed": True}
    if backend == "servo":
        sim["params"] = SERVO_OUTPUTS
    with sim_and_daemon(tmp_path, "square", cfg, **sim) as (server, d):
        wait_moving(server)
        flying = server.snapshot()
        assert flying.guard_version == 1 and not flying.guard_guarding
        assert not scrolls_neutral(flying)
        t_kill = time.monotonic()
        d.signal(signal.SIGKILL)
        trace = record_until(server, lambda s: scrolls_neutral(s) and s.mode == "HOLD", 10.0)
        assert d.wait_exit(10.0) == -signal.SIGKILL
        trim_wall = trace.first(scrolls_neutral) - t_kill
        hold_wall = trace.first(lambda s: s.mode == "HOLD") - t_kill
        secured_snap = trace.samples[-1][1]
        last_seen = secured_snap.gcs_last_seen_s  # helixd's last HEARTBEAT/override
        assert last_seen is not None
        later = server.wait_for(lambda s: s.sim_time_s > last_seen + 4.0, 10.0)
        log = d.log_text()
        engaged = server.history.first("guard")
        hold = server.history.first("mode", lambda e: e.details["mode"] == "HOLD")
        trim = last_change(server, range(1, 5), last_seen)
        texts = [str(e.details["text"]) for e in server.history.entries("statustext")]
    # preflight did not warn: the guard runs and guards 1..4
    assert not [ln for ln in log.splitlines() if "preflight_warning" in ln and "guard" in ln]
    assert engaged is not None and hold is not None and trim is not None
    engaged_s = engaged.sim_time_s - last_seen
    trim_s = trim.sim_time_s - last_seen
    hold_s = hold.sim_time_s - last_seen
    print(
        f"kill -9 ({backend}, helixd-guard): outputs 1-4 at trim {trim_wall:.3f} s, HOLD "
        f"{hold_wall:.3f} s (wall) after the kill; {trim_s:.3f} s / {hold_s:.3f} s (autopilot) "
        f"after helixd's last message (guard engaged at {engaged_s:.3f} s)"
    )
    assert engaged.details["guarding"] is True and engaged.wall_monotonic_s >= t_kill
    assert GUARD_TIMEOUT_S < engaged_s <= GUARD_TIMEOUT_S + GUARD_PERIOD_S + LOOP_S + 1e-6
    assert trim_s <= GUARD_TIMEOUT_S + GUARD_PERIOD_S + 2 * LOOP_S + 1e-6
    assert hold_s == pytest.approx(engaged_s) and hold.details["reason"] == "helixd_guard"
    assert trim_wall <= GUARD_TIMEOUT_S + GUARD_PERIOD_S + SCHEDULING_SLACK_S
    assert "helixd-guard: no heartbeat 500 ms, trim + HOLD" in texts
    # held while the silence lasts: past RC_OVERRIDE_TIME (3 s) and still HOLD
    assert later.scroll_pwm_us == (NEUTRAL_US,) * 4 and later.mode == "HOLD"
    assert later.armed and later.guard_guarding


def gps_fault_flight(tmp_path: Path, fault: str) -> str:
    """Fly the square, inject the simulator's ``fault`` mid-leg: the scrolls neutral within
    1 s of it (simulated time, the daemon's and the vehicle's alike), exit 4 by the GPS
    watchdog; the summary's fault."""

    async def gps_fault(st: Steer) -> tuple[float, float]:
        at_s = (await st.until(moving, 40.0)).sim_time_s + 0.5
        st.schedule(fault, at_s, duration_s=600.0)
        neutral = await st.until(lambda s: s.sim_time_s > at_s and scrolls_neutral(s), 10.0)
        held = await st.until(secured, 10.0)
        return neutral.sim_time_s - at_s, held.sim_time_s - at_s

    flown = simulated_flight(tmp_path, "square", during=gps_fault)
    (to_neutral, to_hold), log = flown.steered, flown.log
    print(f"{fault}: scrolls neutral {to_neutral:.2f} s, HOLD {to_hold:.2f} s (vehicle time)")
    assert to_neutral <= 1.0, log[-3000:]
    assert flown.code == ExitCode.FAULT, log[-3000:]
    assert "event=fallback cause=gps_lost" in log
    result: str = summary(flown.run_dir())["fault"]
    return result


def test_gps_lost(tmp_path: Path) -> None:
    # The receiver stops mid-leg: GPS_RAW_INT says no fix 0.4 s later while the EKF goes on
    # dead-reckoning for 7.3 s (as ArduPilot SITL does); the GPS watchdog, not the EKF, stops
    # the scrolls within 1 s of the loss, counted on the one simulated clock.
    result = gps_fault_flight(tmp_path, "gps_loss")
    assert result.startswith("gps_lost"), result


@pytest.mark.parametrize(
    ("fault", "detail"),
    [
        # GPS_RAW_INT itself stops (ArduPilot: GPS1_TYPE 0, or its stream turned off) while
        # the pose streams and the EKF go on
        ("gps_silent", "GPS_RAW_INT stopped"),
        # the receiver stops sending (a cut cable): ArduPilot repeats the last 3D fix, its
        # time frozen, for 4 s before it says "no GPS"; the fix time not moving is the loss
        ("gps_receiver_silent", "the GPS receiver stopped"),
    ],
)
def test_gps_stream_stopping_stops_the_scrolls_within_1_s(
    tmp_path: Path, fault: str, detail: str
) -> None:
    # The silence is counted on helixd's own clock (safety.gps_stale_s, 0.6 s), the simulated
    # clock the simulator shares.
    result = gps_fault_flight(tmp_path, fault)
    assert result.startswith("gps_lost") and detail in result, result
