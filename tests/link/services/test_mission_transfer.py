"""The sans-IO mission client (helixd.link.services.mission_transfer) against the simulator's
mission protocol.

No sockets: messages are packed and decoded as on the wire (so sender ids are real) and carried
between the client and helixd.sim.firmware.mission_server.MissionServer by a channel that can
drop and duplicate them, under hypothesis.
"""

from __future__ import annotations

import asyncio
import os
from collections import deque
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig
from helixd.link.services import mission_transfer as lm
from helixd.mav.constants import MAV_MISSION_TYPE_FENCE
from helixd.mav.mission_item import MissionItem, wire_xy
from helixd.sim.firmware.mission_server import MissionServer
from tests.support.mavmsgs import stamp

GCS = (255, 190)
VEHICLE = (1, 1)
HOME = (53.52325, -113.52, 668.0)
CFG = LinkConfig()


def items(n: int, mission_type: int = 0, command: int = 16) -> list[MissionItem]:
    return [
        MissionItem(
            seq=i,
            frame=3,
            command=command,
            param1=float(i),
            x=(535_000_000 + i * 1000) / 1e7,
            y=(-1_135_000_000 - i) / 1e7,
            z=float(i) / 2 if mission_type == 0 else 0.0,  # a fence keeps no altitude
            mission_type=mission_type,
        )
        for i in range(n)
    ]


class Channel:
    """Client ⇄ server, with a fate per message: 0 deliver, 1 drop, 2 duplicate."""

    def __init__(self, srv: MissionServer, fates: list[int] | None = None) -> None:
        self.srv = srv
        self.fates = deque(fates or [])
        self.to_vehicle: deque[Any] = deque()
        self.to_gcs: deque[Any] = deque()
        self.vehicle_saw: list[str] = []

    def _fate(self) -> int:
        return self.fates.popleft() if self.fates else 0

    def _queue(self, q: deque[Any], msg: Any, who: tuple[int, int]) -> None:
        fate = self._fate()
        if fate != 1:
            q.append(stamp(msg, who))
        if fate == 2:
            q.append(stamp(msg, who))

    def run(
        self,
        t: lm.MissionUpload | lm.MissionDownload,
        step_s: float = 0.05,
        limit_s: float = 600.0,
    ) -> None:
        now = 0.0
        for m in t.start(now):
            self._queue(self.to_vehicle, m, GCS)
        while not t.done and now < limit_s:
            while self.to_vehicle:
                msg = self.to_vehicle.popleft()
                self.vehicle_saw.append(msg.get_type())
                for _, reply in self.srv.handle(0, msg, now).sends:
                    self._queue(self.to_gcs, reply, VEHICLE)
            while self.to_gcs and not t.done:
                for m in t.on_message(self.to_gcs.popleft(), now):
                    self._queue(self.to_vehicle, m, GCS)
            now += step_s
            for _, reply in self.srv.update(now).sends:
                self._queue(self.to_gcs, reply, VEHICLE)
            for m in t.on_time(now):
                self._queue(self.to_vehicle, m, GCS)
        assert t.done, "transfer neither finished nor failed"
        while self.to_vehicle:  # what the client sent last (the download's ACK) arrives
            msg = self.to_vehicle.popleft()
            self.vehicle_saw.append(msg.get_type())
            self.srv.handle(0, msg, now)


def server() -> MissionServer:
    return MissionServer(*HOME, max_mission_items=50, max_fence_items=20)


def new_upload(its: list[MissionItem], mission_type: int = 0, retries: int = 5) -> lm.MissionUpload:
    return lm.MissionUpload(
        mission_type, 1, 1, CFG.mission_item_timeout_s, retries, own_ids=GCS, items=its
    )


def new_download(mission_type: int = 0, retries: int = 5) -> lm.MissionDownload:
    return lm.MissionDownload(mission_type, 1, 1, CFG.mission_item_timeout_s, retries, own_ids=GCS)


def stored_as_items(srv: MissionServer, mission_type: int) -> list[tuple[Any, ...]]:
    return [(s.command, s.x, s.y, s.z, s.param1) for s in srv.stored(mission_type)]


def as_tuples(its: list[MissionItem] | tuple[MissionItem, ...]) -> list[tuple[Any, ...]]:
    """The items as the wire (and the simulator's storage) hold them: x/y int32."""
    return [(i.command, *wire_xy(i), i.z, i.param1) for i in its]


def test_upload_then_download_round_trip() -> None:
    srv = server()
    its = items(4)
    up = new_upload(its)
    Channel(srv).run(up)
    assert up.error is None
    assert as_tuples(its)[1:] == stored_as_items(srv, 0)[1:]
    down = new_download()
    ch = Channel(srv)
    ch.run(down)
    assert down.error is None and len(down.items) == 4
    assert as_tuples(down.items)[1:] == as_tuples(its)[1:]
    home = down.items[0]  # ArduPilot keeps its own home in row 0
    assert wire_xy(home) == (round(HOME[0] * 1e7), round(HOME[1] * 1e7))
    assert ch.vehicle_saw[-1] == "MISSION_ACK"  # we acked the download
    assert ch.vehicle_saw.count("MISSION_REQUEST_INT") == 4


def test_fence_round_trip() -> None:
    srv = server()
    its = items(3, MAV_MISSION_TYPE_FENCE, command=5001)
    up = new_upload(its, MAV_MISSION_TYPE_FENCE)
    Channel(srv).run(up)
    assert up.error is None
    down = new_download(MAV_MISSION_TYPE_FENCE)
    Channel(srv).run(down)
    assert as_tuples(down.items) == as_tuples(its)


def test_empty_upload_and_download() -> None:
    srv = server()
    up = new_upload([], MAV_MISSION_TYPE_FENCE)
    Channel(srv).run(up)
    assert up.error is None
    down = new_download(MAV_MISSION_TYPE_FENCE)
    Channel(srv).run(down)
    assert down.error is None and down.items == ()


def test_nack_by_name() -> None:
    srv = MissionServer(*HOME, max_mission_items=3)
    up = new_upload(items(4))
    Channel(srv).run(up)
    assert isinstance(up.error, lm.MissionTransferError)
    assert "MAV_MISSION_NO_SPACE" in str(up.error)
    assert up.error.result == 4


def test_unsupported_item_fails_upload_with_its_name() -> None:
    srv = server()
    up = new_upload(items(3, command=176))
    Channel(srv).run(up)
    assert up.error is not None and "MAV_MISSION_UNSUPPORTED" in str(up.error)


def test_silent_vehicle_times_out_after_retries() -> None:
    class Mute(MissionServer):
        def handle(self, link: int, msg: Any, now_s: float) -> Any:
            return super().update(now_s)  # hears nothing

    up = new_upload(items(2), retries=3)
    Channel(Mute(*HOME)).run(up)
    assert up.error is not None and "no answer after 3 retries" in str(up.error)
    assert up.resends == 3
    down = new_download(retries=2)
    ch = Channel(Mute(*HOME))
    ch.run(down)
    assert down.error is not None and down.resends == 2
    assert ch.vehicle_saw.count("MISSION_REQUEST_LIST") == 3


def test_answers_mission_request_int_too() -> None:
    up = new_upload(items(2))
    out = up.start(0.0)
    assert [m.get_type() for m in out] == ["MISSION_COUNT"]
    req = stamp(mavlink.MAVLink_mission_request_int_message(255, 190, 1, 0), VEHICLE)
    (sent,) = up.on_message(req, 0.1)
    assert sent.get_type() == "MISSION_ITEM_INT" and int(sent.seq) == 1
    stranger = stamp(mavlink.MAVLink_mission_request_int_message(255, 190, 0, 0), (2, 1))
    assert up.on_message(stranger, 0.1) == []
    other_type = stamp(mavlink.MAVLink_mission_request_int_message(255, 190, 0, 1), VEHICLE)
    assert up.on_message(other_type, 0.1) == []
    past = stamp(mavlink.MAVLink_mission_request_int_message(255, 190, 2, 0), VEHICLE)
    assert up.on_message(past, 0.2) == [] and up.error is not None


def test_early_accept_is_an_error() -> None:
    up = new_upload(items(2))
    up.start(0.0)
    ack = stamp(mavlink.MAVLink_mission_ack_message(255, 190, 0, 0), VEHICLE)
    up.on_message(ack, 0.1)
    assert up.error is not None and "not sent" in str(up.error)


def test_bad_items_refused_before_sending() -> None:
    with pytest.raises(ValueError, match="finite"):
        new_upload([MissionItem(seq=0, frame=3, command=16, param1=float("nan"))])
    with pytest.raises(ValueError, match="seq"):
        new_upload([MissionItem(seq=1, frame=3, command=16)])
    with pytest.raises(ValueError, match="int32"):
        new_upload([MissionItem(seq=0, frame=3, command=16, x=2**31)])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    n=hs.integers(1, 8),
    fates=hs.lists(hs.sampled_from([0, 0, 0, 1, 2]), max_size=80),
    mission_type=hs.sampled_from([0, 1]),
)
def test_lossy_link_never_corrupts(n: int, fates: list[int], mission_type: int) -> None:
    """Drops and duplicates: a transfer may fail, but one that succeeds is exact."""
    srv = server()
    command = 16 if mission_type == 0 else 5001
    its = items(n, mission_type, command)
    up = new_upload(its, mission_type, retries=8)
    ch = Channel(srv, fates)
    ch.run(up)
    skip = 1 if mission_type == 0 else 0  # row 0 of the mission is home
    if up.error is None:
        assert stored_as_items(srv, mission_type)[skip:] == as_tuples(its)[skip:]
    srv2 = server()
    Channel(srv2).run(new_upload(its, mission_type))
    down = new_download(mission_type, retries=8)
    Channel(srv2, list(fates)).run(down)
    if down.error is None:
        assert as_tuples(down.items)[skip:] == as_tuples(its)[skip:]


@settings(max_examples=30, deadline=None)
@given(n=hs.integers(0, 8), dups=hs.lists(hs.sampled_from([0, 2]), max_size=60))
def test_duplicates_alone_always_succeed(n: int, dups: list[int]) -> None:
    srv = server()
    its = items(n, MAV_MISSION_TYPE_FENCE, 5001)
    up = new_upload(its, MAV_MISSION_TYPE_FENCE)
    Channel(srv, dups).run(up)
    assert up.error is None
    down = new_download(MAV_MISSION_TYPE_FENCE)
    Channel(srv, list(dups)).run(down)
    assert down.error is None and as_tuples(down.items) == as_tuples(its)


def test_item_from_message_rejects_garbage() -> None:
    bad = stamp(
        mavlink.MAVLink_mission_item_message(
            255, 190, 0, 0, 16, 0, 1, 0, 0, 0, 0, float("inf"), 0.0, 0.0, 0
        ),
        VEHICLE,
    )
    assert lm.item_from_message(bad) is None
    nan_z = stamp(
        mavlink.MAVLink_mission_item_int_message(
            255, 190, 0, 0, 16, 0, 1, 0, 0, 0, 0, 1, 2, float("nan"), 0
        ),
        VEHICLE,
    )
    assert lm.item_from_message(nan_z) is None


class QueueLink:
    """A MissionLink over asyncio queues, the server answering inline."""

    def __init__(self, srv: MissionServer) -> None:
        self.srv = srv
        self.inbox: asyncio.Queue[Any] = asyncio.Queue()
        self.t0 = asyncio.get_running_loop().time()

    def send(self, msg: Any) -> None:
        now = asyncio.get_running_loop().time() - self.t0
        for _, reply in self.srv.handle(0, stamp(msg, GCS), now).sends:
            self.inbox.put_nowait(stamp(reply, VEHICLE))

    async def recv(self, timeout_s: float) -> Any | None:
        try:
            return await asyncio.wait_for(self.inbox.get(), timeout_s)
        except TimeoutError:
            return None


def test_run_transfer_async() -> None:
    async def go() -> None:
        srv = server()
        link = QueueLink(srv)
        await lm.run_transfer(new_upload(items(3)), link)
        down = await lm.run_transfer(new_download(), link)
        assert isinstance(down, lm.MissionDownload) and len(down.items) == 3
        with pytest.raises(lm.MissionTransferError, match="NO_SPACE"):
            await lm.run_transfer(new_upload(items(51)), link)

    asyncio.run(go())


class PymavlinkLink:
    """A MissionLink over a pymavlink UDP connection (the tests' MavClient)."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.texts: list[str] = []

    def send(self, msg: Any) -> None:
        self.client.mav.send(msg)

    async def recv(self, timeout_s: float) -> Any | None:
        conn = self.client.conn
        msg = await asyncio.to_thread(conn.recv_match, blocking=True, timeout=max(timeout_s, 0.01))
        if msg is not None and msg.get_type() == "STATUSTEXT":
            self.texts.append(str(msg.text))
        return msg


def test_upload_and_download_over_udp_against_the_running_simulator() -> None:
    from tests.support.harness import GCS_COMPID, GCS_SYSID, MavClient, running_sim

    me = (GCS_SYSID, GCS_COMPID)
    timeout_s, retries = CFG.mission_item_timeout_s, CFG.mission_retries

    def up(its: list[MissionItem], kind: int = 0) -> lm.MissionUpload:
        return lm.MissionUpload(kind, 1, 1, timeout_s, retries, own_ids=me, items=its)

    def dl(kind: int = 0) -> lm.MissionDownload:
        return lm.MissionDownload(kind, 1, 1, timeout_s, retries, own_ids=me)

    with running_sim(speedup=1.0) as (sim, url), MavClient(url) as client:
        link = PymavlinkLink(client)
        its = items(5)
        fence = items(4, MAV_MISSION_TYPE_FENCE, command=5001)

        async def go() -> tuple[lm.MissionDownload, lm.MissionDownload]:
            await lm.run_transfer(up(its), link)
            await lm.run_transfer(up(fence, MAV_MISSION_TYPE_FENCE), link)
            down = await lm.run_transfer(dl(), link)
            fdown = await lm.run_transfer(dl(MAV_MISSION_TYPE_FENCE), link)
            assert isinstance(down, lm.MissionDownload) and isinstance(fdown, lm.MissionDownload)
            return down, fdown

        down, fdown = asyncio.run(go())
        assert as_tuples(down.items)[1:] == as_tuples(its)[1:]
        assert as_tuples(fdown.items) == as_tuples(fence)
        snap = sim.snapshot()
        assert [(i.x, i.y) for i in snap.mission_items[1:]] == [wire_xy(i) for i in its[1:]]
        assert len(snap.fence_items) == 4
        assert "Flight plan received" in link.texts


def test_answers_to_another_gcs_are_not_ours() -> None:
    down = new_download()
    down.start(0.0)
    for_qgc = stamp(mavlink.MAVLink_mission_count_message(254, 190, 9, 0), VEHICLE)
    assert down.on_message(for_qgc, 0.1) == [] and down.count is None
    for_us = stamp(mavlink.MAVLink_mission_count_message(*GCS, 2, 0), VEHICLE)
    (req,) = down.on_message(for_us, 0.2)
    assert down.count == 2 and req.get_type() == "MISSION_REQUEST_INT"
    up = new_upload(items(2))
    up.start(0.0)
    nack_for_qgc = stamp(mavlink.MAVLink_mission_ack_message(254, 190, 14, 0), VEHICLE)
    up.on_message(nack_for_qgc, 0.1)
    assert up.error is None and not up.done


_f32 = hs.floats(width=32)
_i32 = hs.integers(-(2**31), 2**31 - 1)
_seq = hs.integers(0, 6)
_vehicle_msgs = hs.one_of(
    hs.builds(mavlink.MAVLink_mission_count_message, hs.just(255), hs.just(190), _seq,
              hs.sampled_from([0, 1])),
    hs.builds(mavlink.MAVLink_mission_item_int_message, hs.just(255), hs.just(190), _seq,
              hs.integers(0, 255), hs.integers(0, 65535), hs.integers(0, 255),
              hs.integers(0, 255), _f32, _f32, _f32, _f32, _i32, _i32, _f32, hs.just(0)),
    hs.builds(mavlink.MAVLink_mission_item_message, hs.just(255), hs.just(190), _seq,
              hs.integers(0, 255), hs.integers(0, 65535), hs.integers(0, 255),
              hs.integers(0, 255), _f32, _f32, _f32, _f32, _f32, _f32, _f32, hs.just(0)),
    hs.builds(mavlink.MAVLink_mission_request_message, hs.just(255), hs.just(190), _seq,
              hs.just(0)),
    hs.builds(mavlink.MAVLink_mission_request_int_message, hs.just(255), hs.just(190), _seq,
              hs.just(0)),
    hs.builds(mavlink.MAVLink_mission_ack_message, hs.just(255), hs.just(190),
              hs.integers(0, 20), hs.just(0)),
)  # fmt: skip


@settings(max_examples=150, deadline=None)
@given(msgs=hs.lists(hs.tuples(_vehicle_msgs, hs.floats(0, 2)), max_size=25))
def test_fuzz_vehicle_answers(msgs: list[tuple[Any, float]]) -> None:
    """Any sequence of vehicle messages: no exception; a finished download is consistent."""
    up, down = new_upload(items(3)), new_download()
    now = 0.0
    up.start(now)
    down.start(now)
    for msg, dt in msgs:
        now += dt
        wire = stamp(msg, VEHICLE)
        for t in (up, down):
            t.on_message(wire, now)
            t.on_time(now)
    if down.done and down.error is None:
        assert [i.seq for i in down.items] == list(range(down.count or 0))
    if up.done and up.error is None:
        assert up.requested == {0, 1, 2}
