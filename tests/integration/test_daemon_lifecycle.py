"""Crash path, double SIGINT, a wedged daemon, and systemd notifications — end to end."""

from __future__ import annotations

import asyncio
import signal
import socket
from pathlib import Path
from typing import Any

import pytest

import helixd.runtime.flight
from helixd.base.exitcodes import ExitCode
from helixd.config.root import HelixdConfig
from helixd.runtime.daemon import run_mission
from tests.support import harness
from tests.support.run_options import square_run
from tests.support.simulated import Steer, moving, simulated_flight

pytestmark = pytest.mark.integration


def test_unhandled_exception_falls_back_to_hold(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A bug inside the control step (here: the kinematics raising on the 100th step) must
    still end with neutral + release + HOLD, and exit code 1 (internal error)."""
    calls = {"n": 0}
    real = helixd.runtime.flight.scroll_fractions

    def exploding(*args: Any, **kwargs: Any) -> tuple[float, float, float, float]:
        calls["n"] += 1
        if calls["n"] == 100:
            raise ZeroDivisionError("injected bug in the control step")
        return real(*args, **kwargs)

    monkeypatch.setattr(helixd.runtime.flight, "scroll_fractions", exploding)
    flown = simulated_flight(tmp_path, "square")
    outcome, snap = flown.outcome, flown.snapshot
    assert calls["n"] == 100
    assert outcome.exit_code is ExitCode.INTERNAL_ERROR
    assert outcome.summary is not None
    assert outcome.summary.fault is not None and outcome.summary.fault.startswith("exception")
    assert "ZeroDivisionError" in outcome.summary.fault
    assert (
        snap.mode == "HOLD" and harness.overrides_released(snap) and harness.scrolls_neutral(snap)
    )
    # the plain result line is the outcome's last message (the CLI prints it last)
    last = outcome.messages[-1]
    assert last.startswith("helixd: RESULT internal-error exception: ZeroDivisionError")
    assert "autopilot time" in last and last.endswith("exit 1")


def test_second_sigint_forces_exit_after_fallback_sent(tmp_path: Path) -> None:
    """First SIGINT starts the fall-back; the HOLD acknowledgement never comes (the link is
    cut); a second SIGINT makes the daemon exit without waiting out hold_retry_bound_s."""
    cfg = {"safety": {"hold_retry_bound_s": 30.0}}

    async def twice(st: Steer) -> float:
        await st.until(moving, 40.0)
        st.inject("link_drop", duration_s=120.0)
        st.signal(signal.SIGINT)
        await st.line("event=rc_override_released", 5.0)
        t0 = st.now_s()
        st.signal(signal.SIGINT)
        return await st.exited(10.0) - t0

    flown = simulated_flight(tmp_path, "square", cfg, during=twice)
    code, forced_exit_s, result = flown.code, flown.steered, flown.result
    print(f"second SIGINT: exited {forced_exit_s:.2f} s later")
    assert code == ExitCode.OPERATOR_STOP
    assert result.startswith("helixd: RESULT stopped signal: SIGINT") and result.endswith("exit 5")
    assert forced_exit_s < 3.0  # far below the 30 s HOLD retry bound


def test_wedged_daemon_stops_heartbeats_and_gcs_failsafe_takes_over(tmp_path: Path) -> None:
    """SIGSTOP freezes the daemon (a wedged main loop): its HEARTBEATs stop, the autopilot's
    GCS failsafe (FS_GCS_ENABLE) switches to HOLD and the overrides expire by themselves."""
    cfg = {"link": {"heartbeat_rate_hz": 5.0}}  # FS_GCS_TIMEOUT runs on simulated time
    params = {"FS_GCS_ENABLE": 1, "FS_GCS_TIMEOUT": 5}
    with harness.sim_and_daemon(tmp_path, "square", cfg, params=params) as (server, d):
        harness.wait_moving(server)
        d.signal(signal.SIGSTOP)
        try:
            snap = server.wait_for(harness.secured, 10.0)
        finally:
            d.signal(signal.SIGCONT)
            d.signal(signal.SIGINT)
        d.wait_exit(20.0)
    # on the autopilot's (simulated) clock from helixd's last message, so a slow or loaded
    # machine cannot move it (before: wall seconds against 5 s / speed-up + 1.5 s)
    assert snap.gcs_last_seen_s is not None
    elapsed = snap.sim_time_s - snap.gcs_last_seen_s
    print(f"SIGSTOP: autopilot in HOLD with outputs released {elapsed:.2f} s (autopilot) later")
    assert snap.failsafe_gcs
    # FS_GCS_TIMEOUT (5 s), then the failsafe acts once on for FS_TIMEOUT (1.5 s), Rover's
    # way; HEARTBEATs at 5 Hz put helixd's last message at most a period after the last one
    assert 5.0 + 1.5 - 0.05 <= elapsed <= 5.0 + 1.5 + 0.2 + 0.1


def test_systemd_ready_and_watchdog_notifications(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The daemon talks sd_notify to a NOTIFY_SOCKET the test creates: READY=1 after
    preflight, WATCHDOG=1 from the control loop, STOPPING=1 at the end."""
    sock_path = tmp_path / "notify.sock"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(sock_path))
    sock.setblocking(False)
    monkeypatch.setenv("NOTIFY_SOCKET", str(sock_path))
    monkeypatch.setenv("WATCHDOG_USEC", "1000000")

    async def systemd(st: Steer) -> list[str]:
        loop = asyncio.get_running_loop()
        got: list[str] = []

        async def receive() -> None:
            got.append((await asyncio.wait_for(loop.sock_recv(sock, 4096), 60.0)).decode())

        # until the control loop pings the watchdog while flying, then stop the service
        while not any("STATUS=phase: fly" in m for m in got) or "WATCHDOG=1" not in got[-1]:
            await receive()
        st.signal(signal.SIGTERM)  # what `systemctl stop` sends (KillSignal)
        while not any("STOPPING=1" in m for m in got):
            await receive()
        return got

    try:
        flown = simulated_flight(tmp_path, "hexagon", during=systemd, terrain="mud")
    finally:
        sock.close()
    assert flown.code == ExitCode.OPERATOR_STOP, flown.log[-3000:]
    got = flown.steered
    ready = next(i for i, m in enumerate(got) if "READY=1" in m)
    watchdogs = [i for i, m in enumerate(got) if "WATCHDOG=1" in m]
    assert watchdogs and watchdogs[-1] > ready
    assert any("STATUS=phase: fly" in m for m in got)


def test_start_gate_waits_for_the_pilots_switch(tmp_path: Path) -> None:
    """Nobody types on a rover in a pond: with a start switch configured, helixd connects and
    passes preflight, then waits — nothing armed, no override — until the pilot flips it."""
    cfg = {"startup": {"start_switch_channel": 7, "start_switch_threshold_us": 1700}}

    async def gate(st: Steer) -> None:
        await st.line("event=waiting_for_start_switch", 60.0)
        waiting = st.snapshot()
        assert not waiting.armed and not any(waiting.overrides_active)
        st.set_rc(7, 1900)
        await st.line("event=start_switch_on", 10.0)
        await st.until(moving, 40.0)
        st.signal(signal.SIGINT)

    flown = simulated_flight(tmp_path, "hexagon", cfg, during=gate, terrain="mud")
    assert flown.code == ExitCode.OPERATOR_STOP, flown.log[-3000:]
    result = flown.result
    assert result.startswith("helixd: RESULT stopped signal: SIGINT received — 0/6 waypoints")
    assert "autopilot time" in result and result.endswith("exit 5")


def test_start_switch_on_the_mode_channel_is_refused(tmp_path: Path) -> None:
    cfg = {"startup": {"start_switch_channel": 8}}  # MODE_CH = 8 on the autopilot
    flown = simulated_flight(tmp_path, "hexagon", cfg)
    code, result, log = flown.code, flown.result, flown.log
    assert not flown.snapshot.armed
    assert code == ExitCode.PREFLIGHT
    assert "flight-mode channel (MODE_CH = 8)" in log
    assert result.startswith("helixd: RESULT refused preflight: startup.start_switch_channel = 8")
    assert result.endswith("— 0/6 waypoints, not flown, exit 3")
    assert log.splitlines()[-1] == result or log.splitlines()[-2] == result  # at the end


async def test_no_autopilot_ends_with_a_link_failed_result(tmp_path: Path) -> None:
    """Nothing answers on the link: exit 6, one error line saying so, no run directory."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]  # a UDP port nobody listens on once this closes
    url = f"udpout:127.0.0.1:{port}"
    cfg = HelixdConfig.model_validate({"link": {"url": url}, "startup": {"connect_timeout_s": 1.0}})
    outcome = await run_mission(square_run(cfg, url, tmp_path / "runs"))
    assert outcome.exit_code is ExitCode.LINK
    assert outcome.run_dir is None and not (tmp_path / "runs").exists()
    assert outcome.messages == [
        f"error: could not connect to {url}: no HEARTBEAT from system 1 on {url} within 1 s; "
        "nothing received at all"
    ]


async def test_unwritable_recorder_refusal_ends_with_a_result(tmp_path: Path) -> None:
    """recorder.on_write_error: refuse and a run root that cannot be created: exit 3, nothing
    connected, and the result line still comes."""
    blocker = tmp_path / "not-a-dir"
    blocker.write_text("a file where the run root should be")
    cfg = HelixdConfig.model_validate(
        {"link": {"url": "udpout:127.0.0.1:9"}, "recorder": {"on_write_error": "refuse"}}
    )
    outcome = await run_mission(square_run(cfg, "udpout:127.0.0.1:9", blocker / "runs"))
    assert outcome.exit_code is ExitCode.PREFLIGHT
    last = outcome.messages[-1]
    assert last.startswith("helixd: RESULT refused recorder: flight recorder cannot write")
    assert last.endswith("not flown, exit 3")


def test_fault_ends_with_a_plain_fault_result_line(tmp_path: Path) -> None:
    """A watchdog fault (stale pose) ends with scrolls stopped — and the operator reads it in
    one line: ``helixd: RESULT fault pose_stale: … exit 4``."""

    async def stale(st: Steer) -> None:
        await st.until(moving, 40.0)
        st.inject("stale_pose", duration_s=30.0)
        await st.until(harness.secured, 10.0)

    flown = simulated_flight(tmp_path, "square", during=stale)
    assert flown.code == ExitCode.FAULT, flown.log[-3000:]
    result = flown.result
    assert result.startswith("helixd: RESULT fault pose_stale: ")
    assert "/4 waypoints, " in result and " s autopilot time (" in result
    assert result.endswith(" s autopilot time (simulated clock), exit 4")
