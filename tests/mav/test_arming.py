"""AP_MotorsUGV::pre_arm_check over SERVOn_FUNCTION values (helixd.mav.arming)."""

from __future__ import annotations

import pytest

from helixd.mav.arming import motor_prearm_failure, servo_functions

HELIX = {1: 51, 2: 52, 3: 53, 4: 54}  # the scrolls on RC passthrough


@pytest.mark.parametrize(
    ("functions", "frame", "text"),
    [
        ({}, 0, "no motor, sail or scripting outputs defined"),
        (HELIX, 0, "no motor, sail or scripting outputs defined"),
        ({1: 0, 2: 0, 3: 0, 4: 0}, 0, "no motor, sail or scripting outputs defined"),
        ({**HELIX, 5: 1}, 0, "no motor, sail or scripting outputs defined"),
        ({**HELIX, 5: 95}, 0, "no motor, sail or scripting outputs defined"),  # Script2 no
        ({**HELIX, 5: 73}, 0, "check skid steering config"),
        ({**HELIX, 5: 74, 16: 94}, 0, "check skid steering config"),
        ({**HELIX, 5: 70}, 0, "check steering and throttle config"),
        ({**HELIX, 5: 26}, 0, "check steering and throttle config"),
        ({**HELIX, 5: 89}, 0, "check steering and throttle config"),
        ({**HELIX, 5: 128}, 0, "check steering and throttle config"),
        ({**HELIX, 16: 94}, 2, "servo function 33 unassigned"),
        ({5: 33, 6: 34, 7: 35}, 2, "servo function 36 unassigned"),
    ],
)
def test_refusals(functions: dict[int, int], frame: int, text: str) -> None:
    assert motor_prearm_failure(functions, frame) == text


@pytest.mark.parametrize(
    ("functions", "frame"),
    [
        ({**HELIX, 16: 94}, 0),
        ({**HELIX, 9: 94}, 0),
        ({1: 73, 3: 74}, 0),  # stock skid steering
        ({1: 26, 3: 70}, 0),  # stock Ackermann
        ({1: 26, 3: 89}, 0),  # a sailboat without throttle
        ({1: 33, 2: 34, 3: 35}, 1),  # omni3
        ({1: 33, 2: 34, 3: 35}, 4),  # omni3 mecanum
    ],
)
def test_setups_that_pass(functions: dict[int, int], frame: int) -> None:
    assert motor_prearm_failure(functions, frame) is None


def test_servo_functions_reads_only_servo_functions() -> None:
    params = {"SERVO1_FUNCTION": 51.0, "SERVO16_FUNCTION": 94.0, "SERVO2_FUNCTION": None,
              "SERVO1_TRIM": 1500.0, "SERVO_RATE": 50.0, "SERVOX_FUNCTION": 3.0}  # fmt: skip
    assert servo_functions(params) == {1: 51, 16: 94}
