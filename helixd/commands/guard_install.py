"""``helixd autopilot install-guard``: copy helixd-guard.lua onto the autopilot and switch
scripting on.

Steps, on a short link session (:func:`install_guard`):

1. ``SCR_ENABLE`` must exist: firmware built without Lua scripting has no such parameter, and
   nothing is copied then.
2. The scripts directory (ArduPilot ``SCRIPTING_DIRECTORY``, see
   :mod:`helixd.mav.guard_script`): given, or found with MAVLink FTP ListDirectory probes —
   ``/APM/scripts`` (an SD card: scripting was already on), else ``scripts`` (SITL or a Linux
   board, relative to the autopilot's working directory), else ``/APM`` exists (an SD card
   where scripting never ran: ``/APM/scripts`` is made), else ``scripts``.
3. The packaged script (:func:`helixd.mav.guard_script.script_bytes`) is uploaded over MAVLink FTP
   (:class:`helixd.link.services.ftp_transfer.FtpUpload`: missing directories made, the autopilot's
   CRC32 of the written file compared with the bytes sent).
4. ``SCR_ENABLE`` set to 1 if it was not (confirmed by the autopilot's PARAM_VALUE).

The script loads only when the autopilot boots: the caller says so. ``HXG_VERSION`` tells which
guard runs now (None: none), so the caller can say whether the reboot replaces one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import structlog

from helixd.link.services.ftp_link import FtpClient
from helixd.link.services.ftp_transfer import DirectoryProbe, FtpUpload
from helixd.mav.guard_script import (
    BOARD_SCRIPTS_DIR,
    HXG_VERSION,
    POSIX_SCRIPTS_DIR,
    SCR_ENABLE,
    SCRIPT_NAME,
    script_bytes,
    script_version,
)

__all__ = ["GuardInstallRefused", "GuardInstalled", "find_scripts_dir", "install_guard"]

log = structlog.get_logger(__name__)

BOARD_ROOT_DIR = "/APM"  # the SD card's ArduPilot folder (logs, terrain, scripts)


class GuardInstallRefused(Exception):
    """The autopilot cannot take the guard (no Lua scripting in its firmware)."""


class ParamPlugin(Protocol):
    async def get(
        self, name: str, timeout_s: float | None = ..., retries: int | None = ...
    ) -> float | None: ...

    async def set(self, name: str, value: float) -> float: ...


class FtpPluginHost(Protocol):
    """What the scripts-directory probe needs of the Autopilot facade: its FTP plugin."""

    @property
    def ftp(self) -> FtpClient: ...


class GuardHost(FtpPluginHost, Protocol):
    """What the installer needs of the Autopilot facade: its FTP and param plugins."""

    @property
    def param(self) -> ParamPlugin: ...


@dataclass(frozen=True, slots=True)
class GuardInstalled:
    remote_path: str  # where the script now is, as an FTP path
    found_by_probe: bool  # the directory was found on the autopilot (not given)
    version: int  # the installed script's VERSION
    size_bytes: int
    crc32: int  # ArduPilot's CRC32 of the written file, equal to the bytes sent
    scr_enable_before: float
    scr_enable_after: float
    running_version: int | None  # HXG_VERSION before the reboot: the guard that runs now


async def _exists(ap: FtpPluginHost, path: str) -> bool:
    probe = await ap.ftp.run(DirectoryProbe(path))
    return bool(probe.exists)


async def find_scripts_dir(ap: FtpPluginHost) -> str:
    """The autopilot's scripts directory, found by listing (step 2 of the module's list)."""
    if await _exists(ap, BOARD_SCRIPTS_DIR):
        return BOARD_SCRIPTS_DIR
    if await _exists(ap, POSIX_SCRIPTS_DIR):
        return POSIX_SCRIPTS_DIR
    if await _exists(ap, BOARD_ROOT_DIR):
        return BOARD_SCRIPTS_DIR
    return POSIX_SCRIPTS_DIR


async def install_guard(ap: GuardHost, scripts_dir: str | None = None) -> GuardInstalled:
    """Steps 1–4; raises :class:`GuardInstallRefused`, or the link's and FTP's own errors
    (:class:`helixd.mav.url.LinkError`,
    :class:`helixd.link.services.ftp_transfer.FtpTransferError`)."""
    before = await ap.param.get(SCR_ENABLE)
    if before is None:
        raise GuardInstallRefused(
            f"the autopilot has no {SCR_ENABLE} parameter: its firmware was built without Lua "
            "scripting (boards with less than 1 MB of flash, or a custom build), so it cannot "
            "run helixd-guard; use a firmware with scripting"
        )
    running = await ap.param.get(HXG_VERSION)
    found = scripts_dir is None
    directory = await find_scripts_dir(ap) if scripts_dir is None else scripts_dir
    path = f"{directory.rstrip('/')}/{SCRIPT_NAME}"
    data = script_bytes()
    version = script_version(data)
    assert version is not None, "the packaged helixd-guard.lua declares its VERSION"
    upload = await ap.ftp.run(FtpUpload(path, data))
    assert upload.remote_crc32 is not None  # verified: equal to the local CRC32
    log.info("guard_uploaded", path=path, bytes=len(data), crc32=f"0x{upload.remote_crc32:08x}")
    after = before
    if round(before) != 1:
        after = await ap.param.set(SCR_ENABLE, 1.0)
        log.info("scr_enable_set", before=before, after=after)
    return GuardInstalled(
        remote_path=path,
        found_by_probe=found,
        version=version,
        size_bytes=len(data),
        crc32=upload.remote_crc32,
        scr_enable_before=before,
        scr_enable_after=after,
        running_version=None if running is None else round(running),
    )
