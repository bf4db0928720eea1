"""``helixd autopilot install-guard``: put the dead-man switch (helixd-guard.lua) onto the
autopilot over MAVLink FTP (:mod:`helixd.runtime.guard_install`).

Registered on the main app by :func:`register` (one line in :mod:`helixd.cli.app`).
Exit codes: 0 installed; 2 bad command line or config; 3 the autopilot would not take it (no
Lua scripting, an FTP refusal, a CRC mismatch); 6 no link or no answers.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from helixd.base.exitcodes import ExitCode
from helixd.cli.common import fail, link_inputs, run_on_link
from helixd.link.connection import Autopilot
from helixd.mav.ftp_wire import FtpPayloadError, encode_path
from helixd.mav.guard_script import BOARD_SCRIPTS_DIR, POSIX_SCRIPTS_DIR, SCRIPT_NAME
from helixd.runtime.guard_install import GuardInstalled, GuardInstallRefused, install_guard

autopilot_app = typer.Typer(
    name="autopilot",
    help="Set the autopilot up for helixd.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

ConnectOpt = Annotated[
    str | None, typer.Option("--connect", help="autopilot link (default: link.url)")
]
ConfigOpt = Annotated[Path | None, typer.Option("--config", "-c", help="helixd.yaml")]
ScriptsDirOpt = Annotated[
    str | None,
    typer.Option(
        "--scripts-dir",
        help=f"the autopilot's scripts directory as an FTP path: {BOARD_SCRIPTS_DIR} (SD card) "
        f"or {POSIX_SCRIPTS_DIR} (SITL, Linux boards); found by listing when omitted",
    ),
]


def report(url: str, got: GuardInstalled) -> list[str]:
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
    lines.append(
        f"reboot the autopilot to load it: scripts start only at boot ({now}). Then its "
        f"messages show 'helixd-guard: v{got.version} on, outputs …' and the HXG_* parameters "
        "exist; check HXG_CHAN1..4 name every scroll output (helixd's preflight does)"
    )
    return lines


@autopilot_app.command("install-guard")
def install_guard_command(
    connect: ConnectOpt = None,
    config: ConfigOpt = None,
    scripts_dir: ScriptsDirOpt = None,
) -> None:
    """Copy helixd-guard.lua onto the autopilot (MAVLink FTP), set SCR_ENABLE = 1, verify the
    CRC. A reboot of the autopilot loads it."""
    if scripts_dir is not None:
        try:
            encode_path(f"{scripts_dir.rstrip('/')}/{SCRIPT_NAME}")
        except FtpPayloadError as exc:
            raise fail([f"--scripts-dir: {exc}"], ExitCode.USAGE) from None
    cfg, link = link_inputs(config, connect)

    async def body(ap: Autopilot) -> GuardInstalled:
        if ap.state.armed:
            typer.echo(
                "warning: the autopilot is armed; the guard loads only at the next boot",
                err=True,
            )
        return await install_guard(ap, scripts_dir)

    try:
        got = run_on_link(cfg, link, body)
    except GuardInstallRefused as exc:
        raise fail([f"{link.url}: {exc}"], ExitCode.PREFLIGHT) from None
    for line in report(link.url, got):
        typer.echo(line)


def register(app: typer.Typer) -> None:
    app.add_typer(autopilot_app, name="autopilot")
