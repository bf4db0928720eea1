"""Preflight parameter checks: each problem says exactly what to change."""

from __future__ import annotations

from collections.abc import Mapping

import pytest

from helixd.config.link import LinkConfig
from helixd.config.vehicle import ActuationBackend, ActuationConfig, ChannelConfig
from helixd.link.services.preflight import check_obedience, judge
from helixd.mav.guard_script import PARAM_DEFAULTS as GUARD_DEFAULTS
from tests.support.peer import HELIXD_SYSID, linked

RC = ActuationConfig()  # rc_override on channels 1..4
SERVO = ActuationConfig(backend=ActuationBackend.SERVO)
LINK = LinkConfig()
GOOD_RC = {
    "MAV_GCS_SYSID": float(HELIXD_SYSID),
    "MAV_GCS_SYSID_HI": 0.0,
    "RC_OVERRIDE_TIME": 3.0,
    "RC_OPTIONS": 32.0,
    "FS_GCS_ENABLE": 1.0,
    "MODE_CH": 8.0,
    **{f"SERVO{n}_FUNCTION": 50.0 + n for n in range(1, 5)},
    **{f"RC{n}_OPTION": 0.0 for n in range(1, 5)},
    "SCR_ENABLE": 1.0,
    **GUARD_DEFAULTS,  # helixd-guard runs, guarding outputs 1..4 after 0.5 s
}


def messages(params: Mapping[str, float | None], act: ActuationConfig = RC) -> list[str]:
    return [str(p) for p in judge(params, act, LINK)]


async def test_against_the_peer_good_then_bad() -> None:
    async with linked(command_timeout_s=0.15, command_retries=1) as (ap, peer):
        peer.params.update({f"SERVO{n}_FUNCTION": 50.0 + n for n in range(1, 5)})
        assert await check_obedience(ap, RC, ap.cfg) == []
        peer.params.update(
            {
                "MAV_GCS_SYSID": 1.0,
                "RC_OPTIONS": 34.0,
                "SERVO3_FUNCTION": 73.0,
                "FS_GCS_ENABLE": 0.0,
            }
        )
        problems = await check_obedience(ap, RC, ap.cfg)
        text = [str(p) for p in problems]
        assert (
            "error: RC overrides from helixd would be silently ignored: set MAV_GCS_SYSID = "
            f"{HELIXD_SYSID} (currently 1), or run helixd with link.source_system = 1"
        ) in text
        assert (
            "error: RC_OPTIONS = 34 has bit 1 'Ignore MAVLink Overrides' set: set RC_OPTIONS = 32"
            in text
        )
        assert any(
            t.startswith("error: SERVO3_FUNCTION = 73") and "set SERVO3_FUNCTION = 53" in t
            for t in text
        )
        assert any(p.severity == "warning" and p.param == "FS_GCS_ENABLE" for p in problems)


def test_legacy_sysid_name_is_read_when_the_new_one_is_missing() -> None:
    params = {**GOOD_RC, "MAV_GCS_SYSID": None, "SYSID_MYGCS": float(HELIXD_SYSID)}
    assert messages(params) == []
    params["SYSID_MYGCS"] = 250.0
    assert messages(params) == [
        f"error: RC overrides from helixd would be silently ignored: set SYSID_MYGCS = "
        f"{HELIXD_SYSID} (currently 250), or run helixd with link.source_system = 250"
    ]


def test_override_time() -> None:
    assert (
        "error: RC_OVERRIDE_TIME = 0 disables RC overrides entirely"
        in messages({**GOOD_RC, "RC_OVERRIDE_TIME": 0.0})[0]
    )
    never = messages({**GOOD_RC, "RC_OVERRIDE_TIME": -1.0})
    assert never[0].startswith("warning: RC_OVERRIDE_TIME = -1: overrides never expire")
    assert "set RC_OVERRIDE_TIME = 3" in never[0]
    short = messages({**GOOD_RC, "RC_OVERRIDE_TIME": 0.08})
    assert short[0].startswith("warning: RC_OVERRIDE_TIME = 0.08 s is shorter than two")


def test_rc_channel_wiring() -> None:
    wrong_rcin = messages({**GOOD_RC, "SERVO2_FUNCTION": 51.0})
    assert wrong_rcin == [
        "error: SERVO2_FUNCTION = 51 makes output 2 follow RC input 1, not the overridden RC "
        "channel 2: set SERVO2_FUNCTION = 52 (RCIN2)"
    ]
    assert messages({**GOOD_RC, "SERVO1_FUNCTION": 1.0}) == []  # RCPassThru, same number
    assert "leaves output 4 unused" in messages({**GOOD_RC, "SERVO4_FUNCTION": 0.0})[0]
    assert "MODE_CH = 3" in messages({**GOOD_RC, "MODE_CH": 3.0})[0]
    assert "set RC2_OPTION = 0" in messages({**GOOD_RC, "RC2_OPTION": 41.0})[0]
    high = ActuationConfig(channels=(ChannelConfig(channel=17), *RC.channels[1:]))
    params = {**GOOD_RC, "RC17_OPTION": 0.0}
    assert any("RCIN passthrough exists for 1..16" in m for m in messages(params, high))


def test_servo_backend_functions() -> None:
    params = {
        "MAV_GCS_SYSID": float(HELIXD_SYSID),
        "FS_GCS_ENABLE": 1.0,
        "SERVO1_FUNCTION": 0.0,
        "SERVO2_FUNCTION": 73.0,
        "SERVO3_FUNCTION": 51.0,
        "SERVO4_FUNCTION": None,
        "SCR_ENABLE": 1.0,
        **GUARD_DEFAULTS,
    }
    text = messages(params, SERVO)
    assert (
        "error: SERVO2_FUNCTION = 73: ArduPilot refuses DO_SET_SERVO on this output; "
        "set SERVO2_FUNCTION = 0" in text
    )
    assert any(t.startswith("warning: SERVO3_FUNCTION = 51") for t in text)
    assert "warning: cannot read SERVO4_FUNCTION" in text
    assert len(text) == 3
    # a sysid mismatch only weakens the GCS failsafe for this backend
    assert messages({**params, "MAV_GCS_SYSID": 1.0}, SERVO)[0].startswith("warning:")


@pytest.mark.parametrize(
    ("function", "severity"),
    [(28, "warning"), (140, "warning"), (155, "warning"), (94, "error"), (156, "error")],
)
def test_servo_backend_judges_outputs_as_do_set_servo_does(function: int, severity: str) -> None:
    """The gripper (28) and RCIN1..16 mapped (140..155) pass AP_ServoRelayEvents::do_set_servo;
    a scripting output (94) does not."""
    params = {
        "MAV_GCS_SYSID": float(HELIXD_SYSID),
        "FS_GCS_ENABLE": 1.0,
        **{f"SERVO{n}_FUNCTION": 0.0 for n in range(1, 5)},
        "SERVO2_FUNCTION": float(function),
        "SCR_ENABLE": 1.0,
        **GUARD_DEFAULTS,
    }
    assert [t.split(":")[0] for t in messages(params, SERVO)] == [severity]


async def test_legacy_firmware_against_the_peer() -> None:
    async with linked(command_timeout_s=0.15, command_retries=1) as (ap, peer):
        peer.params.update({f"SERVO{n}_FUNCTION": 50.0 + n for n in range(1, 5)})
        del peer.params["MAV_GCS_SYSID"]
        peer.params["SYSID_MYGCS"] = 254.0
        problems = await check_obedience(ap, RC, ap.cfg)
        assert [p.param for p in problems] == ["SYSID_MYGCS"]
        assert f"set SYSID_MYGCS = {HELIXD_SYSID} (currently 254)" in problems[0].message


def test_ardupilot_default_gcs_id_is_never_offered_as_the_way_out() -> None:
    text = messages({**GOOD_RC, "MAV_GCS_SYSID": 255.0})
    assert text == [
        f"error: RC overrides from helixd would be silently ignored: set MAV_GCS_SYSID = "
        f"{HELIXD_SYSID} (currently 255); 255 is the default id of QGroundControl/Mission "
        f"Planner/MAVProxy, which helixd must not share"
    ]


def test_gcs_sysid_range_as_ardupilot_reads_it() -> None:
    # MAV_GCS_SYSID_HI <= MAV_GCS_SYSID: a single id (GCS::sysid_is_gcs)
    assert messages({**GOOD_RC, "MAV_GCS_SYSID_HI": float(HELIXD_SYSID - 1)}) == []
    wide = messages({**GOOD_RC, "MAV_GCS_SYSID": 240.0, "MAV_GCS_SYSID_HI": 255.0})
    assert len(wide) == 1 and wide[0].startswith("warning: MAV_GCS_SYSID_HI = 255 makes every")
    outside = messages({**GOOD_RC, "MAV_GCS_SYSID": 250.0, "MAV_GCS_SYSID_HI": 255.0})
    assert "and MAV_GCS_SYSID_HI = 0 (currently 255)" in outside[0]


def test_helixd_on_a_ground_station_id_is_warned() -> None:
    link = LinkConfig(source_system=255)
    problems = judge({**GOOD_RC, "MAV_GCS_SYSID": 255.0}, RC, link)
    assert [p.severity for p in problems] == ["warning"]
    assert "link.source_system = 255 is the default system id of QGroundControl" in str(problems[0])


async def test_another_sender_on_our_id_is_refused() -> None:
    async with linked(command_timeout_s=0.15, command_retries=1) as (ap, peer):
        peer.params.update({f"SERVO{n}_FUNCTION": 50.0 + n for n in range(1, 5)})
        ap.start_heartbeat()  # the autopilot knows us from now on
        for _ in range(2):  # a ground station left on helixd's id, forwarded by the autopilot
            peer.send_as(HELIXD_SYSID, 190, lambda c: c.heartbeat_encode(6, 8, 0, 0, 4))
        problems = await check_obedience(ap, RC, ap.cfg)
        assert [p.severity for p in problems] == ["error"]
        text = str(problems[0])
        assert f"another sender uses helixd's system id {HELIXD_SYSID}" in text
        assert "component 190" in text and "HEARTBEAT type GCS" in text
        assert not ap.state.foreign_sysid_counts  # not mistaken for another vehicle


# --- helixd-guard -----------------------------------------------------------------------------

GOOD_SERVO = {
    "MAV_GCS_SYSID": float(HELIXD_SYSID),
    "FS_GCS_ENABLE": 1.0,
    **{f"SERVO{n}_FUNCTION": 0.0 for n in range(1, 5)},
    "SCR_ENABLE": 1.0,
    **GUARD_DEFAULTS,
}
NO_GUARD = {"HXG_VERSION": None, "HXG_ENABLE": None, "HXG_TIMEOUT": None}


def test_the_default_guard_passes_both_backends() -> None:
    assert messages(GOOD_SERVO, SERVO) == []
    assert messages(GOOD_RC, RC) == []


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (
            {**NO_GUARD, "SCR_ENABLE": 0.0},
            "helixd-guard does not run on the autopilot (no HXG_VERSION parameter); "
            "SCR_ENABLE = 0: a killed helixd leaves the DO_SET_SERVO outputs driving; install "
            "it with `helixd autopilot install-guard --connect URL` and reboot the autopilot",
        ),
        (
            {**NO_GUARD, "SCR_ENABLE": None},
            "; the autopilot has no SCR_ENABLE: its firmware has no Lua scripting:",
        ),
        (
            {"HXG_VERSION": 2.0},
            "helixd-guard v2 runs on the autopilot, this helixd needs v1: install it with",
        ),
        ({"HXG_ENABLE": 0.0}, "HXG_ENABLE = 0: helixd-guard is off and a killed helixd"),
        (
            {"HXG_CHAN2": 0.0, "HXG_CHAN4": 1.0},
            "helixd-guard does not guard scroll outputs 2, 4 (HXG_CHAN1..4 = 1, 0, 3, 1): set "
            "HXG_CHAN1..4 = 1, 2, 3, 4",
        ),
        (
            {"HXG_TIMEOUT": 0.3},
            "link.heartbeat_rate_hz = 5 is too slow for helixd-guard's HXG_TIMEOUT = 0.3 s: one "
            "lost HEARTBEAT leaves helixd silent for 0.40 s and the guard would stop the rover "
            "mid-mission; set link.heartbeat_rate_hz >= 8.33333 or HXG_TIMEOUT >= 0.5",
        ),
    ],
    ids=["missing", "no_scripting", "other_version", "disabled", "unguarded", "slow_heartbeat"],
)
def test_servo_backend_refuses_without_a_working_guard(
    change: dict[str, float | None], says: str
) -> None:
    params = {**GOOD_SERVO, **change}
    problems = judge(params, SERVO, LINK)
    assert len(problems) == 1, problems
    assert problems[0].severity == "error"
    assert says in problems[0].message
    warned = judge(params, SERVO, LINK, servo_guard="warn")
    assert [(p.severity, p.message) for p in warned] == [("warning", problems[0].message)]


def test_rc_override_backend_only_warns_about_the_guard() -> None:
    missing = messages({**GOOD_RC, **NO_GUARD})
    assert len(missing) == 1
    assert missing[0].startswith("warning: helixd-guard does not run on the autopilot")
    assert "a killed helixd's RC overrides drive on until RC_OVERRIDE_TIME" in missing[0]
    assert messages({**GOOD_RC, "HXG_ENABLE": 0.0})[0].startswith("warning: HXG_ENABLE = 0")


def test_heartbeat_rate_rule() -> None:
    """period × 2.5 ≤ HXG_TIMEOUT: 5 Hz fits the default 0.5 s, 4 Hz and the old 1 Hz do not;
    the RC-override backend's 20 Hz overrides refresh the guard as well."""
    assert LinkConfig().heartbeat_rate_hz == 5.0
    for rate, ok in ((5.0, True), (4.0, False), (1.0, False), (10.0, True)):
        link = LinkConfig(heartbeat_rate_hz=rate)
        assert (judge(GOOD_SERVO, SERVO, link) == []) is ok, rate
        assert judge(GOOD_RC, RC, link) == []  # overrides at 20 Hz: 0.125 s ≤ 0.5 s
    slow = LinkConfig(heartbeat_rate_hz=1.0)
    assert judge({**GOOD_SERVO, "HXG_TIMEOUT": 2.5}, SERVO, slow) == []
    tight = [str(p) for p in judge({**GOOD_RC, "HXG_TIMEOUT": 0.1}, RC, slow)]
    assert len(tight) == 1 and tight[0].startswith("warning: link.heartbeat_rate_hz = 1 is too")


def test_scroll_outputs_above_16_cannot_be_guarded() -> None:
    high = ActuationConfig(
        backend=ActuationBackend.SERVO, channels=(ChannelConfig(channel=17), *SERVO.channels[1:])
    )
    text = messages({**GOOD_SERVO, "SERVO17_FUNCTION": 0.0}, high)
    assert text == [
        "error: helixd-guard does not guard scroll output 17 (HXG_CHAN1..4 = 1, 2, 3, 4): drive "
        "the scrolls on outputs 1..16, which the guard can hold"
    ]


async def test_guard_read_from_the_autopilot() -> None:
    async with linked(command_timeout_s=0.15, command_retries=1) as (ap, peer):
        peer.params.update({"HXG_CHAN3": 0.0})
        problems = await check_obedience(ap, SERVO, ap.cfg)
        assert [(p.severity, p.param) for p in problems] == [("error", "HXG_CHAN1")]
        for name in GUARD_DEFAULTS:
            del peer.params[name]
        problems = await check_obedience(ap, SERVO, ap.cfg, "warn")
        assert [(p.severity, p.param) for p in problems] == [("warning", "HXG_VERSION")]
