"""The simulator's arm applies ArduPilot's PreArm check on the motor outputs
(AP_MotorsUGV::pre_arm_check, via :mod:`helixd.mav.arming`), with ArduPilot's texts; force
(21196) still arms; the Helix defaults (scrolls on RCIN1-4, SERVO16 = Script1) arm normally."""

from __future__ import annotations

import pytest

from helixd.mav.arming import FORCE_ARM_MAGIC
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_FAILED,
)
from helixd.sim.firmware.param_store import DEFAULT_PARAMS
from tests.sim.firmware.test_rover_firmware import Rig

PASSTHROUGH = {"SERVO1_FUNCTION": 51, "SERVO2_FUNCTION": 52, "SERVO3_FUNCTION": 53,
               "SERVO4_FUNCTION": 54}  # fmt: skip
NO_SPARE = {**PASSTHROUGH, "SERVO16_FUNCTION": 0}


def ready(params: dict[str, float]) -> Rig:
    """Booted, home set and the other PreArm checks passed."""
    rig = Rig(params=params, prearm_delay_s=0.0).boot()
    rig.run(0.5)
    return rig


def arm(rig: Rig, param2: float = 0.0) -> int | None:
    return rig.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, param2)


def test_the_helix_defaults_arm_without_force() -> None:
    assert DEFAULT_PARAMS["SERVO16_FUNCTION"].default == 94
    rig = ready({})
    assert arm(rig) == MAV_RESULT_ACCEPTED
    assert rig.ap.armed
    assert rig.ap.events[-1].details == {"forced": False}
    assert not [t for t in rig.texts() if t.startswith("PreArm")]


def test_the_spare_script_output_stays_at_trim() -> None:
    rig = ready({})
    assert arm(rig) == MAV_RESULT_ACCEPTED
    rig.run(0.1)
    assert rig.outputs[15] == 1500  # SERVO16_TRIM: no script drives Script1


@pytest.mark.parametrize(
    ("functions", "text"),
    [
        (NO_SPARE, "PreArm: no motor, sail or scripting outputs defined"),
        ({**PASSTHROUGH, "SERVO16_FUNCTION": 0, "SERVO5_FUNCTION": 1},
         "PreArm: no motor, sail or scripting outputs defined"),  # RCPassThru is no motor
        ({**NO_SPARE, "SERVO5_FUNCTION": 73}, "PreArm: check skid steering config"),
        ({**NO_SPARE, "SERVO5_FUNCTION": 74}, "PreArm: check skid steering config"),
        ({**NO_SPARE, "SERVO5_FUNCTION": 70}, "PreArm: check steering and throttle config"),
        ({**NO_SPARE, "SERVO5_FUNCTION": 26}, "PreArm: check steering and throttle config"),
        ({**NO_SPARE, "SERVO5_FUNCTION": 89}, "PreArm: check steering and throttle config"),
        ({"SERVO5_FUNCTION": 73}, "PreArm: check skid steering config"),  # Script1 no help
    ],
)  # fmt: skip
def test_motor_output_refusals_have_ardupilots_texts(
    functions: dict[str, float], text: str
) -> None:
    rig = ready(functions)
    assert arm(rig) == MAV_RESULT_FAILED
    assert not rig.ap.armed
    assert rig.texts()[-1] == text
    assert arm(rig, FORCE_ARM_MAGIC) == MAV_RESULT_ACCEPTED  # force skips every check
    assert rig.ap.events[-1].details == {"forced": True}


@pytest.mark.parametrize(
    "functions",
    [
        {**NO_SPARE, "SERVO5_FUNCTION": 73, "SERVO6_FUNCTION": 74},  # ArduPilot's skid mixer
        {**NO_SPARE, "SERVO5_FUNCTION": 70, "SERVO6_FUNCTION": 26},  # throttle + steering
        {**NO_SPARE, "SERVO9_FUNCTION": 94},  # any spare output as Script1
        {**NO_SPARE, "SERVO5_FUNCTION": 89, "SERVO6_FUNCTION": 26},  # a sailboat
    ],
)
def test_motor_output_setups_ardupilot_arms(functions: dict[str, float]) -> None:
    rig = ready(functions)
    assert arm(rig) == MAV_RESULT_ACCEPTED


def test_both_refusals_are_said_before_home() -> None:
    rig = Rig(params=NO_SPARE).boot()
    rig.ap.home = None
    assert arm(rig) == MAV_RESULT_FAILED
    assert rig.texts()[-2:] == [
        "PreArm: AHRS: waiting for home",
        "PreArm: no motor, sail or scripting outputs defined",
    ]


def test_skipping_all_checks_arms_without_outputs() -> None:
    rig = ready({**NO_SPARE, "ARMING_SKIPCHK": -1})
    assert arm(rig) == MAV_RESULT_ACCEPTED
