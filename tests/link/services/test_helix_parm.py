"""The parameter files a crew loads on a real Helix (config/ardupilot/) make `helixd autopilot
check` say ok on every line: judged over stock ArduPilot Rover defaults, as a freshly flashed
autopilot has them, with helixd-guard installed (its own parameters come with the script)."""

from __future__ import annotations

import pytest

from helixd.config.link import LinkConfig
from helixd.config.vehicle import ActuationBackend, ActuationConfig
from helixd.files.parmfile import load_parm
from helixd.link.services.autopilot_setup import judge_setup
from helixd.mav.guard_script import HXG_VERSION, PARAM_DEFAULTS, VERSION
from helixd.sim.firmware.param_store import DEFAULT_PARAMS
from tests.support.paths import REPO_ROOT

ARDUPILOT_DIR = REPO_ROOT / "config" / "ardupilot"

# where a Helix differs from stock Rover (the simulator's table already has the Helix's values)
STOCK_ROVER = {
    "SERVO1_FUNCTION": 26.0,  # GroundSteering
    "SERVO2_FUNCTION": 0.0,
    "SERVO3_FUNCTION": 70.0,  # Throttle
    "SERVO4_FUNCTION": 0.0,
    "SERVO16_FUNCTION": 0.0,
    "RCMAP_THROTTLE": 3.0,
    "MAV_GCS_SYSID": 255.0,
    "FS_GCS_ENABLE": 0.0,
    "SCR_ENABLE": 0.0,
}


def autopilot_after_loading(*files: str) -> dict[str, float | None]:
    params: dict[str, float | None] = {k: float(s.default) for k, s in DEFAULT_PARAMS.items()}
    params.update(STOCK_ROVER)
    for name in files:
        params.update(load_parm(ARDUPILOT_DIR / name))
    params.update(PARAM_DEFAULTS)
    params[HXG_VERSION] = float(VERSION)
    return params


def test_stock_rover_is_not_ready() -> None:
    lines = judge_setup(autopilot_after_loading(), ActuationConfig(), LinkConfig())
    assert any(line.status == "error" for line in lines)


@pytest.mark.parametrize(
    ("files", "backend"),
    [
        (("helix.parm",), ActuationBackend.RC_OVERRIDE),
        (("helix.parm", "helix-servo.parm"), ActuationBackend.SERVO),
    ],
)
def test_the_shipped_files_pass_the_check_with_no_warning(
    files: tuple[str, ...], backend: ActuationBackend
) -> None:
    actuation = ActuationConfig(backend=backend)
    lines = judge_setup(autopilot_after_loading(*files), actuation, LinkConfig())
    not_ok = [f"{line}" for line in lines if line.status != "ok"]
    assert not_ok == []
    assert len(lines) >= 6
