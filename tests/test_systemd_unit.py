"""systemd/helixd@.service, systemd/helixd.{sysusers,tmpfiles}.conf and tools/install.sh.

The unit is checked twice: structurally (always — parsed here, see ``parse_unit``) and, when
``systemd-analyze`` is installed (Debian's ``systemd`` package), by systemd itself with
``systemd-analyze verify`` on the instance ``helixd@square.service``. Where the tool is absent
(a minimal CI image) the verify tests fall back to the structural checks instead of skipping.
The same pattern applies to ``systemd-sysusers`` / ``systemd-tmpfiles``.

Nothing here touches the host: install.sh runs with ``--dry-run`` or into a temporary
``--root``, where users go into that root's own /etc/passwd.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.config.load import load_config
from helixd.config.root import HelixdConfig
from tests.support.paths import REPO_ROOT

REPO = REPO_ROOT
UNIT = REPO / "systemd" / "helixd@.service"
SYSUSERS = REPO / "systemd" / "helixd.sysusers.conf"
TMPFILES = REPO / "systemd" / "helixd.tmpfiles.conf"
INSTALL = REPO / "tools" / "install.sh"
INSTALLED_EXEC = "/opt/helixd/venv/bin/helixd"
TOOL_TIMEOUT_S = 60.0

Unit = dict[str, dict[str, list[str]]]


def parse_unit(text: str) -> Unit:
    """Sections → key → every value, in order.

    Not configparser: a unit repeats keys (DeviceAllow=, SystemCallFilter=) and configparser
    either rejects duplicates (strict) or keeps only the last one; both would hide mistakes.
    Backslash line continuations are joined as systemd does.
    """
    unit: Unit = {}
    section: dict[str, list[str]] | None = None
    text = re.sub(r"\\\n", " ", text)
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith(("#", ";")):
            continue
        if line.startswith("[") and line.endswith("]"):
            section = unit.setdefault(line[1:-1], {})
            continue
        assert section is not None, f"key outside a section: {line!r}"
        key, sep, value = line.partition("=")
        assert sep, f"not key=value: {line!r}"
        section.setdefault(key.strip(), []).append(value.strip())
    return unit


def one(unit: Unit, section: str, key: str) -> str:
    values = unit[section][key]
    assert len(values) == 1, f"{section}.{key} set {len(values)} times: {values}"
    return values[0]


def seconds(value: str) -> float:
    match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*(s|sec|min|ms)?", value)
    assert match, f"not a simple time span: {value!r}"
    scale = {"ms": 0.001, "min": 60.0}.get(match.group(2) or "s", 1.0)
    return float(match.group(1)) * scale


# How a run can end → must systemd start the mission again by itself?
# ("exit", n) is exit(n); ("signal", name) a death by signal; ("watchdog", "SIGABRT") is
# systemd's watchdog killing a hung daemon.
Ending = tuple[str, str]
EXPECTED_RESTART: dict[Ending, bool] = {
    ("exit", str(int(ExitCode.OK))): False,
    ("exit", str(int(ExitCode.INTERNAL_ERROR))): False,  # fall-back ran mid-mission
    ("exit", str(int(ExitCode.USAGE))): False,
    ("exit", str(int(ExitCode.PREFLIGHT))): False,
    ("exit", str(int(ExitCode.FAULT))): False,
    ("exit", str(int(ExitCode.OPERATOR_STOP))): False,
    ("exit", str(int(ExitCode.LINK))): True,  # autopilot not up yet; nothing was armed
    ("watchdog", "SIGABRT"): False,
    ("signal", "SIGKILL"): False,  # e.g. OOM kill mid-mission
    ("signal", "SIGSEGV"): False,
    ("signal", "SIGTERM"): False,
}
CLEAN_SIGNALS = {"SIGHUP", "SIGINT", "SIGTERM", "SIGPIPE"}  # systemd: a clean death


def would_restart(unit: Unit, ending: Ending) -> bool:
    """systemd's service_shall_restart() (src/core/service.c) for an unrequested ending.

    Order as in systemd: RestartPreventExitStatus= wins, then RestartForceExitStatus=,
    then Restart= applied to the result (exit 0/SuccessExitStatus=/clean signal = success).
    """
    kind, status = ending

    def listed(key: str) -> bool:
        return status in " ".join(unit["Service"].get(key, [])).split()

    if listed("RestartPreventExitStatus"):
        return False
    if listed("RestartForceExitStatus"):
        return True
    if kind == "exit":
        success = status == "0" or listed("SuccessExitStatus")
    else:
        success = kind == "signal" and (status in CLEAN_SIGNALS or listed("SuccessExitStatus"))
    restart = one(unit, "Service", "Restart")
    if restart == "no":
        return False
    if restart == "always":
        return True
    if restart == "on-success":
        return success
    if restart == "on-failure":
        return not success
    if restart == "on-abnormal":
        return not success and kind != "exit"
    if restart == "on-watchdog":
        return kind == "watchdog"
    if restart == "on-abort":
        return kind != "exit" and not success
    raise AssertionError(f"unknown Restart={restart}")


def stops_and_restarts_safely(
    unit: Unit, cfg: HelixdConfig, expected_restart: dict[Ending, bool]
) -> None:
    """SIGKILL must not cut the bounded fall-back (neutral+release+HOLD, HOLD retries) short;
    the unit restarts after each ending as ``expected_restart`` says."""
    fallback_s = cfg.safety.fallback_deadline_s + cfg.safety.hold_retry_bound_s
    assert seconds(one(unit, "Service", "TimeoutStopSec")) >= 2.0 * fallback_s
    assert one(unit, "Service", "KillSignal") in {"SIGINT", "SIGTERM"}
    for ending, expected in expected_restart.items():
        assert would_restart(unit, ending) is expected, ending


def notify_service_running(unit: Unit, args: str) -> None:
    """A Type=notify service (helixd's main process only may notify) running the installed
    helixd with ``args``."""
    assert one(unit, "Service", "Type") == "notify"
    assert one(unit, "Service", "NotifyAccess") == "main"
    assert one(unit, "Service", "ExecStart") == f"{INSTALLED_EXEC} {args}"


def check_unit_structure(unit: Unit) -> None:
    """Every requirement of the brief, asserted on the parsed unit."""
    svc = unit["Service"]
    notify_service_running(
        unit,
        "run --mission /etc/helixd/missions/%i.yaml "
        "--config /etc/helixd/helixd.yaml --run-dir /var/lib/helixd/runs",
    )
    environment = " ".join(svc["Environment"]).split()
    assert "PYTHONUNBUFFERED=1" in environment
    assert "PYTHONFAULTHANDLER=1" in environment  # stack dump when the watchdog aborts us

    cfg = load_config(REPO / "config" / "helixd.yaml")
    watchdog_s = seconds(one(unit, "Service", "WatchdogSec"))
    assert 1.0 <= watchdog_s <= 30.0
    # time to READY covers waiting for the autopilot's first heartbeat, then preflight
    assert seconds(one(unit, "Service", "TimeoutStartSec")) >= 2 * cfg.startup.connect_timeout_s
    # Restart only what is safe: never after a fault, an operator stop or a refusal.
    stops_and_restarts_safely(unit, cfg, EXPECTED_RESTART)
    prevented = set(one(unit, "Service", "RestartPreventExitStatus").split())
    must_not_restart = {ExitCode.USAGE, ExitCode.PREFLIGHT, ExitCode.FAULT}
    must_not_restart |= {ExitCode.OPERATOR_STOP, ExitCode.INTERNAL_ERROR}
    assert {str(int(code)) for code in must_not_restart} <= prevented
    assert "SIGABRT" in prevented  # a watchdog kill is a fault too
    assert str(int(ExitCode.LINK)) not in prevented  # autopilot not up yet: retry
    assert str(int(ExitCode.OK)) not in prevented
    # `systemctl stop` → exit 5 must not leave the unit "failed"
    assert one(unit, "Service", "SuccessExitStatus").split() == [str(int(ExitCode.OPERATOR_STOP))]
    # start limits live in [Unit]; systemd ignores them in [Service]
    assert "StartLimitBurst" not in svc and "StartLimitIntervalSec" not in svc
    assert 1 <= int(one(unit, "Unit", "StartLimitBurst")) <= 10
    assert seconds(one(unit, "Unit", "StartLimitIntervalSec")) > 0

    assert one(unit, "Service", "User") == "helixd"
    assert "dialout" in one(unit, "Service", "SupplementaryGroups").split()
    assert one(unit, "Service", "StateDirectory") == "helixd"
    assert one(unit, "Service", "UMask") == "0027"
    assert one(unit, "Service", "CapabilityBoundingSet") == ""
    for key in (
        "NoNewPrivileges",
        "ProtectHome",
        "PrivateTmp",
        "ProtectKernelTunables",
        "ProtectKernelModules",
        "ProtectControlGroups",
        "RestrictNamespaces",
        "LockPersonality",
        "MemoryDenyWriteExecute",
    ):
        assert one(unit, "Service", key) == "yes", key
    assert one(unit, "Service", "ProtectSystem") == "strict"
    assert one(unit, "Service", "PrivateDevices") == "no"  # needs the serial port
    assert one(unit, "Service", "DevicePolicy") == "closed"
    allowed = set(svc["DeviceAllow"])
    assert {"char-ttyACM rw", "char-ttyUSB rw"} <= allowed
    assert not any("*" in entry for entry in allowed)  # systemd does not glob paths
    families = set(one(unit, "Service", "RestrictAddressFamilies").split())
    assert families == {"AF_UNIX", "AF_INET", "AF_INET6"}
    assert "@system-service" in svc["SystemCallFilter"]
    assert one(unit, "Install", "WantedBy") == "multi-user.target"


def test_unit_structure() -> None:
    check_unit_structure(parse_unit(UNIT.read_text()))


@pytest.mark.parametrize(
    ("restart", "prevent"),
    [
        ("no", "2 3"),  # RestartForceExitStatus=4 6 below: a fault (4) would be retried
        ("on-failure", "1 2 3 4 5 SIGABRT"),  # restarts after an OOM kill mid-mission
        ("on-failure", "2 3 4 5"),  # ... and after an internal error
        ("always", "1 2 3 4 5 SIGABRT"),
    ],
)
def test_structure_check_catches_a_dangerous_restart_policy(restart: str, prevent: str) -> None:
    """The structural check is not vacuous: each of these would re-drive a faulted rover."""
    text = re.sub(r"(?m)^Restart=.*$", f"Restart={restart}", UNIT.read_text())
    text = re.sub(r"(?m)^RestartPreventExitStatus=.*$", f"RestartPreventExitStatus={prevent}", text)
    text = text.replace("RestartForceExitStatus=6", "RestartForceExitStatus=4 6")
    with pytest.raises(AssertionError):
        check_unit_structure(parse_unit(text))


def test_restart_model_matches_systemd_rules() -> None:
    """The model itself: the unit as the brief first sketched it restarts after SIGKILL."""
    sketch = parse_unit(
        "[Service]\nRestart=on-failure\nRestartPreventExitStatus=2 3 4 5\nSuccessExitStatus=5\n"
    )
    assert would_restart(sketch, ("signal", "SIGKILL"))
    assert would_restart(sketch, ("exit", "1"))
    assert would_restart(sketch, ("exit", "6"))
    assert not would_restart(sketch, ("exit", "4"))
    assert not would_restart(sketch, ("signal", "SIGTERM"))  # clean signal
    assert not would_restart(sketch, ("exit", "0"))


def verifiable_copy(tmp_path: Path, text: str) -> Path:
    """helixd@square.service in tmp_path: ExecStart on a binary that exists here."""
    executable = shutil.which("true")
    assert executable is not None
    assert INSTALLED_EXEC in text
    (tmp_path / "helixd@.service").write_text(text.replace(INSTALLED_EXEC, executable))
    instance = tmp_path / "helixd@square.service"
    instance.symlink_to("helixd@.service")
    return instance


def systemd_analyze(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["systemd-analyze", *args],
        capture_output=True,
        text=True,
        timeout=TOOL_TIMEOUT_S,
        check=False,
    )


def test_unit_passes_systemd_analyze_verify(tmp_path: Path) -> None:
    if shutil.which("systemd-analyze") is None:
        # Fallback documented above: no systemd tools on this machine.
        check_unit_structure(parse_unit(UNIT.read_text()))
        return
    instance = verifiable_copy(tmp_path, UNIT.read_text())
    result = systemd_analyze("verify", str(instance))
    # verify exits 0 even for unknown keys/bad values; those are printed, so any line that
    # names our unit is a finding (other lines can come from the host's own units).
    ours = [line for line in result.stderr.splitlines() if "helixd@" in line]
    assert result.returncode == 0, result.stderr
    assert ours == []


def test_systemd_analyze_verify_would_catch_mistakes(tmp_path: Path) -> None:
    """Proves the verify test above can fail: a typo and a bad value are reported."""
    if shutil.which("systemd-analyze") is None:
        text = UNIT.read_text().replace("Type=notify", "Type=simple")
        with pytest.raises(AssertionError):
            check_unit_structure(parse_unit(text))
        return
    text = UNIT.read_text().replace("WatchdogSec=", "WatchdogSecs=")
    text = re.sub(r"(?m)^(RestartPreventExitStatus=.*)$", r"\1 SIGNOPE", text)
    result = systemd_analyze("verify", str(verifiable_copy(tmp_path, text)))
    assert "Unknown key 'WatchdogSecs'" in result.stderr
    assert "SIGNOPE" in result.stderr
    # and the real ExecStart must exist for verify — which is why we verify a copy
    missing = tmp_path / "missing"
    missing.mkdir()
    (missing / "helixd@.service").write_text(UNIT.read_text())
    (missing / "helixd@square.service").symlink_to("helixd@.service")
    if not Path(INSTALLED_EXEC).exists():
        result = systemd_analyze("verify", str(missing / "helixd@square.service"))
        assert result.returncode != 0
        assert "not executable" in result.stderr


def test_unit_hardening_exposure_is_low(tmp_path: Path) -> None:
    """`systemd-analyze security --offline` score (0 best … 10 worst); 1.5 when written."""
    if shutil.which("systemd-analyze") is None:
        check_unit_structure(parse_unit(UNIT.read_text()))
        return
    instance = verifiable_copy(tmp_path, UNIT.read_text())
    result = systemd_analyze("security", "--offline=yes", "--no-pager", str(instance))
    match = re.search(
        r"Overall exposure level for helixd@square\.service: (\d+\.\d)", result.stdout
    )
    if result.returncode != 0 and "--offline" in result.stderr:
        # systemd < 250 has no offline mode: the structural check is what we can do
        check_unit_structure(parse_unit(UNIT.read_text()))
        return
    assert match is not None, result.stdout + result.stderr
    assert float(match.group(1)) <= 2.5


# ---------------------------------------------------------------------------------------------
# helixd.service: helixd serve, all day

SERVE_UNIT = REPO / "systemd" / "helixd.service"
# helixd serve comes back idle (it never moves on its own): restarting after a crash is safe
SERVE_EXPECTED_RESTART: dict[Ending, bool] = {
    ("exit", str(int(ExitCode.OK))): False,  # stopped by systemctl stop
    ("exit", str(int(ExitCode.INTERNAL_ERROR))): True,
    ("exit", str(int(ExitCode.USAGE))): False,  # bad config: a human must fix it
    ("watchdog", "SIGABRT"): True,
    ("signal", "SIGKILL"): True,
    ("signal", "SIGSEGV"): True,
    ("signal", "SIGTERM"): False,
}


def check_serve_unit(unit: Unit) -> None:
    svc = unit["Service"]
    notify_service_running(
        unit, "serve --config /etc/helixd/helixd.yaml --run-dir /var/lib/helixd/runs"
    )
    cfg = load_config(REPO / "config" / "helixd.yaml")
    # the liveness task pings every serve.tick_s: several pings per watchdog period
    assert seconds(one(unit, "Service", "WatchdogSec")) >= 10 * cfg.serve.tick_s
    stops_and_restarts_safely(unit, cfg, SERVE_EXPECTED_RESTART)
    assert "StartLimitBurst" not in svc
    assert 1 <= int(one(unit, "Unit", "StartLimitBurst")) <= 10
    # the same identity and hardening as the one-shot unit
    one_shot = parse_unit(UNIT.read_text())["Service"]
    for key in (
        "User",
        "SupplementaryGroups",
        "StateDirectory",
        "UMask",
        "CapabilityBoundingSet",
        "ProtectSystem",
        "DevicePolicy",
        "DeviceAllow",
        "RestrictAddressFamilies",
        "SystemCallFilter",
        "MemoryDenyWriteExecute",
        "NoNewPrivileges",
    ):
        assert svc[key] == one_shot[key], key
    assert one(unit, "Install", "WantedBy") == "multi-user.target"


def test_serve_unit_structure() -> None:
    check_serve_unit(parse_unit(SERVE_UNIT.read_text()))


def test_serve_unit_check_catches_a_restart_after_a_bad_config() -> None:
    text = SERVE_UNIT.read_text().replace("RestartPreventExitStatus=2", "RestartPreventExitStatus=")
    with pytest.raises(AssertionError):
        check_serve_unit(parse_unit(text))


def test_serve_unit_passes_systemd_analyze_verify(tmp_path: Path) -> None:
    if shutil.which("systemd-analyze") is None:
        check_serve_unit(parse_unit(SERVE_UNIT.read_text()))
        return
    executable = shutil.which("true")
    assert executable is not None
    unit = tmp_path / "helixd.service"
    unit.write_text(SERVE_UNIT.read_text().replace(INSTALLED_EXEC, executable))
    result = systemd_analyze("verify", str(unit))
    ours = [line for line in result.stderr.splitlines() if "helixd.service" in line]
    assert result.returncode == 0, result.stderr
    assert ours == []


# ---------------------------------------------------------------------------------------------
# sysusers.d / tmpfiles.d


def test_sysusers_and_tmpfiles_configs(tmp_path: Path) -> None:
    sysusers = [ln.split() for ln in SYSUSERS.read_text().splitlines() if ln[:1] not in ("#", "")]
    assert ["m", "helixd", "dialout"] in sysusers
    assert any(fields[:2] == ["u", "helixd"] for fields in sysusers)
    tmpfiles = [ln.split() for ln in TMPFILES.read_text().splitlines() if ln[:1] not in ("#", "")]
    assert ["d", "/var/lib/helixd/runs", "0750", "helixd", "helixd", "-"] in tmpfiles
    if shutil.which("systemd-sysusers") is None or os.geteuid() != 0:
        return  # the structural assertions above are the fallback
    root = tmp_path / "root"
    (root / "etc").mkdir(parents=True)
    for tool, conf, extra in (
        ("systemd-sysusers", SYSUSERS, []),
        ("systemd-tmpfiles", TMPFILES, ["--create"]),
    ):
        subprocess.run(
            [tool, f"--root={root}", *extra, "-"],
            input=conf.read_text(),
            text=True,
            capture_output=True,
            timeout=TOOL_TIMEOUT_S,
            check=True,
        )
    passwd = {
        ln.split(":")[0]: ln.split(":") for ln in (root / "etc/passwd").read_text().splitlines()
    }
    groups = {
        ln.split(":")[0]: ln.split(":") for ln in (root / "etc/group").read_text().splitlines()
    }
    assert "helixd" in groups["dialout"][3].split(",")
    runs = (root / "var/lib/helixd/runs").stat()
    assert runs.st_uid == int(passwd["helixd"][2])
    assert oct(runs.st_mode & 0o777) == "0o750"


# ---------------------------------------------------------------------------------------------
# tools/install.sh


def run_install(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["bash", str(INSTALL), *args],
        capture_output=True,
        text=True,
        timeout=TOOL_TIMEOUT_S,
        check=False,
        env=env,
    )


def test_install_dry_run_changes_nothing() -> None:
    targets = [
        Path("/etc/helixd"),
        Path("/opt/helixd"),
        Path("/var/lib/helixd"),
        Path("/etc/systemd/system/helixd@.service"),
        Path("/etc/sysusers.d/helixd.conf"),
    ]
    before = {p: p.exists() for p in targets}
    result = run_install("--dry-run")
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "dry run" in out
    # (on a machine where helixd is already installed the same steps report "unchanged")
    assert (
        f"+ install -D -m 0644 {UNIT} /etc/systemd/system/helixd@.service" in out
        or "unchanged /etc/systemd/system/helixd@.service" in out
    )
    assert " -m venv /opt/helixd/venv" in out or "venv /opt/helixd/venv exists" in out
    assert f"-m pip install --quiet --upgrade {REPO}" in out
    assert "/etc/helixd/missions/square.yaml" in out
    assert "/var/lib/helixd/runs" in out
    assert {p: p.exists() for p in targets} == before


def file_mode(path: Path) -> int:
    return path.stat().st_mode & 0o777


def test_install_into_a_root_is_complete_and_idempotent(tmp_path: Path) -> None:
    root = tmp_path / "rootfs"
    first = run_install("--root", str(root), "--no-venv")
    assert first.returncode == 0, first.stdout + first.stderr

    unit = root / "etc/systemd/system/helixd@.service"
    assert unit.read_text() == UNIT.read_text()
    assert (root / "etc/systemd/system/helixd.service").read_text() == SERVE_UNIT.read_text()
    assert (root / "etc/sysusers.d/helixd.conf").read_text() == SYSUSERS.read_text()
    assert (root / "etc/tmpfiles.d/helixd.conf").read_text() == TMPFILES.read_text()
    assert (root / "opt/helixd/share/README.systemd.md").is_file()
    config = root / "etc/helixd/helixd.yaml"
    assert config.read_text() == (REPO / "config/helixd.yaml").read_text()
    assert file_mode(config) == 0o640
    assert file_mode(root / "etc/helixd") == 0o750
    for mission in (REPO / "config/missions").glob("*.yaml"):
        assert (root / "etc/helixd/missions" / mission.name).read_text() == mission.read_text()
    runs = root / "var/lib/helixd/runs"
    assert runs.is_dir()
    assert file_mode(runs) == 0o750
    assert not (root / "opt/helixd/venv").exists()  # --no-venv
    assert "not calling systemctl" in first.stdout

    if os.geteuid() == 0 and shutil.which("systemd-sysusers") is not None:
        passwd = (root / "etc/passwd").read_text()
        uid = int(next(ln for ln in passwd.splitlines() if ln.startswith("helixd:")).split(":")[2])
        assert runs.stat().st_uid == uid
        group = (root / "etc/group").read_text()
        gid = int(next(ln for ln in group.splitlines() if ln.startswith("helixd:")).split(":")[2])
        assert config.stat().st_gid == gid
        assert config.stat().st_uid == 0

    # second run: nothing changes; an operator's edit survives, the new default goes to .new
    config.write_text(config.read_text() + "# tuned on site\n")
    second = run_install("--root", str(root), "--no-venv")
    assert second.returncode == 0, second.stdout + second.stderr
    assert "unchanged /etc/systemd/system/helixd@.service" in second.stdout
    assert "unchanged /etc/helixd/missions/square.yaml" in second.stdout
    assert config.read_text().endswith("# tuned on site\n")
    assert (root / "etc/helixd/helixd.yaml.new").read_text() == (
        REPO / "config/helixd.yaml"
    ).read_text()
    third = run_install("--root", str(root), "--no-venv")
    assert third.returncode == 0
    assert "new default already in /etc/helixd/helixd.yaml.new" in third.stdout


def test_install_without_systemd_tools(tmp_path: Path) -> None:
    """A root without systemd-sysusers/-tmpfiles on PATH: plain directories, a clear notice."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    tools = "bash env dirname basename install cmp awk mkdir id cut getent tr grep chown"
    for name in tools.split():
        found = shutil.which(name)
        if found is not None:
            (bin_dir / name).symlink_to(found)
    env = {**os.environ, "PATH": str(bin_dir)}
    root = tmp_path / "rootfs"
    result = run_install(f"--prefix={root}", "--no-venv", env=env)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "creates it from /etc/sysusers.d/helixd.conf at first boot" in result.stdout
    assert not (root / "etc/passwd").exists()
    assert (root / "var/lib/helixd/runs").is_dir()
    assert (root / "etc/systemd/system/helixd@.service").read_text() == UNIT.read_text()


def test_install_rejects_unknown_options() -> None:
    result = run_install("--frobnicate")
    assert result.returncode == 2
    assert "unknown option: --frobnicate" in result.stderr


def _installed_url(root: Path) -> str:
    cfg = load_config(root / "etc/helixd/helixd.yaml")  # still a valid config
    return cfg.link.url


def test_install_finds_the_autopilots_serial_device(tmp_path: Path) -> None:
    """Before: installed, helixd listened on udpin:0.0.0.0:14550. install.sh now takes the
    one autopilot in /dev/serial/by-id/ (its MAVLink interface, -if00, not SLCAN's -if02)."""
    root = tmp_path / "rootfs"
    by_id = root / "dev/serial/by-id"
    by_id.mkdir(parents=True)
    name = "usb-ArduPilot_Pixhawk6X_36004E000F51323138363132"
    for interface in ("if00", "if02"):
        (by_id / f"{name}-{interface}").touch()
    (by_id / "usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0").touch()  # not an autopilot
    result = subprocess.run(
        ["bash", str(INSTALL), "--root", str(root), "--no-venv"],
        capture_output=True,
        text=True,
        timeout=TOOL_TIMEOUT_S,
        check=False,
        stdin=subprocess.DEVNULL,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert _installed_url(root) == f"/dev/serial/by-id/{name}-if00"
    last = result.stdout.splitlines()[-3:]
    assert last[0].endswith(f"link.url = /dev/serial/by-id/{name}-if00 (/etc/helixd/helixd.yaml)")
    assert "systemctl enable --now helixd" in last[1] and "helixd.service" in last[1]
    assert "helixd@<mission>" in last[2]
    again = run_install("--root", str(root), "--no-venv")
    assert "unchanged /etc/helixd/helixd.yaml" in again.stdout


def test_install_link_option_sets_the_url(tmp_path: Path) -> None:
    root = tmp_path / "rootfs"
    result = run_install("--root", str(root), "--no-venv", "--link", "/dev/serial0:921600")
    assert result.returncode == 0, result.stdout + result.stderr
    assert _installed_url(root) == "/dev/serial0:921600"


def test_install_without_a_device_says_the_link_stays_udp(tmp_path: Path) -> None:
    root = tmp_path / "rootfs"
    result = run_install("--root", str(root), "--no-venv")
    assert result.returncode == 0, result.stdout + result.stderr
    assert _installed_url(root) == "udpin:0.0.0.0:14550"
    assert "warning: link.url stays udpin:0.0.0.0:14550" in result.stdout
    assert "--link URL" in result.stdout
