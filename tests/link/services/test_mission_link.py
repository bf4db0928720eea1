"""helixd.link.services.mission_link: the MissionLink adapter on the Autopilot's message
listener, and whole-mission transfers through it against the simulator's mission protocol (no
sockets: packed and decoded frames, so sender ids are real)."""

from __future__ import annotations

import asyncio
import os
import time
from collections.abc import Callable
from typing import Any

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.link.services.mission_link import AutopilotMissionLink, MissionClient
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.mav.constants import MAV_MISSION_TYPE_FENCE
from helixd.mav.mission_item import MissionItem
from helixd.sim.firmware.mission_server import MissionServer
from tests.support.mavmsgs import stamp

CFG = LinkConfig(mission_item_timeout_s=0.2, mission_retries=2)
GCS = (CFG.source_system, CFG.source_component)
VEHICLE = (1, 1)

Listener = Callable[[Any, float], None]


class Host:
    """The Autopilot's part: listeners fed by the 'reader', a send to the vehicle."""

    def __init__(self, srv: MissionServer | None = None) -> None:
        self.cfg = CFG
        self.listeners: list[Listener] = []
        self.srv = srv
        self.sent: list[str] = []

    def add_message_listener(self, callback: Listener) -> None:
        self.listeners.append(callback)

    def remove_message_listener(self, callback: Listener) -> None:
        self.listeners.remove(callback)

    def rx(self, msg: Any) -> None:
        for cb in list(self.listeners):
            cb(stamp(msg, VEHICLE), time.monotonic())

    def send(self, msg: Any) -> bool:
        self.sent.append(msg.get_type())
        if self.srv is not None:
            out = self.srv.handle(0, stamp(msg, GCS), 0.0)
            loop = asyncio.get_running_loop()
            for step in out.steps:  # replies arrive later, as from a socket, in order
                if isinstance(step, tuple):
                    loop.call_soon(self.rx, step[1])
                else:
                    text = mavlink.MAVLink_statustext_message(step.severity, step.text.encode())
                    loop.call_soon(self.rx, text)
        return True


def test_recv_passes_mission_messages_only_and_times_out() -> None:
    async def main() -> None:
        host = Host()
        with AutopilotMissionLink(host, host.send) as link:
            assert len(host.listeners) == 1
            host.rx(mavlink.MAVLink_attitude_message(0, 0, 0, 0, 0, 0, 0))
            host.rx(mavlink.MAVLink_mission_count_message(247, 191, 3, 0))
            got = await link.recv(1.0)
            assert got is not None and got.get_type() == "MISSION_COUNT"
            t0 = time.monotonic()
            assert await link.recv(0.05) is None  # the ATTITUDE was not queued
            assert time.monotonic() - t0 >= 0.04
            assert await link.recv(0.0) is None
        assert host.listeners == []  # removed after the transfer

    asyncio.run(main())


def items(n: int) -> tuple[MissionItem, ...]:
    return tuple(
        MissionItem(seq=i, frame=3, command=16, x=(536_000_000 + i) / 1e7, y=-113.5)
        for i in range(n)
    )


def fence() -> tuple[MissionItem, ...]:
    return tuple(
        MissionItem(
            seq=i, frame=0, command=5001, param1=3.0, x=(535_000_000 + 1000 * i) / 1e7,
            y=(-1_135_000_000 + 1000 * (i % 2)) / 1e7, mission_type=MAV_MISSION_TYPE_FENCE,
        )
        for i in range(3)
    )  # fmt: skip


def test_upload_then_download_through_the_adapter() -> None:
    async def main() -> None:
        srv = MissionServer(53.5, -113.5, 600.0, max_mission_items=20, max_fence_items=10)
        host = Host(srv)
        await MissionClient(host, host.send).upload(items(5), fence())
        assert len(srv.stored()) == 5 and len(srv.stored(MAV_MISSION_TYPE_FENCE)) == 3
        got = await MissionClient(host, host.send).download()
        assert [(i.seq, i.x) for i in got.mission[1:]] == [(i.seq, i.x) for i in items(5)[1:]]
        assert got.mission[0].x == 53.5  # home: the vehicle's own, not what we wrote
        assert [(i.command, i.param1, i.x) for i in got.fence] == [
            (f.command, f.param1, f.x) for f in fence()
        ]
        await MissionClient(host, host.send).upload(items(3), ())  # an empty fence clears it
        assert srv.stored(MAV_MISSION_TYPE_FENCE) == ()
        assert host.listeners == []

    asyncio.run(main())


def test_a_refusal_names_the_result_and_the_vehicles_text() -> None:
    async def main() -> None:
        srv = MissionServer(53.5, -113.5, 600.0, max_mission_items=4)
        host = Host(srv)
        with pytest.raises(MissionTransferError) as err:
            await MissionClient(host, host.send).upload(items(5), None)
        assert err.value.result == 4
        assert str(err.value) == (
            "mission upload refused: MAV_MISSION_NO_SPACE (autopilot: Only 4 items are supported)"
        )
        assert host.sent == ["MISSION_COUNT"]  # nothing more after the refusal

    asyncio.run(main())


def test_silence_fails_after_the_retries() -> None:
    async def main() -> None:
        host = Host()  # nobody answers
        with pytest.raises(
            MissionTransferError, match=r"^mission download .* no answer after 2 retries"
        ) as err:
            await MissionClient(host, host.send).download()
        assert err.value.result is None and err.value.vehicle_text is None
        assert host.sent.count("MISSION_REQUEST_LIST") == 3

    asyncio.run(main())
