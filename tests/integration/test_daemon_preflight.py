"""Preflight refusals: each names what to change, exits 3 and never arms the vehicle."""

from __future__ import annotations

import asyncio
import signal
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.harness import (
    GCS_SYSID,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_HOME,
    MAV_RESULT_ACCEPTED,
)
from tests.support.simulated import Steer, moving, simulated_flight

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
    flown = simulated_flight(tmp_path, "square", config, params=params)
    code, log, snap = flown.code, flown.log, flown.snapshot
    arms = flown.server.history.entries("arm")
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

    async def ground_station(st: Steer) -> None:  # a GCS heartbeats at 1 Hz; faster here
        gcs = st.ground_station(1, GCS_SYSID)
        while not st.flight_done():
            gcs.heartbeat()
            await asyncio.sleep(0.2)

    flown = simulated_flight(tmp_path, "square", during=ground_station, links=2)
    code, log, snap = flown.code, flown.log, flown.snapshot
    arms = flown.server.history.entries("arm")
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

    async def set_home(st: Steer) -> None:
        await st.line("event=waiting_for_home", 60.0)
        assert st.server.history.entries("arm") == []
        gcs = st.ground_station(1, 255)
        assert await gcs.command(MAV_CMD_DO_SET_HOME, 1) == MAV_RESULT_ACCEPTED
        await st.until(moving, 40.0)
        st.signal(signal.SIGINT)

    flown = simulated_flight(tmp_path, "square", during=set_home, links=2, home_delay_s=None)
    log, history = flown.log, flown.server.history
    homes = history.entries("home")
    arms = history.entries("arm")
    refused = [
        e
        for e in history.entries("command")
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
    flown = simulated_flight(tmp_path, "square", config, home_delay_s=None)
    code, log, arms = flown.code, flown.log, flown.server.history.entries("arm")
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
    flown = simulated_flight(tmp_path, "square", SERVO_ON_1_TO_4, params=FUNCTION_0, **sim)
    code, log, arms = flown.code, flown.log, flown.server.history.entries("arm")
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    refusal = "\n".join(line for line in log.splitlines() if line.startswith("preflight:"))
    for needle in needles:
        assert needle in refusal, f"{needle!r} not in {refusal!r}"
    assert arms == []


def test_no_gps_fix_is_refused(tmp_path: Path) -> None:
    """The receiver has no fix when helixd starts: preflight refuses (exit 3), names the fix
    and the setting, and nothing is armed."""

    async def no_fix(st: Steer) -> None:
        st.inject("gps_loss")

    flown = simulated_flight(tmp_path, "square", during=no_fix)
    code, log, arms = flown.code, flown.log, flown.server.history.entries("arm")
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    refusal = "\n".join(line for line in log.splitlines() if line.startswith("preflight:"))
    assert "GPS not good enough to drive on: GPS fix no fix (fix_type 1)" in refusal, log[-3000:]
    assert "safety.gps_min_fix_type" in refusal
    assert arms == []
