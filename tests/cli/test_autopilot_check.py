"""``helixd autopilot check`` against the simulator over UDP: the Helix defaults (scrolls on
RCIN1-4, SERVO16 = Script1) pass; without the spare output it names what to set, exit 3."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.cli import FAST_CONNECT, autopilot_verb, config_file, run_main
from tests.support.harness import running_sim

FAST = FAST_CONNECT + "link:\n  command_timeout_s: 0.3\n"


def test_the_simulators_helix_setup_passes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim() as (_, url):
        code, out, err = autopilot_verb(tmp_path, "check", url, capsys, config=FAST)
    assert code == 0, out + err
    assert (
        "ok      arming (motor outputs): a normal arm passes the motor-output check "
        "(SERVO16_FUNCTION = 94 (Script1))"
    ) in out
    assert "ok      arming (checks): ARMING_SKIPCHK = 0: every PreArm check is made" in out
    assert "ok      GCS system id: MAV_GCS_SYSID = 247 is helixd's link.source_system" in out
    assert "RC passthrough, as the rc_override backend needs" in out
    assert "a normal arm is possible (no force)" in out


def test_without_the_spare_output_it_says_what_to_set(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim(params={"SERVO16_FUNCTION": 0, "MAV_GCS_SYSID": 255}) as (_, url):
        code, out, err = autopilot_verb(tmp_path, "check", url, capsys, config=FAST)
    assert code == int(ExitCode.PREFLIGHT), out + err
    assert (
        "error   arming (motor outputs): a normal arm is refused: 'PreArm: no motor, sail or "
        "scripting outputs defined'; set SERVO16_FUNCTION = 94 (Script1)"
    ) in out
    assert "error   GCS system id:" in out and "set MAV_GCS_SYSID = 247" in out
    assert "not ready" in out


def test_sim_flag_checks_the_built_in_simulator(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run_main(
        ["autopilot", "check", "--sim", "--config", config_file(tmp_path, FAST)], capsys
    )
    assert code == 0, out + err
    assert "ok      helixd-guard: v1 runs and guards every scroll" in out


def test_sim_and_connect_exclude_each_other(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_main(["autopilot", "check", "--sim", "--connect", "udpin:0.0.0.0:1"], capsys)
    assert code == int(ExitCode.USAGE)
    assert "--sim and --connect exclude each other" in err


def test_a_throttle_switch_resting_high_is_named_with_what_it_must_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """RCMAP_THROTTLE = 5 as the check asks, the radio's switch on RC5 resting high: the
    check says the arm would be refused and what RC5 must read — not force."""
    rc = (1500,) * 4 + (1900,) + (1500,) * 11
    with running_sim(pilot_rc_us=rc, params={"RC5_DZ": 30}) as (server, url):
        server.wait_for(lambda s: not s.booting, 30.0)  # RC inputs read 0 while it boots
        code, out, err = autopilot_verb(tmp_path, "check", url, capsys, config=FAST)
    assert code == int(ExitCode.PREFLIGHT), out + err
    assert (
        "error   arming (throttle): a normal arm is refused: 'Arm: Throttle (RC5) is not "
        "neutral'; RC5 (RCMAP_THROTTLE) must read its trim RC5_TRIM = 1500 µs ± RC5_DZ = 30 µs "
        "(1470–1530 µs) to arm; it reads 1900 µs"
    ) in out
    assert "force" not in out
