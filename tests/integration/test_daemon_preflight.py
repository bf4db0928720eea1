"""Preflight refusals: each names what to change, exits 3 and never arms the vehicle."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from helixd.exitcodes import ExitCode
from tests.integration.daemon_harness import sim_and_daemon

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
            ["MAV_GCS_SYSID", "255", "source_system"],
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
