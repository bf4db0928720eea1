"""``helixd autopilot setup --file config/ardupilot/helix.parm`` against the simulator over
UDP: the difference shown, the values set, the reboot named, the check run after."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.cli import run_main
from tests.support.harness import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_RESULT_ACCEPTED,
    MavClient,
    client,
    running_sim,
)
from tests.support.paths import REPO_ROOT

FAST = "startup:\n  connect_timeout_s: 5.0\nlink:\n  command_timeout_s: 0.3\n"
HELIX_PARM = str(REPO_ROOT / "config" / "ardupilot" / "helix.parm")
# an autopilot not yet set up for helixd: ground stations' GCS id, throttle on RC3, no spare
NOT_SET_UP = {"MAV_GCS_SYSID": 255.0, "RCMAP_THROTTLE": 3.0, "SERVO16_FUNCTION": 0.0}


ARM_WITHIN_S = 10.0


def arm_normally(gcs: MavClient) -> None:
    """A normal arm (every PreArm check), asked again while the simulator's EKF still starts."""
    deadline = time.monotonic() + ARM_WITHIN_S
    while gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) != MAV_RESULT_ACCEPTED:
        assert time.monotonic() < deadline, f"not armed within {ARM_WITHIN_S} s: {gcs.texts[-3:]}"


def config(tmp_path: Path) -> str:
    path = tmp_path / "helixd.yaml"
    path.write_text(FAST, encoding="utf-8")
    return str(path)


def setup(url: str, tmp_path: Path, *extra: str) -> list[str]:
    return ["autopilot", "setup", "--connect", url, "--config", config(tmp_path), *extra]


def test_shows_sets_names_the_reboot_and_checks(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim(params=NOT_SET_UP) as (_, url):
        code, out, err = run_main(setup(url, tmp_path, "--file", HELIX_PARM, "--yes"), capsys)
        assert code == 0, out + err
        # the three above, RC1..5's range (ArduPilot's default 1100..1900), FS_GCS_ENABLE and
        # SCR_ENABLE (off in these tests' simulator)
        assert "15 parameters to set:" in out
        assert "MAV_GCS_SYSID             255 → 247" in out
        assert "RCMAP_THROTTLE              3 → 5  (after a reboot)" in out
        assert "SERVO16_FUNCTION            0 → 94" in out
        assert "set 15 of 15" in out
        assert "reboot the autopilot: RCMAP_THROTTLE, SCR_ENABLE take effect at boot" in out
        assert "a normal arm is possible (no force)" in out
        assert "ok      arming (throttle):" in out  # the check's every line, RC5 read too
        # a second run finds nothing to change
        code, out, err = run_main(setup(url, tmp_path, "--file", HELIX_PARM, "--yes"), capsys)
        assert code == 0, out + err
        assert "every parameter already has the file's value" in out
        assert "to set" not in out


def test_without_a_terminal_it_asks_for_yes_and_sets_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim(params=NOT_SET_UP) as (_, url):
        code, out, err = run_main(setup(url, tmp_path, "--file", HELIX_PARM), capsys)
        assert code == int(ExitCode.USAGE), out + err
        assert "run it again with --yes" in err
        code, out, err = run_main(
            ["autopilot", "check", "--connect", url, "-c", config(tmp_path)], capsys
        )
    assert code == int(ExitCode.PREFLIGHT)  # still not set up
    assert "set MAV_GCS_SYSID = 247" in out


def test_refused_while_armed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # armed normally (the spare output is there), then asked to change the GCS id
    with running_sim(params={"MAV_GCS_SYSID": 255.0}) as (_, url), client(url) as gcs:
        gcs.expect("HEARTBEAT", 10.0, lambda m: int(m.custom_mode) == 0)  # booted: MANUAL
        arm_normally(gcs)
        code, out, err = run_main(setup(url, tmp_path, "--file", HELIX_PARM, "--yes"), capsys)
    assert code == int(ExitCode.PREFLIGHT), out + err
    assert "the autopilot is armed: disarm before changing its parameters" in err
    assert "to set" not in out


def test_a_bad_file_is_named_by_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.parm"
    bad.write_text("SERVO1_FUNCTION 51\nRCMAP_THROTTLE five\n", encoding="utf-8")
    code, _, err = run_main(
        ["autopilot", "setup", "--connect", "udpin:127.0.0.1:1", "--file", str(bad)], capsys
    )
    assert code == int(ExitCode.USAGE)
    assert f"error: {bad}:2: RCMAP_THROTTLE = 'five' is not a number" in err


def test_reboot_reboots_the_autopilot_when_a_parameter_needs_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: setup said "reboot the autopilot" but had no way to; `--reboot` sends
    MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN after the check, and the simulator reboots."""
    with running_sim(params=NOT_SET_UP) as (server, url):
        args = setup(url, tmp_path, "--file", HELIX_PARM, "--yes", "--reboot")
        code, out, err = run_main(args, capsys)
        assert code == 0, out + err
        assert "MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (246) param1=1" in out
        assert "the autopilot accepted the reboot: RCMAP_THROTTLE, SCR_ENABLE take effect" in out
        assert "ok      arming (throttle):" in out  # checked before the reboot
        server.wait_for(lambda s: server.history.first("reboot") is not None, 10.0)
        # nothing left to set: no reboot asked for again
        code, out, err = run_main(args, capsys)
        assert code == 0, out + err
        assert "every parameter already has the file's value" in out and "246" not in out
