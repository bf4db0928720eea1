"""``helixd autopilot check``'s judgement (pure) and its parameter reads (against the peer)."""

from __future__ import annotations

from collections.abc import Mapping

import pytest

from helixd.config.link import LinkConfig
from helixd.config.vehicle import ActuationBackend, ActuationConfig
from helixd.link.services.autopilot_setup import (
    SetupLine,
    failed,
    judge_motor_outputs,
    judge_setup,
    judge_skipped_checks,
    read_setup,
    spare_output,
)
from helixd.link.services.preflight import judge
from helixd.mav.guard_script import PARAM_DEFAULTS as GUARD_DEFAULTS
from tests.support.peer import HELIXD_SYSID, linked

RC = ActuationConfig()  # rc_override on channels 1..4
SERVO = ActuationConfig(backend=ActuationBackend.SERVO)
LINK = LinkConfig()
OUTPUTS = {f"SERVO{n}_FUNCTION": 0.0 for n in range(1, 17)}
HELIX_RC = {
    "MAV_GCS_SYSID": float(HELIXD_SYSID),
    "MAV_GCS_SYSID_HI": 0.0,
    "RC_OVERRIDE_TIME": 3.0,
    "RC_OPTIONS": 0.0,
    "FS_GCS_ENABLE": 1.0,
    "FS_THR_ENABLE": 1.0,
    "RCMAP_THROTTLE": 5.0,  # a channel helixd does not override
    "FS_THR_VALUE": 960.0,
    "MODE_CH": 8.0,
    **OUTPUTS,
    **{f"SERVO{n}_FUNCTION": 50.0 + n for n in range(1, 5)},
    "SERVO16_FUNCTION": 94.0,
    **{f"RC{n}_OPTION": 0.0 for n in range(1, 5)},
    "SCR_ENABLE": 1.0,
    "ARMING_SKIPCHK": 0.0,
    **GUARD_DEFAULTS,
}
HELIX_SERVO = {**HELIX_RC, **{f"SERVO{n}_FUNCTION": 0.0 for n in range(1, 5)}}


def topics(lines: list[SetupLine]) -> dict[str, list[SetupLine]]:
    out: dict[str, list[SetupLine]] = {}
    for line in lines:
        out.setdefault(line.topic, []).append(line)
    return out


def judged(params: Mapping[str, float | None], act: ActuationConfig = RC) -> list[SetupLine]:
    return judge_setup(params, act, LINK)


@pytest.mark.parametrize(("params", "act"), [(HELIX_RC, RC), (HELIX_SERVO, SERVO)])
def test_the_helix_setup_is_all_ok(params: dict[str, float], act: ActuationConfig) -> None:
    lines = judged(params, act)
    assert [line.status for line in lines] == ["ok"] * 8, [str(x) for x in lines]
    assert not failed(lines)
    by = topics(lines)
    assert "SERVO16_FUNCTION = 94 (Script1)" in by["arming (motor outputs)"][0].message
    assert by["GCS system id"][0].message.startswith("MAV_GCS_SYSID = 247 is helixd's")
    assert "reads channel 5, which helixd does not override" in by["pilot's radio"][0].message


def test_a_throttle_channel_helixd_overrides_hides_a_lost_radio() -> None:
    """Measured on SITL: while a GCS overrides ArduPilot's throttle channel, a receiver that
    sends its failsafe frame (or stops) changes nothing ArduPilot reports."""
    by = topics(judged({**HELIX_RC, "RCMAP_THROTTLE": 3.0}))
    (line,) = by["pilot's radio"]
    assert line.status == "warning" and line.param == "RCMAP_THROTTLE"
    assert line.message.startswith("RCMAP_THROTTLE = 3 is a channel helixd overrides")
    assert "(e.g. 5)" in line.message and "below FS_THR_VALUE (960 µs)" in line.message
    # the servo backend overrides nothing: ArduPilot's own radio failsafe sees the receiver
    assert (
        topics(judged({**HELIX_SERVO, "RCMAP_THROTTLE": 3.0}, SERVO))["pilot's radio"][0].status
        == "ok"
    )


def test_a_radio_failsafe_switched_off_is_a_warning() -> None:
    (line,) = topics(judged({**HELIX_RC, "FS_THR_ENABLE": 0.0}))["pilot's radio"]
    assert line.status == "warning" and line.message.startswith("FS_THR_ENABLE = 0")


def test_no_radio_warning_when_the_config_drives_on_without_a_pilot() -> None:
    params = {**HELIX_RC, "RCMAP_THROTTLE": 3.0}
    assert [p.param for p in judge(params, RC, LINK, watch_radio=False)] == []
    assert [p.param for p in judge(params, RC, LINK)] == ["RCMAP_THROTTLE"]


def test_without_the_spare_it_names_the_output_to_set() -> None:
    line = judge_motor_outputs({**HELIX_RC, "SERVO16_FUNCTION": 0.0}, RC)
    assert line.status == "error" and line.param == "SERVO16_FUNCTION"
    assert line.message.startswith(
        "a normal arm is refused: 'PreArm: no motor, sail or scripting outputs defined'; "
        "set SERVO16_FUNCTION = 94 (Script1) on this spare output with nothing connected"
    )
    assert failed(judged({**HELIX_RC, "SERVO16_FUNCTION": 0.0}))


def test_the_spare_is_the_highest_free_output_not_a_scroll() -> None:
    used = {n: 0 for n in range(1, 17)} | {16: 1, 15: -1, 14: 33}
    assert spare_output(used, {1, 2, 3, 4}) == 13
    assert spare_output({1: 0, 2: 0, 3: 0, 4: 0}, {1, 2, 3, 4}) is None
    assert spare_output({n: 0 for n in range(1, 17)}, {14, 15, 16, 13}) == 12
    assert spare_output({}, set()) is None  # nothing read: nothing to offer


def test_half_set_up_motor_functions_are_named() -> None:
    line = judge_motor_outputs({**HELIX_RC, "SERVO7_FUNCTION": 73.0}, RC)
    assert line.status == "error"
    assert "'PreArm: check skid steering config'" in line.message
    assert "(SERVO7_FUNCTION = 73)" in line.message


@pytest.mark.parametrize(
    ("params", "status", "says"),
    [
        ({"ARMING_SKIPCHK": 0.0}, "ok", "ARMING_SKIPCHK = 0: every PreArm check is made"),
        ({"ARMING_SKIPCHK": -1.0}, "error", "ARMING_SKIPCHK = -1 skips every PreArm check"),
        ({"ARMING_SKIPCHK": 8.0}, "error", "skips the checks in bitmask 8"),
        ({"ARMING_CHECK": 1.0}, "ok", "ARMING_CHECK = 1: every PreArm check is made"),
        ({"ARMING_CHECK": 0.0}, "error", "ARMING_CHECK = 0 skips every PreArm check"),
        ({"ARMING_CHECK": 72.0}, "error", "ARMING_CHECK = 72 skips some PreArm checks"),
        ({}, "warning", "neither ARMING_SKIPCHK nor ARMING_CHECK could be read"),
    ],
)
def test_skipped_checks(params: dict[str, float], status: str, says: str) -> None:
    line = judge_skipped_checks(params)
    assert line.status == status and says in line.message


def test_preflight_problems_land_in_their_topics() -> None:
    lines = judged(
        {**HELIX_RC, "MAV_GCS_SYSID": 255.0, "SERVO2_FUNCTION": 74.0, "FS_GCS_ENABLE": 0.0}
    )
    by = topics(lines)
    assert [x.status for x in by["GCS system id"]] == ["error"]
    assert "set MAV_GCS_SYSID = 247" in by["GCS system id"][0].message
    assert "SERVO2_FUNCTION = 74" in by["scroll outputs"][0].message
    assert by["scroll outputs"][0].status == "error"
    assert [x.status for x in by["link and failsafe"]] == ["warning"]
    # a lone ThrottleRight on a scroll output also fails ArduPilot's motor check
    assert "check skid steering config" in by["arming (motor outputs)"][0].message
    assert failed(lines)


def test_warnings_alone_pass() -> None:
    lines = judged({**HELIX_RC, "FS_GCS_ENABLE": 0.0})
    assert any(x.status == "warning" for x in lines) and not failed(lines)


async def test_read_setup_against_the_peer() -> None:
    async with linked(command_timeout_s=0.1, command_retries=1) as (ap, peer):
        peer.params.update({k: v for k, v in HELIX_RC.items() if not k.startswith("HXG_")})
        params = await read_setup(ap, RC)
        assert params["SERVO16_FUNCTION"] == 94.0
        assert params["ARMING_SKIPCHK"] == 0.0
        assert params["SERVO17_FUNCTION"] is None and "SERVO18_FUNCTION" not in params
        lines = judge_setup(params, RC, LINK)
        assert topics(lines)["arming (motor outputs)"][0].status == "ok"


THROTTLE_AT_TRIM = {**HELIX_RC, "RC5_TRIM": 1500.0, "RC5_DZ": 30.0}


def rc_with(channel: int, pwm_us: int) -> tuple[int, ...]:
    return tuple(pwm_us if n == channel else 1500 for n in range(1, 17))


def test_a_throttle_channel_off_its_trim_is_named_with_what_it_must_read() -> None:
    """The crew's radio: RCMAP_THROTTLE = 5, its switch resting high. ArduPilot refuses the
    arm ("Arm: Throttle (RC5) is not neutral"); the check says what RC5 must read."""
    lines = judge_setup(THROTTLE_AT_TRIM, RC, LINK, rc_inputs_us=rc_with(5, 1900))
    line = topics(lines)["arming (throttle)"][0]
    assert line.status == "error" and failed(lines)
    assert line.message == (
        "a normal arm is refused: 'Arm: Throttle (RC5) is not neutral'; RC5 (RCMAP_THROTTLE) "
        "must read its trim RC5_TRIM = 1500 µs ± RC5_DZ = 30 µs (1470–1530 µs) to arm; it "
        "reads 1900 µs — put the stick or switch on RC5 where it reads its trim (a 3-position "
        "switch in its middle position), or set RC5_TRIM to the value RC5 rests at"
    )
    assert "force" not in line.message


@pytest.mark.parametrize(("pwm_us", "status"), [(1530, "ok"), (1470, "ok"), (1531, "error")])
def test_the_throttle_channel_is_neutral_within_its_dead_zone(pwm_us: int, status: str) -> None:
    line = topics(judge_setup(THROTTLE_AT_TRIM, RC, LINK, rc_inputs_us=rc_with(5, pwm_us)))
    assert line["arming (throttle)"][0].status == status


def test_without_rc_input_the_throttle_line_still_says_what_to_read() -> None:
    line = topics(judge_setup(THROTTLE_AT_TRIM, RC, LINK))["arming (throttle)"][0]
    assert line.status == "ok"
    assert line.message.startswith("RC5 (RCMAP_THROTTLE) must read its trim RC5_TRIM = 1500 µs")
    assert "no RC input seen" in line.message


def test_moving_the_throttle_channel_says_what_it_must_then_read_to_arm() -> None:
    line = topics(judged({**HELIX_RC, "RCMAP_THROTTLE": 3.0}))["pilot's radio"][0]
    assert "to arm, that channel must then read its trim (RCn_TRIM ± RCn_DZ" in line.message
    assert "force" not in line.message
