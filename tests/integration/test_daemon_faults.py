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
from helixd.sim.snapshot import HistoryEntry
from tests.support.harness import (
    NEUTRAL_US,
    SPEEDUP,
    overrides_released,
    record_until,
    scrolls_neutral,
    secured,
    sim_and_daemon,
    time_until,
    wait_moving,
)

pytestmark = pytest.mark.integration

FALLBACK_S = 0.5  # stopped, released and HOLD within 0.5 s of detection
# A loaded 2-core CI box adds scheduling latency to both processes; measured values are
# printed, the bound asserted is the requirement plus this allowance.
SCHEDULING_SLACK_S = 0.25


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
    with sim_and_daemon(tmp_path, "square", config) as (server, d):
        wait_moving(server)
        t0 = time.monotonic()
        if inject.startswith("signal:"):
            d.signal(signal.Signals[inject.split(":", 1)[1]])
        elif inject.startswith("rc:"):
            channel, pwm = (int(v) for v in inject.split(":")[1:])
            server.set_rc(channel, pwm)
        else:
            server.inject(inject, **kwargs)
        elapsed = time_until(server, secured, t0, timeout_s=detection_s + 10.0)
        code = d.wait_exit(20.0)
        log = d.log_text()
        run_dir = d.run_dir()
    print(f"{inject}: secured {elapsed:.3f} s after injection (detection budget {detection_s} s)")
    assert code == exit_code, log[-3000:]
    assert elapsed <= detection_s + FALLBACK_S + SCHEDULING_SLACK_S
    assert "event=fallback" in log and f"cause={cause}" in log
    s = summary(run_dir)
    assert s["completed"] is False
    assert s["fault"].startswith(cause)
    return elapsed


def test_sigint_mid_mission(tmp_path: Path) -> None:
    check_fallback(tmp_path, "signal:SIGINT", 0.1, ExitCode.OPERATOR_STOP, "signal")


def test_ctrl_c_is_an_operator_stop_and_disarms_what_it_armed(tmp_path: Path) -> None:
    """Regression: after Ctrl-C the log said `phase=fly ok=true` and the rover was left armed
    in HOLD. The fly phase ends not ok (cause signal), the run is an operator stop (exit 5,
    not completed), and the autopilot — not the daemon's word — shows HOLD and disarmed."""
    with sim_and_daemon(tmp_path, "square") as (server, d):
        wait_moving(server)
        d.signal(signal.SIGINT)
        code = d.wait_exit(20.0)
        after = server.wait_for(lambda s: secured(s) and not s.armed, 10.0)
        log = d.log_text()
        run_dir = d.run_dir()
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
    # with an override active: helixd must notice, stop its scrolls and release.
    check_fallback(tmp_path, "pilot_takeover", 0.2, ExitCode.OPERATOR_STOP, "pilot_takeover")


def test_pilot_takeover_by_rc_switch(tmp_path: Path) -> None:
    cfg = {"safety": {"takeover": {"switch_channel": 7, "switch_threshold_us": 1700}}}
    check_fallback(tmp_path, "rc:7:1900", 0.2, ExitCode.OPERATOR_STOP, "pilot_takeover", cfg)


def test_pilot_takeover_by_stick_deflection(tmp_path: Path) -> None:
    # Sticks on channels helixd does not override (5, 6) are visible in RC_CHANNELS.
    cfg = {"safety": {"takeover": {"stick_channels": [5, 6], "stick_deflection_us": 150}}}
    check_fallback(tmp_path, "rc:6:1750", 0.2, ExitCode.OPERATOR_STOP, "pilot_takeover", cfg)


def test_autopilot_link_lost(tmp_path: Path) -> None:
    # Both directions drop for 3 s (wall): the daemon detects it as a stale pose (0.5 s)
    # before the HEARTBEAT timeout (2 s); its neutral/release cannot get through, so the
    # autopilot's RC_OVERRIDE_TIME hands the outputs back to the pilot; the HOLD request,
    # re-sent until acknowledged, lands when the link returns.
    with sim_and_daemon(tmp_path, "square") as (server, d):
        wait_moving(server)
        t0 = time.monotonic()
        server.inject("link_drop", duration_s=3.0 * SPEEDUP)
        override_time_s = 3.0 / SPEEDUP  # RC_OVERRIDE_TIME in wall seconds
        released = time_until(
            server, lambda s: overrides_released(s) and scrolls_neutral(s), t0, 5.0
        )
        held = time_until(server, secured, t0, 10.0)
        code = d.wait_exit(20.0)
        log = d.log_text()
    print(f"link_drop: outputs back to the pilot after {released:.3f} s, HOLD after {held:.3f} s")
    assert released <= override_time_s + FALLBACK_S + SCHEDULING_SLACK_S
    assert held <= 3.0 + FALLBACK_S + SCHEDULING_SLACK_S  # as soon as the link is back
    assert code == ExitCode.FAULT
    # every message stopped: the link is named, once, not the pose or the GPS it starved,
    # and the HOLD requests it could not carry are one summary, not a warning each
    assert "phase=fly ok=false cause=link_lost" in log, log
    assert "cause=pose_stale" not in log and "cause=gps_lost" not in log
    assert "event=command_timeout" not in log
    fallback = [ln for ln in log.splitlines() if "event=fallback" in ln]
    assert len(fallback) == 1 and fallback[0].count("HOLD request") <= 1, fallback


def test_pose_stale(tmp_path: Path) -> None:
    check_fallback(
        tmp_path, "stale_pose", 0.5, ExitCode.FAULT, "pose_stale", duration_s=30.0 * SPEEDUP
    )


def test_ekf_unhealthy(tmp_path: Path) -> None:
    check_fallback(
        tmp_path, "ekf_unhealthy", 0.3, ExitCode.FAULT, "ekf_unhealthy", duration_s=30.0 * SPEEDUP
    )


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
    with sim_and_daemon(tmp_path, "square", cfg) as (server, d):
        wait_moving(server)
        server.inject("stall", duration_s=600.0)
        server.wait_for(secured, 84.0 / SPEEDUP + 10.0)
        code = d.wait_exit(20.0)
        log = d.log_text()
    assert code == ExitCode.FAULT and "cause=mission_time" in log, log[-3000:]


def test_stall_dig_in(tmp_path: Path) -> None:
    cfg = {"safety": {"stall": {"duration_s": 1.0}}}
    check_fallback(
        tmp_path, "stall", 1.0 + 0.3, ExitCode.FAULT, "stall", cfg, duration_s=60.0 * SPEEDUP
    )


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
    with sim_and_daemon(tmp_path, "square", cfg, params={"FS_ACTION": 0}) as (server, d):
        wait_moving(server)
        server.inject("rc_loss", kind="failsafe_values")
        code = d.wait_exit(60.0)
        log = d.log_text()
        run_dir = d.run_dir()
    assert code == ExitCode.OK, log[-3000:]
    assert log.count("event=rc_lost_driving_on") == 1, log[-3000:]
    assert summary(run_dir)["completed"] is True


def test_autopilot_reboot(tmp_path: Path) -> None:
    with sim_and_daemon(tmp_path, "square") as (server, d):
        wait_moving(server)
        server.inject("reboot")
        code = d.wait_exit(30.0)
        log = d.log_text()
        snap = server.snapshot()
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


def gps_fault_flight(tmp_path: Path, fault: str, speedup: float) -> str:
    """Fly the square, inject the simulator's ``fault`` mid-leg: the scrolls neutral within
    1 s of it (vehicle time), exit 4 by the GPS watchdog; the summary's fault."""
    with sim_and_daemon(tmp_path, "square", speedup=speedup) as (server, d):
        at_s = wait_moving(server).sim_time_s + 0.5
        server.schedule(fault, at_s, duration_s=600.0)
        neutral = server.wait_for(lambda s: s.sim_time_s > at_s and scrolls_neutral(s), 10.0)
        held = server.wait_for(secured, 10.0)
        code = d.wait_exit(20.0)
        log = d.log_text()
        run_dir = d.run_dir()
    to_neutral, to_hold = neutral.sim_time_s - at_s, held.sim_time_s - at_s
    print(f"{fault}: scrolls neutral {to_neutral:.2f} s, HOLD {to_hold:.2f} s (vehicle time)")
    assert to_neutral <= 1.0, log[-3000:]
    assert code == ExitCode.FAULT, log[-3000:]
    assert "event=fallback cause=gps_lost" in log
    result: str = summary(run_dir)["fault"]
    return result


def test_gps_lost(tmp_path: Path) -> None:
    # The receiver stops mid-leg: GPS_RAW_INT says no fix 0.4 s later while the EKF goes on
    # dead-reckoning for 7.3 s (as ArduPilot SITL does); the GPS watchdog, not the EKF, stops
    # the scrolls within 1 s of the loss, counted on the simulator's (the vehicle's) clock, so
    # the simulator runs at only 2× (the daemon's wall-clock latencies count double).
    result = gps_fault_flight(tmp_path, "gps_loss", 2.0)
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
    # The silence is counted on helixd's own clock (safety.gps_stale_s, 0.6 s), so the
    # simulator runs in real time: its clock is then the wall clock the rover would live on.
    result = gps_fault_flight(tmp_path, fault, 1.0)
    assert result.startswith("gps_lost") and detail in result, result
