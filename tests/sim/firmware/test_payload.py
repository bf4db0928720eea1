"""The payload commands, as ArduPilot answers them: through the simulator core, with its
COMMAND_ACK, its outputs and RELAY_STATUS (and the home it keeps)."""

from __future__ import annotations

import os
from typing import Any

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.mav.constants import (
    MAV_CMD_DO_DIGICAM_CONTROL,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_REPEAT_RELAY,
    MAV_CMD_DO_REPEAT_SERVO,
    MAV_CMD_DO_SET_CAM_TRIGG_DIST,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_RELAY,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_DO_SPRAYER,
    MAV_CMD_IMAGE_START_CAPTURE,
    MAV_CMD_IMAGE_STOP_CAPTURE,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_FAILED,
    MAVLINK_MSG_ID_HOME_POSITION,
    MAVLINK_MSG_ID_RELAY_STATUS,
)
from helixd.sim.core import SimCore
from tests.support.simcore import command, incoming, make_core, of_type, run

RELAY1 = {"RELAY1_FUNCTION": 1, "RELAY1_PIN": 13}


def core(**params: float) -> SimCore:
    c = make_core(params=params)
    run(c, 2.0)
    return c


def kinds(c: SimCore, kind: str) -> list[dict[str, object]]:
    return [dict(e.details) for e in c.drain_events() if e.kind == kind]


def requested(c: SimCore, msg_id: int) -> Any:
    """MAV_CMD_REQUEST_MESSAGE: ACCEPTED, and the message (as of the next loop) comes back."""
    run(c, 0.04)
    req = mavlink.MAVLink_command_long_message(1, 1, MAV_CMD_REQUEST_MESSAGE, 0, msg_id,
                                               0, 0, 0, 0, 0, 0)  # fmt: skip
    c.handle(0, incoming(req))
    out = c.drain_outbox()
    (ack,) = [m for _, m in out if m.get_type() == "COMMAND_ACK"]
    assert ack.result == MAV_RESULT_ACCEPTED
    found = [m for lk, m in out if lk == 0 and m.get_msgId() == msg_id]
    return found[0] if found else None


def relay_status(c: SimCore) -> tuple[int, int]:
    msg = requested(c, MAVLINK_MSG_ID_RELAY_STATUS)
    return int(msg.on), int(msg.present)


def test_a_relay_needs_a_function_and_a_pin() -> None:
    c = core()
    assert command(c, 0, MAV_CMD_DO_SET_RELAY, 0, 1) == MAV_RESULT_FAILED
    c = core(**RELAY1)
    assert command(c, 0, MAV_CMD_DO_SET_RELAY, 0, 1) == MAV_RESULT_ACCEPTED
    assert relay_status(c) == (1, 1)
    assert command(c, 0, MAV_CMD_DO_SET_RELAY, 0, 2) == MAV_RESULT_ACCEPTED  # 2: toggle
    assert relay_status(c) == (0, 1)
    assert command(c, 0, MAV_CMD_DO_SET_RELAY, 1, 1) == MAV_RESULT_FAILED  # RELAY2: none


def test_repeat_relay_toggles_count_times_two() -> None:
    c = core(**RELAY1)
    c.drain_events()
    assert command(c, 0, MAV_CMD_DO_REPEAT_RELAY, 0, 2, 1.0) == MAV_RESULT_ACCEPTED
    run(c, 3.0)
    toggles = kinds(c, "relay")
    assert [t["on"] for t in toggles] == [True, False, True, False]


def test_repeat_servo_cycles_value_and_trim_and_a_set_servo_cancels_it() -> None:
    c = core(SERVO2_FUNCTION=73)  # output 2 drives ArduPilot's left throttle
    assert command(c, 0, MAV_CMD_DO_REPEAT_SERVO, 9, 1900, 3, 2.0) == MAV_RESULT_ACCEPTED
    run(c, 0.1)
    assert c.outputs_us[8] == 1900
    run(c, 1.0)
    assert c.outputs_us[8] == 1500  # trim, half a period later
    assert command(c, 0, MAV_CMD_DO_SET_SERVO, 9, 1234) == MAV_RESULT_ACCEPTED
    run(c, 3.0)
    assert c.outputs_us[8] == 1234
    assert command(c, 0, MAV_CMD_DO_REPEAT_SERVO, 2, 1900, 3, 2.0) == MAV_RESULT_FAILED


def test_camera_without_a_backend_answers_as_ardupilot() -> None:
    c = core()
    assert command(c, 0, MAV_CMD_DO_DIGICAM_CONTROL, 0, 0, 0, 0, 1) == MAV_RESULT_ACCEPTED
    assert command(c, 0, MAV_CMD_DO_SET_CAM_TRIGG_DIST, 5, 0, 1) == MAV_RESULT_ACCEPTED
    assert command(c, 0, MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1) == MAV_RESULT_FAILED
    assert command(c, 0, MAV_CMD_IMAGE_STOP_CAPTURE, 0) == MAV_RESULT_ACCEPTED
    assert c.ap.payload.pictures == 0


def test_camera_with_a_backend_takes_pictures() -> None:
    c = core(CAM1_TYPE=1)
    assert command(c, 0, MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1) == MAV_RESULT_ACCEPTED
    assert command(c, 0, MAV_CMD_DO_DIGICAM_CONTROL, 0, 0, 0, 0, 1) == MAV_RESULT_ACCEPTED
    assert c.ap.payload.pictures == 2


def test_gripper_needs_enabling_and_the_sprayer_is_built_in() -> None:
    assert command(core(), 0, MAV_CMD_DO_GRIPPER, 1, 1) == MAV_RESULT_FAILED
    c = core(GRIP_ENABLE=1)
    assert command(c, 0, MAV_CMD_DO_GRIPPER, 1, 1) == MAV_RESULT_ACCEPTED
    assert c.ap.payload.gripper_grabbed is True
    assert command(c, 0, MAV_CMD_DO_SPRAYER, 1) == MAV_RESULT_ACCEPTED


def home_position(c: SimCore) -> tuple[float, float, float, float]:
    msg = requested(c, MAVLINK_MSG_ID_HOME_POSITION)
    return msg.latitude / 1e7, msg.longitude / 1e7, float(msg.x), float(msg.y)


def test_home_is_where_the_rover_is_and_follows_it_while_disarmed() -> None:
    c = make_core(initial_north_m=3.0, initial_east_m=-2.0)
    out = run(c, 0.2)
    assert not of_type(out, "HOME_POSITION")  # no origin yet: no home, nothing sent
    out = run(c, 2.0)
    (pushed,) = of_type(out, "HOME_POSITION", 0)  # AP_AHRS::set_home pushes it
    assert (pushed.x, pushed.y) == pytest.approx((3.0, -2.0), abs=0.01)
    _, _, n, e = home_position(c)
    assert (n, e) == pytest.approx((3.0, -2.0), abs=0.01)
    assert any("Set HOME to" in str(d["text"]) for d in kinds(c, "statustext"))


def test_do_set_home_current_or_a_place_locks_it() -> None:
    c = core()
    lat0, lon0, _, _ = home_position(c)
    msg = mavlink.MAVLink_command_int_message(
        1, 1, 0, MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 0, 0,
        round((lat0 + 1e-4) * 1e7), round(lon0 * 1e7), 0.0,
    )  # fmt: skip
    c.handle(0, incoming(msg))
    (ack,) = [m for _, m in c.drain_outbox() if m.get_type() == "COMMAND_ACK"]
    assert ack.result == MAV_RESULT_ACCEPTED
    lat, _, n, _ = home_position(c)
    assert lat == pytest.approx(lat0 + 1e-4, abs=1e-7) and n == pytest.approx(11.1, abs=0.1)
    assert c.ap.home is not None and c.ap.home.locked
    run(c, 3.0)  # locked: the once-a-second update leaves it
    assert home_position(c)[2] == pytest.approx(n)
    assert command(c, 0, MAV_CMD_DO_SET_HOME, 1) == MAV_RESULT_ACCEPTED  # where the rover is
    assert home_position(c)[2] == pytest.approx(0.0, abs=0.01)
