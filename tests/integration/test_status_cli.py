"""`helixd status` against the simulator over UDP: read-only, and it says what it sees."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.harness import free_udp_port, running_sim

pytestmark = pytest.mark.integration


def test_status_once() -> None:
    with running_sim(speedup=5.0) as (server, url):
        server.wait_for(lambda s: not s.booting and s.sim_time_s > 6.0, 20.0)
        res = subprocess.run(
            [sys.executable, "-m", "helixd", "status", "--connect", url],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        snap = server.snapshot()
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "mode      : MANUAL  (disarmed)" in out
    assert "pose      : N " in out and "(NED, clockwise from North)" in out
    assert "ekf       : EKF healthy" in out
    assert "rc in µs  : 1500" in out
    first, second = out.splitlines()[:2]  # which config, then what it waits for
    assert first == "config  : built-in defaults"
    assert second.startswith("status    : waiting up to 30 s (startup.connect_timeout_s)")
    assert "gps       : 3D fix, " in out and " satellites" in out
    assert "battery   : " in out and " V" in out
    assert "position  : 53.52" in out and "(the EKF pose through its origin)" in out
    assert not snap.armed and not any(snap.overrides_active)  # read-only


def test_status_says_what_it_waits_for_and_when_it_gives_up(tmp_path: Path) -> None:
    """Nothing answers: a line at once, and one clear line at the timeout (not 30 s of
    silence)."""
    config = tmp_path / "c.yaml"
    config.write_text("startup:\n  connect_timeout_s: 1.0\n", encoding="utf-8")
    res = subprocess.run(
        [sys.executable, "-m", "helixd", "status", "-c", str(config), "--connect",
         f"udpout:127.0.0.1:{free_udp_port()}"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert res.returncode == ExitCode.LINK
    assert res.stdout.splitlines()[0] == f"config  : {config}"
    assert res.stdout.splitlines()[1].startswith(
        "status    : waiting up to 1 s (startup.connect_timeout_s)"
    )
    assert res.stderr.count("error:") == 1 and "no HEARTBEAT" in res.stderr


@pytest.mark.parametrize("command", [["status"], ["mission", "download"]])
def test_a_command_that_does_not_fly_never_trips_the_gcs_failsafe(command: list[str]) -> None:
    """The rover in MANUAL, the autopilot's GCS failsafe on (FS_GCS_ENABLE 1, FS_ACTION 2 =
    HOLD): a read-only command speaks as link.observer_system and sends no HEARTBEAT, so the
    autopilot never counts on it and stays in MANUAL after it exits — watched on the
    simulator's own clock for FS_GCS_TIMEOUT + FS_TIMEOUT and more."""
    with running_sim(speedup=5.0, params={"FS_GCS_ENABLE": 1.0}) as (server, url):
        server.wait_for(lambda s: not s.booting and s.mode == "MANUAL", 20.0)
        res = subprocess.run(
            [sys.executable, "-m", "helixd", *command, "--connect", url],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        ended = server.snapshot()
        params = ended.params
        watch_until = ended.sim_time_s + params["FS_GCS_TIMEOUT"] + params["FS_TIMEOUT"] + 2.0
        after = server.wait_for(lambda s: s.sim_time_s >= watch_until, 30.0)
    assert res.returncode == 0, res.stderr
    if command == ["status"]:
        assert "system 248 (link.observer_system)" in res.stdout  # it says which id it used
    assert after.gcs_heartbeats_seen == 0 and after.gcs_last_seen_s is None
    assert not after.failsafe_gcs and not after.failsafe_triggered
    assert after.mode == "MANUAL"


def test_status_bad_url_is_one_clear_line() -> None:
    res = subprocess.run(
        [sys.executable, "-m", "helixd", "status", "--connect", "bogus://x"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert res.returncode == ExitCode.USAGE  # a bad command line, not a failed connection
    assert "Traceback" not in res.stderr
    assert res.stderr.count("error:") == 1 and "bogus://x" in res.stderr
