"""``helixd autopilot install-guard`` against the simulator over UDP: the file lands where
ArduPilot loads scripts from, SCR_ENABLE is set, and after a reboot the guard runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.mav.arming import FORCE_ARM_MAGIC
from helixd.mav.constants import MAV_CMD_COMPONENT_ARM_DISARM
from helixd.mav.guard_script import VERSION, script_bytes
from tests.support.cli import autopilot_verb, run_main
from tests.support.harness import client, running_sim, running_sim_links


def test_install_then_reboot_runs_the_guard(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim() as (server, url):
        assert server.snapshot().params["SCR_ENABLE"] == 0.0
        code, out, err = autopilot_verb(tmp_path, "install-guard", url, capsys)
        assert code == 0, err
        # SITL layout (no /APM): ./scripts in the autopilot's working directory
        assert (server.workdir / "scripts" / "helixd-guard.lua").read_bytes() == script_bytes()
        assert f"helixd-guard v{VERSION} → {url} scripts/helixd-guard.lua" in out
        assert "found on the autopilot" in out
        assert "SCR_ENABLE = 1 (was 0)" in out
        assert "reboot the autopilot to load it" in out and "no helixd-guard runs yet" in out
        snap = server.snapshot()
        assert snap.params["SCR_ENABLE"] == 1.0
        assert snap.guard_version is None  # scripts load at boot only
        server.inject("reboot")
        snap = server.wait_for(lambda s: s.guard_version is not None, 20.0)
        assert snap.guard_version == VERSION
        assert snap.params["HXG_VERSION"] == VERSION and snap.params["HXG_ENABLE"] == 1.0
        code, out, err = autopilot_verb(tmp_path, "install-guard", url, capsys)
        assert code == 0, err
        assert "SCR_ENABLE = 1 (already set)" in out
        assert f"helixd-guard v{VERSION} runs until then" in out


def test_an_sd_card_layout_gets_apm_scripts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    workdir = tmp_path / "card"
    (workdir / "APM" / "LOGS").mkdir(parents=True)  # an SD card where scripting never ran
    with running_sim(workdir=workdir) as (_, url):
        code, out, err = autopilot_verb(tmp_path, "install-guard", url, capsys)
    assert code == 0, err
    assert (workdir / "APM" / "scripts" / "helixd-guard.lua").read_bytes() == script_bytes()
    assert " /APM/scripts/helixd-guard.lua (" in out


def test_a_given_scripts_dir_is_used(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    workdir = tmp_path / "ap"
    with running_sim(workdir=workdir) as (_, url):
        code, out, err = autopilot_verb(
            tmp_path, "install-guard", url, capsys, "--scripts-dir", "/APM/scripts/"
        )
    assert code == 0, err
    assert (workdir / "APM" / "scripts" / "helixd-guard.lua").is_file()
    assert "scripts directory as given" in out


def test_a_refused_upload_exits_3_naming_the_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim() as (server, url):
        code, _, err = autopilot_verb(
            tmp_path, "install-guard", url, capsys, "--scripts-dir", "@ROMFS/scripts"
        )
        assert server.snapshot().params["SCR_ENABLE"] == 0.0  # nothing set after a refusal
    assert code == ExitCode.PREFLIGHT
    assert err.strip().splitlines() == [
        f"error: {url}: FTP upload of @ROMFS/scripts/helixd-guard.lua: CreateFile refused: "
        "FailErrno (errno 30 EROFS)"
    ]


def test_a_bad_scripts_dir_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_main(
        ["autopilot", "install-guard", "--connect", "udpout:127.0.0.1:9", "--scripts-dir", "ü"],
        capsys,
    )
    assert code == ExitCode.USAGE
    assert "--scripts-dir: FTP path" in err and "only ASCII names are sent" in err


def test_reboot_installs_then_reboots_and_the_guard_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: install-guard said a reboot was needed and could not do it. ``--reboot``
    sends MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1=1 (printed); the simulator ACKs, goes
    silent, boots again and loads the guard."""
    with running_sim() as (server, url):
        code, out, err = autopilot_verb(tmp_path, "install-guard", url, capsys, "--reboot")
        assert code == 0, err
        assert (
            "sending COMMAND_LONG MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (246) param1=1 (reboot the "
            "autopilot) to system 1 component 1"
        ) in out
        assert "the autopilot accepted the reboot" in out
        snap = server.wait_for(lambda s: s.guard_version is not None, 20.0)
        assert snap.guard_version == VERSION
        reboots = server.history.entries("reboot")
        assert len(reboots) == 1


def test_reboot_is_refused_while_armed_and_nothing_is_installed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with running_sim_links(["udpin:127.0.0.1:0", "udpin:127.0.0.1:0"]) as server:
        ours, gcs_url = (f"udpout:127.0.0.1:{p}" for p in server.local_ports)
        with client(gcs_url, sysid=255) as gcs:
            gcs.heartbeat()
            server.wait_for(lambda s: s.home_ne_m is not None and not s.booting, 20.0)
            assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM_MAGIC) == 0
            code, out, err = autopilot_verb(tmp_path, "install-guard", ours, capsys, "--reboot")
        assert server.snapshot().armed
        assert not (server.workdir / "scripts" / "helixd-guard.lua").exists()
    assert code == ExitCode.PREFLIGHT
    assert "MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN" not in out
    assert "the autopilot is armed: --reboot only while disarmed (nothing installed)" in err


def test_a_simulator_with_a_state_dir_remembers_the_installed_guard_across_a_restart(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: `helixd sim` forgot an installed guard when restarted (a fresh temporary
    directory each time). With a working directory of its own (``--state-dir``) the script
    and the parameters set (SCR_ENABLE, as SITL's eeprom.bin) survive: the restarted
    simulator boots with the guard running."""
    state = tmp_path / "ap"
    with running_sim(workdir=state) as (server, url):
        code, _, err = autopilot_verb(tmp_path, "install-guard", url, capsys)
        assert code == 0, err
        assert server.snapshot().params["SCR_ENABLE"] == 1.0
    with running_sim(workdir=state) as (server, _):
        snap = server.wait_for(lambda s: s.guard_version is not None, 20.0)
        assert snap.guard_version == VERSION
        assert snap.params["SCR_ENABLE"] == 1.0
    with running_sim() as (server, _):  # a fresh temporary directory: nothing remembered
        assert server.snapshot().params["SCR_ENABLE"] == 0.0


def test_sim_state_dir_is_the_simulators_working_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    state = tmp_path / "state"
    code, _, err = run_main(
        ["sim", "--listen", "udpin:127.0.0.1:0", "--speedup", "10", "--duration", "3",
         "--state-dir", str(state)],
        capsys,
    )  # fmt: skip
    assert code == 0, err
    assert state.is_dir()  # kept: not a temporary directory removed at stop
