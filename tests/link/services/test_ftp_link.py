"""helixd.link.services.ftp_link: MAVLink FTP over a real Autopilot against the simulator over
UDP, and the adapter's filter (only the autopilot's replies addressed to us)."""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.link.connection import Autopilot
from helixd.link.services.ftp_link import AutopilotFtpLink
from helixd.link.services.ftp_transfer import DirectoryProbe, FtpUpload
from helixd.mav.ftp_wire import FtpOp, FtpPayload, crc32_ardupilot, to_message
from tests.support.harness import running_sim
from tests.support.mavmsgs import stamp
from tests.support.peer import safety_config

CFG = LinkConfig()
GCS = (CFG.source_system, CFG.source_component)
VEHICLE = (CFG.target_system, CFG.target_component)


async def test_upload_and_probe_over_a_real_autopilot_link() -> None:
    data = bytes(range(256)) * 9  # 2304 bytes: 10 WriteFile chunks
    with running_sim() as (server, url):
        ap = await Autopilot.connect(CFG.model_copy(update={"url": url}), safety_config())
        try:
            await ap.wait_heartbeat(10.0)
            before = await ap.ftp.run(DirectoryProbe("scripts"))
            up = await ap.ftp.run(FtpUpload("scripts/x.lua", data))
            after = await ap.ftp.run(DirectoryProbe("scripts"))
        finally:
            await ap.close()
        assert (server.workdir / "scripts" / "x.lua").read_bytes() == data
    assert before.exists is False and after.exists is True
    assert up.remote_crc32 == crc32_ardupilot(data) and up.resends == 0


class Host:
    def __init__(self) -> None:
        self.cfg = CFG
        self.listeners: list[Callable[[Any, float], None]] = []
        self.sent: list[Any] = []

    def add_message_listener(self, callback: Callable[[Any, float], None]) -> None:
        self.listeners.append(callback)

    def remove_message_listener(self, callback: Callable[[Any, float], None]) -> None:
        self.listeners.remove(callback)

    def send_message(self, msg: Any) -> bool:
        self.sent.append(msg)
        return False  # the transport dropped it


async def test_the_adapter_keeps_only_replies_for_us_and_counts_the_rest() -> None:
    host = Host()
    reply = FtpPayload(1, 1, int(FtpOp.Ack), req_opcode=int(FtpOp.ListDirectory))
    for_us = stamp(to_message(reply, *GCS), VEHICLE)
    broadcast_comp = stamp(to_message(reply, GCS[0], 0), VEHICLE)
    with AutopilotFtpLink(host) as link:
        feed = host.listeners[0]
        feed(stamp(to_message(reply, 200, 190), VEHICLE), 0.0)  # another GCS's
        feed(stamp(to_message(reply, *GCS), (VEHICLE[0], 100)), 0.0)  # another component's
        feed(stamp(to_message(reply, GCS[0], 99), VEHICLE), 0.0)  # our system, other comp
        feed(stamp(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3), VEHICLE), 0.0)
        assert link.ignored == 3 and await link.recv(0.0) is None
        feed(for_us, 0.0)
        feed(broadcast_comp, 0.0)
        assert await link.recv(0.0) == reply.pack()
        assert await link.recv(0.1) == reply.pack()
        assert await link.recv(0.01) is None
        link.send(reply.pack())
        assert link.send_failed == 1
        sent = stamp(host.sent[0], GCS)
        assert (sent.target_system, sent.target_component) == VEHICLE
    assert host.listeners == []
