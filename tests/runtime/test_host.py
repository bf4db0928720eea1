"""``helixd serve``'s host: each flight lent the service's one long-lived link records that
link's traffic from its start to its end in its own run directory's ``link.tlog``; the link
stays up between flights and nothing between them is in either tlog."""

from __future__ import annotations

import asyncio
import os
import socket
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.run_files import TLOG_FILE
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.runtime.host import ServeHost
from helixd.runtime.setup import Held
from helixd.runtime.signals import StopRequest
from tests.support.mavmsgs import read_tlog

CFG = HelixdConfig.model_validate({"link": {"url": "udpin:127.0.0.1:0"}})


def heartbeat() -> bytes:
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    return bytes(mavlink.MAVLink_heartbeat_message(10, 3, 0, 0, 4, 3).pack(mav))


def override_us(ap: Autopilot, pwm_us: int) -> None:
    """A frame out on the link, marked by its channel 1 (recorded as it is sent)."""
    ap.action.send_rc_override([pwm_us] + [1500] * 7 + [0] * 10)


def overrides_in(path: Path) -> list[int]:
    return [int(m.chan1_raw) for m in read_tlog(path) if m.get_type() == "RC_CHANNELS_OVERRIDE"]


def received_overrides(peer: socket.socket, count: int) -> list[int]:
    """Channel 1 of the first ``count`` RC_CHANNELS_OVERRIDE the autopilot's side received."""
    mav = mavlink.MAVLink(None)
    got: list[int] = []
    peer.settimeout(5.0)
    while len(got) < count:
        for msg in mav.parse_buffer(peer.recv(2048)) or []:
            if msg.get_type() == "RC_CHANNELS_OVERRIDE":
                got.append(int(msg.chan1_raw))
    return got


async def autopilot_with_peer(cfg: HelixdConfig) -> tuple[Autopilot, socket.socket]:
    """helixd's link and the autopilot's end of it (a UDP socket that sent one HEARTBEAT)."""
    ap = await Autopilot.connect(cfg.link, cfg.safety)
    addr = ap.local_address
    assert addr is not None
    peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    peer.sendto(heartbeat(), addr)
    return ap, peer


def test_each_serve_flight_records_the_link_in_its_own_tlog(tmp_path: Path) -> None:
    async def main() -> None:
        ap, peer = await autopilot_with_peer(CFG)
        try:
            with peer:
                await ap.wait_heartbeat(5.0)
                override_us(ap, 1100)  # the service before any flight
                for flight in (1, 2):
                    run_dir = tmp_path / f"flight{flight}"
                    run_dir.mkdir()
                    host = ServeHost(ap, StopRequest())
                    held = Held()
                    assert await host.open(CFG, held, lambda _: None, run_dir) is ap
                    assert held.ap is ap and ap.tlog is not None
                    override_us(ap, 1200 + flight)  # in this flight
                    await host.close(ap)
                    assert ap.tlog is None
                    override_us(ap, 1300 + flight)  # between flights
                # the service's link stayed up: every frame reached the autopilot
                assert received_overrides(peer, 5) == [1100, 1201, 1301, 1202, 1302]
        finally:
            await ap.close()

    asyncio.run(main())
    assert overrides_in(tmp_path / "flight1" / TLOG_FILE) == [1201]
    assert overrides_in(tmp_path / "flight2" / TLOG_FILE) == [1202]


def test_no_tlog_when_it_is_off(tmp_path: Path) -> None:
    cfg = CFG.model_copy(update={"link": CFG.link.model_copy(update={"tlog_enabled": False})})

    async def main() -> None:
        ap, peer = await autopilot_with_peer(cfg)
        try:
            with peer:
                host = ServeHost(ap, StopRequest())
                await host.open(cfg, Held(), lambda _: None, tmp_path)
                assert ap.tlog is None
                await host.close(ap)
        finally:
            await ap.close()

    asyncio.run(main())
    assert not (tmp_path / TLOG_FILE).exists()
