"""helixd.commands.guard_install against an in-memory autopilot: the simulator's FTP server
behind the real FTP adapter (helixd.link.services.ftp_link), and a parameter table."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

os.environ.setdefault("MAVLINK20", "1")

from helixd.commands.guard_install import GuardInstallRefused, find_scripts_dir, install_guard
from helixd.config.link import LinkConfig
from helixd.link.services.ftp_link import FtpClient
from helixd.link.services.ftp_transfer import FtpTransferError
from helixd.mav.ftp_wire import FtpOp, FtpPayload, from_message, to_message
from helixd.mav.guard_script import script_bytes
from helixd.sim.ftp_server import FtpServer
from tests.support.mavmsgs import stamp

CFG = LinkConfig()
GCS = (CFG.source_system, CFG.source_component)
VEHICLE = (CFG.target_system, CFG.target_component)


class Params:
    def __init__(self, values: dict[str, float]) -> None:
        self.values = values
        self.sets: list[tuple[str, float]] = []

    async def get(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> float | None:
        return self.values.get(name)

    async def set(self, name: str, value: float) -> float:
        self.sets.append((name, value))
        self.values[name] = value
        return value


class Vehicle:
    """The Autopilot facade's part the installer uses, with an FTP server behind it."""

    def __init__(self, root: Path, params: dict[str, float]) -> None:
        self.cfg = CFG
        self.srv = FtpServer(root)
        self.param = Params(params)
        self.listeners: list[Callable[[Any, float], None]] = []
        self.requests: list[FtpPayload] = []
        self.noise: list[Any] = []  # messages delivered before each reply
        self.ftp = FtpClient(self)

    def add_message_listener(self, callback: Callable[[Any, float], None]) -> None:
        self.listeners.append(callback)

    def remove_message_listener(self, callback: Callable[[Any, float], None]) -> None:
        self.listeners.remove(callback)

    def send_message(self, msg: Any) -> bool:
        got = stamp(msg, GCS)
        assert (got.target_system, got.target_component) == VEHICLE
        payload = from_message(got)
        self.requests.append(FtpPayload.unpack(payload))
        for reply in self.srv.handle(payload, sysid=GCS[0], compid=GCS[1], now_s=0.0):
            for extra in self.noise:
                self._deliver(extra)
            self._deliver(stamp(to_message(FtpPayload.unpack(reply), *GCS), VEHICLE))
        return True

    def _deliver(self, msg: Any) -> None:
        for callback in list(self.listeners):
            callback(msg, 0.0)


async def test_no_scripting_in_the_firmware_is_refused_before_any_copy(tmp_path: Path) -> None:
    ap = Vehicle(tmp_path, {})
    with pytest.raises(GuardInstallRefused, match="no SCR_ENABLE parameter"):
        await install_guard(ap)
    assert ap.requests == [] and ap.param.sets == []


async def test_install_sets_scr_enable_and_reports(tmp_path: Path) -> None:
    ap = Vehicle(tmp_path, {"SCR_ENABLE": 0.0})
    got = await install_guard(ap)
    assert (tmp_path / "scripts" / "helixd-guard.lua").read_bytes() == script_bytes()
    assert ap.param.sets == [("SCR_ENABLE", 1.0)]
    assert (got.remote_path, got.found_by_probe, got.running_version) == (
        "scripts/helixd-guard.lua",
        True,
        None,
    )
    assert got.size_bytes == len(script_bytes()) and got.scr_enable_after == 1.0
    assert ap.listeners == []  # the adapter removed itself


async def test_scripts_dir_preference(tmp_path: Path) -> None:
    ap = Vehicle(tmp_path, {})
    assert await find_scripts_dir(ap) == "scripts"  # nothing there: SITL's ./scripts
    (tmp_path / "APM").mkdir()
    assert await find_scripts_dir(ap) == "/APM/scripts"  # an SD card, scripting never on
    (tmp_path / "scripts").mkdir()
    assert await find_scripts_dir(ap) == "scripts"  # SITL where scripting already ran
    (tmp_path / "APM" / "scripts").mkdir()
    assert await find_scripts_dir(ap) == "/APM/scripts"
    listed = [p.data.decode() for p in ap.requests if p.opcode == FtpOp.ListDirectory]
    assert listed[-1] == "/APM/scripts"


async def test_a_given_directory_is_not_probed(tmp_path: Path) -> None:
    ap = Vehicle(tmp_path, {"SCR_ENABLE": 1.0, "HXG_VERSION": 1.0})
    got = await install_guard(ap, "/APM/scripts")
    assert got.running_version == 1 and not got.found_by_probe
    assert FtpOp.ListDirectory not in [p.opcode for p in ap.requests]
    assert ap.param.sets == []  # SCR_ENABLE already 1
    assert (tmp_path / "APM" / "scripts" / "helixd-guard.lua").is_file()


async def test_an_unanswered_exchange_times_out_as_a_link_problem(tmp_path: Path) -> None:
    ap = Vehicle(tmp_path, {"SCR_ENABLE": 1.0})
    ap.srv.handle = lambda *a, **k: []  # type: ignore[method-assign]  # a mute autopilot
    with pytest.raises(FtpTransferError) as info:
        await install_guard(ap, "scripts")
    assert info.value.timed_out
