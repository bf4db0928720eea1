"""The servo output model's timed override (a script's set_output_pwm_chan_timeout)."""

from __future__ import annotations

from helixd.sim.firmware.outputs import MotorDemand, ServoOutputs
from helixd.sim.firmware.param_store import ParamStore
from helixd.sim.sim_config import SimConfig

RADIO = [1500] * 16


def outputs_with(**functions: int) -> tuple[ServoOutputs, ParamStore]:
    params = ParamStore({**SimConfig().params, **functions})
    return ServoOutputs(), params


def test_hold_lasts_its_loops_then_a_function_0_output_keeps_the_value() -> None:
    out, params = outputs_with(SERVO5_FUNCTION=0)
    assert out.do_set_servo(5, 1700, params) is None
    out.hold(5, 1500, loops=5)  # 100 ms at 50 Hz
    seen = []
    for _ in range(7):
        seen.append((out.update(RADIO, params, None)[4], out.held_channels()))
    assert [h for _, h in seen] == [(5,)] * 5 + [(), ()]
    assert [pwm for pwm, _ in seen] == [1500] * 7  # have_pwm: the held value stays
    assert out.do_set_servo(5, 1650, params) is None
    assert out.update(RADIO, params, None)[4] == 1650


def test_do_set_servo_under_the_hold_is_accepted_and_lost() -> None:
    out, params = outputs_with(SERVO5_FUNCTION=0)
    out.hold(5, 1500, loops=3)
    out.update(RADIO, params, None)
    assert out.do_set_servo(5, 1800, params) is None  # accepted …
    for _ in range(5):
        assert out.update(RADIO, params, None)[4] == 1500  # … and never applied


def test_passthrough_ignores_the_hold_and_ardupilot_functions_resume_after_it() -> None:
    out, params = outputs_with(SERVO1_FUNCTION=51, SERVO3_FUNCTION=70)
    radio = [1800] + [1500] * 15
    out.hold(1, 1500, loops=3)
    out.hold(3, 1500, loops=3)
    demand = MotorDemand(throttle=0.5)
    first = out.update(radio, params, demand)
    assert first[0] == 1800  # output_ch copies RC input 1 after the override
    assert first[2] == 1500  # throttle held at the override value
    for _ in range(3):
        last = out.update(radio, params, demand)
    assert last[2] == 1750  # throttle 0.5 computed again: 1500 + 0.5 × (2000 − 1500)


def test_a_parameter_set_between_loops_is_read_by_the_next_loop() -> None:
    """The outputs read SERVOn_FUNCTION/TRIM and RCn_DZ once per parameter version: a change
    (or another parameter store) is seen at the very next loop."""
    out, params = outputs_with(SERVO5_FUNCTION=0, SERVO5_TRIM=1500)
    assert out.update(RADIO, params, None)[4] == 1500
    params.set("SERVO5_TRIM", 1420)
    assert out.update(RADIO, params, None)[4] == 1420
    params.set("SERVO5_FUNCTION", 55)  # RCIN5: the pilot's channel 5
    assert out.update([1500] * 4 + [1750] + [1500] * 11, params, None)[4] == 1750
    other = ParamStore({**SimConfig().params, "SERVO5_FUNCTION": 0, "SERVO5_TRIM": 1600})
    assert out.update(RADIO, other, None)[4] == 1600
