"""``helixd autopilot install-guard``: put the dead-man switch (helixd-guard.lua) onto the
autopilot over MAVLink FTP (:mod:`helixd.commands.guard_install`).

Registered on the ``autopilot`` group by :func:`register` (in :mod:`helixd.cli.app`).
Exit codes: 0 installed (and, with ``--reboot``, the reboot accepted); 2 bad command line or
config; 3 the autopilot would not take it (no Lua scripting, an FTP refusal, a CRC mismatch;
``--reboot`` while armed, or the reboot refused); 6 no link or no answers.

``--reboot`` sends MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (246) with param1 = 1 (reboot the
autopilot) once the script is in place, disarmed only: ArduPilot refuses it while armed
(``GCS_MAVLINK::handle_preflight_reboot``, short of a force value helixd never sends).
"""

from __future__ import annotations

from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import ConfigOpt, ObserverConnectOpt, fail, link_inputs, run_on_link
from helixd.commands.guard_install import GuardInstalled, GuardInstallRefused, install_guard
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandError
from helixd.mav.constants import MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
from helixd.mav.ftp_wire import FtpPayloadError, encode_path
from helixd.mav.guard_script import BOARD_SCRIPTS_DIR, POSIX_SCRIPTS_DIR, SCRIPT_NAME

ScriptsDirOpt = Annotated[
    str | None,
    typer.Option(
        "--scripts-dir",
        help=f"the autopilot's scripts directory as an FTP path: {BOARD_SCRIPTS_DIR} (SD card) "
        f"or {POSIX_SCRIPTS_DIR} (SITL, Linux boards); found by listing when omitted",
    ),
]
RebootOpt = Annotated[
    bool,
    typer.Option(
        "--reboot",
        help="then reboot the autopilot so the guard loads (disarmed only: refused while "
        "armed); sends MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (246) param1=1",
    ),
]
REBOOT_AUTOPILOT = 1.0  # MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1: reboot the autopilot


def reboot_line(target_system: int, target_component: int) -> str:
    """The command ``--reboot`` sends, as the operator reads it (pure)."""
    return (
        f"sending COMMAND_LONG MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (246) param1={REBOOT_AUTOPILOT:g} "
        f"(reboot the autopilot) to system {target_system} component {target_component}"
    )


class RebootRefused(Exception):
    """``--reboot`` was not done; ``str()`` says why."""


def report(url: str, got: GuardInstalled, rebooted: bool = False) -> list[str]:
    """What the operator reads after an install (pure)."""
    how = "found on the autopilot" if got.found_by_probe else "as given"
    lines = [
        f"helixd-guard v{got.version} → {url} {got.remote_path} ({got.size_bytes} bytes, "
        f"CRC32 0x{got.crc32:08x} checked by the autopilot; scripts directory {how})",
    ]
    if round(got.scr_enable_before) == 1:
        lines.append("SCR_ENABLE = 1 (already set)")
    else:
        lines.append(f"SCR_ENABLE = {got.scr_enable_after:g} (was {got.scr_enable_before:g})")
    if got.running_version is None:
        now = "no helixd-guard runs yet"
    else:
        now = f"helixd-guard v{got.running_version} runs until then"
    first = (
        "the autopilot accepted the reboot; it loads the guard as it boots"
        if rebooted
        else f"reboot the autopilot to load it (or run this again with --reboot): scripts start "
        f"only at boot ({now})"
    )
    lines.append(
        f"{first}. Then its messages show 'helixd-guard: v{got.version} on, outputs …' and the "
        "HXG_* parameters exist; check HXG_CHAN1..4 name every scroll output (helixd's "
        "preflight does; helixd status shows it)"
    )
    return lines


def install_guard_command(
    connect: ObserverConnectOpt = None,
    config: ConfigOpt = None,
    scripts_dir: ScriptsDirOpt = None,
    reboot: RebootOpt = False,
) -> None:
    """Copy helixd-guard.lua onto the autopilot (MAVLink FTP), set SCR_ENABLE = 1, verify the
    CRC. A reboot of the autopilot loads it (--reboot: helixd asks for it, disarmed only)."""
    if scripts_dir is not None:
        try:
            encode_path(f"{scripts_dir.rstrip('/')}/{SCRIPT_NAME}")
        except FtpPayloadError as exc:
            raise fail([f"--scripts-dir: {exc}"], ExitCode.USAGE) from None
    cfg, link = link_inputs(config, connect)

    async def body(ap: Autopilot) -> GuardInstalled:
        if ap.state.armed:
            if reboot:
                raise RebootRefused(
                    "the autopilot is armed: --reboot only while disarmed (nothing installed); "
                    "disarm, then run this again"
                )
            typer.echo(
                "warning: the autopilot is armed; the guard loads only at the next boot",
                err=True,
            )
        got = await install_guard(ap, scripts_dir)
        if reboot:
            if ap.state.armed:  # armed during the upload
                raise RebootRefused("the autopilot armed during the install: not rebooted")
            typer.echo(reboot_line(cfg.link.target_system, cfg.link.target_component))
            try:
                await ap.action.command_long(MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, (REBOOT_AUTOPILOT,))
            except CommandError as exc:
                raise RebootRefused(f"installed, but the reboot was refused: {exc}") from None
        return got

    try:
        got = run_on_link(cfg, link, body)
    except (GuardInstallRefused, RebootRefused) as exc:
        raise fail([f"{link.url}: {exc}"], ExitCode.PREFLIGHT) from None
    for line in report(link.url, got, rebooted=reboot):
        typer.echo(line)


def register(app: typer.Typer) -> None:
    """Add ``install-guard`` to ``app`` (the autopilot group)."""
    app.command("install-guard")(install_guard_command)
