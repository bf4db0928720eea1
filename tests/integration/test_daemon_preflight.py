"""Preflight refusals: each names what to change, exits 3 and never arms the vehicle."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.harness import (
    GCS_SYSID,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_HOME,
    MAV_RESULT_ACCEPTED,
    SPEEDUP,
    client,
    daemon,
    running_sim_links,
    sim_and_daemon,
    wait_moving,
)

pytestmark = pytest.mark.integration

SERVO_CFG = {
    "actuation": {
        "backend": "servo",
        "channels": [{"channel": 5}, {"channel": 6}, {"channel": 7}, {"channel": 8}],
    }
}


@pytest.mark.parametrize(
    ("params", "config", "needles"),
    [
        pytest.param(
            {"MAV_GCS_SYSID": 1},
            None,
            ["MAV_GCS_SYSID = 247", "currently 1", "source_system"],
            id="wrong_gcs_sysid",
        ),
        pytest.param(
            {"RC_OPTIONS": 2},
            None,
            ["RC_OPTIONS = 2", "Ignore MAVLink Overrides", "RC_OPTIONS = 0"],
            id="overrides_disabled",
        ),
        pytest.param(
            {"SERVO5_FUNCTION": 73},
            SERVO_CFG,
            ["SERVO5_FUNCTION", "0, 1, 22, 23 or 51..66", "already in use"],
            id="servo_channel_in_use",
        ),
        pytest.param(
            {"SERVO3_FUNCTION": 73},
            None,
            ["SERVO3_FUNCTION", "73", "53"],
            id="override_channel_not_passthrough",
        ),
    ],
)
def test_preflight_refusal(
    tmp_path: Path, params: dict[str, float], config: dict[str, Any] | None, needles: list[str]
) -> None:
    with sim_and_daemon(tmp_path, "square", config, params=params) as (server, d):
        code = d.wait_exit(60.0)
        log = d.log_text()
        arms = server.history.entries("arm")
        snap = server.snapshot()
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    refusal = [line for line in log.splitlines() if line.startswith("preflight:")]
    assert refusal, log[-3000:]
    text = "\n".join(refusal)
    for needle in needles:
        assert needle in text, f"{needle!r} not in {text!r}"
    assert arms == [] and not snap.armed
    assert "Traceback" not in log


def test_ground_station_on_helixd_s_system_id_is_refused(tmp_path: Path) -> None:
    """A GCS left on helixd's id, on another link of the autopilot: ArduPilot forwards its
    HEARTBEATs to helixd's link; preflight refuses (exit 3) and nothing is armed."""
    links = ["udpin:127.0.0.1:0", "udpin:127.0.0.1:0"]
    with running_sim_links(links, speedup=SPEEDUP) as server:
        helixd_port, gcs_port = server.local_ports
        with client(f"udpout:127.0.0.1:{gcs_port}", sysid=GCS_SYSID) as gcs:
            stop = threading.Event()

            def ground_station() -> None:  # a GCS heartbeats at 1 Hz; faster here
                while not stop.wait(0.2):
                    gcs.heartbeat()

            pinger = threading.Thread(target=ground_station, name="gcs-on-our-id", daemon=True)
            pinger.start()
            try:
                with daemon(tmp_path, f"udpout:127.0.0.1:{helixd_port}", "square") as d:
                    code = d.wait_exit(60.0)
                    log = d.log_text()
            finally:
                stop.set()
                pinger.join(timeout=2.0)
        arms = server.history.entries("arm")
        snap = server.snapshot()
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    refusal = "\n".join(line for line in log.splitlines() if line.startswith("preflight:"))
    assert f"another sender uses helixd's system id {GCS_SYSID}" in refusal, log[-3000:]
    assert "component 190" in refusal and "HEARTBEAT type GCS" in refusal
    assert arms == [] and not snap.armed
    assert "Traceback" not in log


def test_arming_waits_for_the_autopilot_s_home_instead_of_being_refused(tmp_path: Path) -> None:
    """Regression: every demo warned "FAILED …; it said: 'PreArm: AHRS: waiting for home'".
    Here the autopilot has an EKF origin and a pose but no home until a ground station (on
    another link, its own id) sets it with MAV_CMD_DO_SET_HOME once helixd says it waits:
    helixd arms after HOME_POSITION, once, unforced — the autopilot saw no refused arming."""
    links = ["udpin:127.0.0.1:0", "udpin:127.0.0.1:0"]
    with running_sim_links(links, speedup=SPEEDUP, home_delay_s=None) as server:
        helixd_port, gcs_port = server.local_ports
        with daemon(tmp_path, f"udpout:127.0.0.1:{helixd_port}", "square") as d:
            d.wait_line("event=waiting_for_home", 60.0)
            assert server.history.entries("arm") == []
            with client(f"udpout:127.0.0.1:{gcs_port}", sysid=255) as gcs:
                assert gcs.command(MAV_CMD_DO_SET_HOME, 1) == MAV_RESULT_ACCEPTED
            wait_moving(server)
            d.stop(20.0)
            log = d.log_text()
        homes = server.history.entries("home")
        arms = server.history.entries("arm")
        refused = [
            e
            for e in server.history.entries("command")
            if e.details["command"] == MAV_CMD_COMPONENT_ARM_DISARM
            and e.details["result"] != MAV_RESULT_ACCEPTED
        ]
    assert len(homes) == 1 and len(arms) == 1, log[-3000:]
    assert arms[0].sim_time_s >= homes[0].sim_time_s
    assert arms[0].details["forced"] is False
    assert refused == []
    assert "event=home_known" in log
    assert "arm_refused_retrying" not in log and "waiting for home" not in log


def test_no_home_within_the_timeout_is_a_preflight_refusal(tmp_path: Path) -> None:
    config = {"startup": {"home_timeout_s": 1.0}}
    with sim_and_daemon(tmp_path, "square", config, home_delay_s=None) as (server, d):
        code = d.wait_exit(60.0)
        log = d.log_text()
        arms = server.history.entries("arm")
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    assert "preflight: the autopilot reported no home (HOME_POSITION)" in log
    assert "startup.home_timeout_s = 1 s" in log
    assert arms == []


SERVO_ON_1_TO_4 = {
    "actuation": {"backend": "servo"},
}
FUNCTION_0 = {f"SERVO{n}_FUNCTION": 0 for n in range(1, 5)}


@pytest.mark.parametrize(
    ("sim", "needles"),
    [
        pytest.param(
            {},
            [
                "helixd-guard does not run on the autopilot (no HXG_VERSION parameter); "
                "SCR_ENABLE = 0",
                "helixd autopilot install-guard --connect URL",
            ],
            id="guard_missing",
        ),
        pytest.param(
            {"guard_installed": True, "guard_params": {"HXG_CHAN3": 0.0}},
            ["helixd-guard does not guard scroll output 3", "set HXG_CHAN1..4 = 1, 2, 3, 4"],
            id="output_not_guarded",
        ),
    ],
)
def test_servo_backend_refuses_without_the_guard(
    tmp_path: Path, sim: dict[str, Any], needles: list[str]
) -> None:
    with sim_and_daemon(tmp_path, "square", SERVO_ON_1_TO_4, params=FUNCTION_0, **sim) as (
        server,
        d,
    ):
        code = d.wait_exit(60.0)
        log = d.log_text()
        arms = server.history.entries("arm")
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    refusal = "\n".join(line for line in log.splitlines() if line.startswith("preflight:"))
    for needle in needles:
        assert needle in refusal, f"{needle!r} not in {refusal!r}"
    assert arms == []


def test_no_gps_fix_is_refused(tmp_path: Path) -> None:
    """The receiver has no fix when helixd starts: preflight refuses (exit 3), names the fix
    and the setting, and nothing is armed."""
    with sim_and_daemon(tmp_path, "square") as (server, d):
        server.inject("gps_loss")
        code = d.wait_exit(60.0)
        log = d.log_text()
        arms = server.history.entries("arm")
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    refusal = "\n".join(line for line in log.splitlines() if line.startswith("preflight:"))
    assert "GPS not good enough to drive on: GPS fix no fix (fix_type 1)" in refusal, log[-3000:]
    assert "safety.gps_min_fix_type" in refusal
    assert arms == []
