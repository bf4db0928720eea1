"""Hostile input over real sockets: garbage between valid frames costs no valid frame.

A raw UDP socket (helixd listens with udpin) or a raw TCP server (helixd connects with tcp:)
plays the autopilot, system 1. Hypothesis draws the garbage put between numbered valid frames
(NAMED_VALUE_INT "fuzz" = k): random bytes, ``FD FF`` (a MAVLink 2 start claiming 255 bytes),
a bare start marker with random header, truncated and bad-CRC frames, unknown message ids,
valid frames with NaN/inf/huge floats, ``time_boot_ms`` going backwards, other systems, and
stray STATUSTEXT chunks (random id / chunk_seq / bytes).
On UDP the garbage goes in its own datagram or glued in front of the frame. The listener counts
the numbered frames that arrive; no handler may fail, no link task may die, and no NaN reaches
the pose.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import socket
from collections.abc import AsyncIterator, Callable, MutableMapping
from dataclasses import dataclass
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink
from structlog.testing import capture_logs

from helixd.link.connection import Autopilot
from helixd.link.wire.framing import MAX_FRAME_BYTES
from tests.support.peer import link_config, safety_config

FAILURE_EVENTS = {"message_handler_failed", "link_task_failed", "mavlink_decode_failed"}
UDP_MIN_DELIVERY = 0.99
TCP_MIN_DELIVERY = 0.98
ARRIVAL_TIMEOUT_S = 2.0
FUZZ_EXAMPLES = 15
CHUNK_ITEMS = 25  # valid frames sent between two waits for their arrival (no socket overflow)


def codec(sysid: int = 1, compid: int = 1) -> Any:
    return mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)


def pack(build: Callable[[Any], Any], sysid: int = 1) -> bytes:
    c = codec(sysid)
    return bytes(build(c).pack(c))


def numbered(k: int) -> bytes:
    return pack(lambda c: c.named_value_int_encode(k, b"fuzz", k))


def heartbeat() -> bytes:
    return pack(lambda c: c.heartbeat_encode(10, 3, 1, 0, 4))


def unknown_id_frame(msgid: int, payload: bytes) -> bytes:
    body = bytes((0xFD, len(payload), 0, 0, 9, 1, 1, msgid & 0xFF, (msgid >> 8) & 0xFF))
    body += bytes(((msgid >> 16) & 0xFF,)) + payload
    crc = mavlink.x25crc(body[1:]).crc
    return body + bytes((crc & 0xFF, crc >> 8))


def bad_crc(frame: bytes) -> bytes:
    out = bytearray(frame)
    out[-2] ^= 0x5A
    return bytes(out)


hostile_float = st.sampled_from([math.nan, math.inf, -math.inf, 3.0e38, -3.0e38, 1e-45])
garbage = st.one_of(
    st.binary(min_size=1, max_size=80),
    st.just(b"\xfd\xff"),
    st.binary(max_size=12).map(lambda b: b"\xfd" + b),
    st.binary(max_size=12).map(lambda b: b"\xfe" + b),
    st.integers(1, 30).map(lambda n: numbered(10**6)[:n]),  # truncated
    st.integers(0, 10**6).map(lambda k: bad_crc(numbered(k))),
    st.tuples(st.integers(20_000, 2**24 - 1), st.binary(max_size=40)).map(
        lambda t: unknown_id_frame(*t)
    ),
    hostile_float.map(
        lambda v: pack(lambda c: c.local_position_ned_encode(5_000, v, v, v, v, v, v))
    ),
    hostile_float.map(lambda v: pack(lambda c: c.attitude_encode(5_000, v, v, v, v, v, v))),
    st.integers(0, 100).map(  # time_boot_ms going backwards
        lambda t: pack(lambda c: c.attitude_encode(t, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0))
    ),
    st.integers(2, 254).map(lambda s: pack(lambda c: c.heartbeat_encode(1, 3, 129, 4, 4), s)),
    st.tuples(st.integers(0, 65535), st.integers(0, 255), st.binary(max_size=50)).map(
        lambda t: pack(lambda c: c.statustext_encode(4, t[2], t[0], t[1]))  # stray chunks
    ),
)
# (garbage in front of the frame, glued into the frame's UDP datagram or in its own)
item = st.tuples(garbage, st.booleans())


@dataclass
class Tally:
    sent: int = 0
    arrived: int = 0
    runs: int = 0


class Received:
    def __init__(self, ap: Autopilot) -> None:
        self.values: set[int] = set()
        self.event = asyncio.Event()
        ap.add_message_listener(self._on)

    def _on(self, msg: Any, _rx_s: float) -> None:
        if msg.get_type() == "NAMED_VALUE_INT" and msg.name == "fuzz":
            self.values.add(int(msg.value))
            self.event.set()

    async def wait_for(self, count: int, timeout_s: float) -> None:
        """Until ``count`` numbered frames arrived or ``timeout_s`` passed (loss is measured)."""
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(timeout_s):
                while len(self.values) < count:
                    self.event.clear()
                    await self.event.wait()


def check_sound(ap: Autopilot, logs: list[MutableMapping[str, Any]]) -> None:
    failures = [e for e in logs if e["event"] in FAILURE_EVENTS]
    assert not failures, failures
    pose = ap.state.pose
    if pose is not None:
        assert math.isfinite(pose.ned.north_m) and math.isfinite(pose.ned.yaw_ned_rad)
    assert ap.state.yaw_ned_rad is None or math.isfinite(ap.state.yaw_ned_rad)


@contextlib.asynccontextmanager
async def udp_link() -> AsyncIterator[tuple[Autopilot, Callable[[bytes], None]]]:
    ap = await Autopilot.connect(link_config(), safety_config(heartbeat_timeout_s=5.0))
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    address = ap.local_address
    assert address is not None
    try:

        def send(data: bytes) -> None:
            sock.sendto(data, address)

        yield ap, send
    finally:
        sock.close()
        await ap.close()


@contextlib.asynccontextmanager
async def heard_udp_link() -> AsyncIterator[tuple[Autopilot, Callable[[bytes], None], Received]]:
    """:func:`udp_link` once helixd has heard the autopilot's HEARTBEAT; with a
    :class:`Received` for the numbered frames that come after it."""
    async with udp_link() as (ap, send):
        send(heartbeat())
        await ap.wait_heartbeat(3.0)
        yield ap, send, Received(ap)


@contextlib.asynccontextmanager
async def tcp_link() -> AsyncIterator[tuple[Autopilot, Callable[[bytes], None]]]:
    loop = asyncio.get_running_loop()
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    server.setblocking(False)
    port = server.getsockname()[1]
    accepted = loop.create_task(loop.sock_accept(server))
    ap = await Autopilot.connect(
        link_config(url=f"tcp:127.0.0.1:{port}"), safety_config(heartbeat_timeout_s=5.0)
    )
    client, _ = await accepted
    client.setblocking(True)  # small writes into an idle loopback connection
    try:
        yield ap, client.sendall
    finally:
        client.close()
        server.close()
        await ap.close()


async def run_scenario(
    link: Callable[[], contextlib.AbstractAsyncContextManager[tuple[Autopilot, Any]]],
    items: list[tuple[bytes, bool]],
    datagrams: bool,
    tally: Tally,
) -> None:
    chunks = wire_chunks(items, datagrams)
    with capture_logs() as logs:
        async with link() as (ap, send):
            received = Received(ap)
            send(heartbeat())
            await ap.wait_heartbeat(3.0)
            frames_sent = 0
            for chunk in chunks:
                send(chunk)
                frames_sent += chunk.endswith(numbered(frames_sent))
                # a datagram socket could overflow; a stream may hold a frame back behind a
                # bogus length until more bytes come, so only UDP paces itself
                if datagrams and frames_sent % CHUNK_ITEMS == 0:
                    await received.wait_for(frames_sent, ARRIVAL_TIMEOUT_S)
            if not datagrams:
                send(b"\x00" * MAX_FRAME_BYTES)  # a stream keeps flowing: flush a held frame
            await received.wait_for(len(items), ARRIVAL_TIMEOUT_S)
            check_sound(ap, logs)
            tally.sent += len(items)
            tally.arrived += len(received.values & set(range(len(items))))
            tally.runs += 1
            stats = ap.link_stats
            assert stats.rx_messages >= len(received.values)


def pymavlink_baseline(chunks: list[bytes], count: int) -> int:
    """How many numbered frames pymavlink's robust parser, carried across reads, would get."""
    parser = codec(0, 0)
    parser.robust_parsing = True
    got: set[int] = set()
    for chunk in chunks:
        for msg in parser.parse_buffer(chunk) or []:
            if msg.get_type() == "NAMED_VALUE_INT" and msg.name == "fuzz":
                got.add(int(msg.value))
    return len(got & set(range(count)))


def wire_chunks(items: list[tuple[bytes, bool]], datagrams: bool) -> list[bytes]:
    chunks: list[bytes] = []
    for k, (junk, glued) in enumerate(items):
        if datagrams and not glued:
            chunks += [junk, numbered(k)]
        else:
            chunks.append(junk + numbered(k))
    return chunks


def fuzz(
    name: str,
    link: Callable[[], contextlib.AbstractAsyncContextManager[tuple[Autopilot, Any]]],
    datagrams: bool,
    bound: float,
) -> None:
    tally = Tally()
    baseline = 0

    @settings(
        max_examples=FUZZ_EXAMPLES,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(st.lists(item, min_size=20, max_size=120))
    def one(items: list[tuple[bytes, bool]]) -> None:
        nonlocal baseline
        asyncio.run(run_scenario(link, items, datagrams, tally))
        baseline += pymavlink_baseline(wire_chunks(items, datagrams), len(items))

    one()
    share = tally.arrived / tally.sent
    print(
        f"fuzz {name}: {tally.arrived}/{tally.sent} valid frames = {share:.2%} in {tally.runs} "
        f"runs (pymavlink's parser carried across reads: {baseline / tally.sent:.2%})"
    )
    assert share >= bound, (tally.arrived, tally.sent)


def test_udp_fuzz() -> None:
    fuzz("udp", udp_link, datagrams=True, bound=UDP_MIN_DELIVERY)


def test_tcp_fuzz() -> None:
    fuzz("tcp", tcp_link, datagrams=False, bound=TCP_MIN_DELIVERY)


async def test_fd_ff_datagrams_between_every_frame_cost_nothing() -> None:
    """The flood: a 2-byte ``FD FF`` datagram before every one of the autopilot's."""
    async with udp_link() as (ap, send):
        received = Received(ap)
        send(heartbeat())
        await ap.wait_heartbeat(3.0)
        before = ap.state.heartbeat_count
        for k in range(200):
            send(b"\xfd\xff")
            send(numbered(k))
            send(b"\xfd\xff")
            send(heartbeat())
            if (k + 1) % CHUNK_ITEMS == 0:
                await received.wait_for(k + 1, ARRIVAL_TIMEOUT_S)
        await received.wait_for(200, ARRIVAL_TIMEOUT_S)
        assert received.values == set(range(200))
        assert ap.state.heartbeat_count - before == 200
        assert ap.link_stats.bad_data == 400
        assert not ap.state.link_lost


async def test_unknown_ids_are_not_a_foreign_system() -> None:
    async with heard_udp_link() as (ap, send, received):
        for k in range(5):
            send(unknown_id_frame(0xABCDE, b"hello"))
            send(numbered(k))
        await received.wait_for(5, ARRIVAL_TIMEOUT_S)
        assert ap.link_stats.unknown_messages == 5
        assert 0 not in ap.state.foreign_sysid_counts
        assert not ap.state.foreign_sysid_counts


async def test_nan_pose_fields_are_rejected_at_the_edge() -> None:
    async with heard_udp_link() as (ap, send, received):
        send(pack(lambda c: c.attitude_encode(1_000, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0)))
        send(pack(lambda c: c.attitude_encode(1_010, 0.0, 0.0, math.nan, 0.0, 0.0, 0.0)))
        send(pack(lambda c: c.local_position_ned_encode(1_020, math.inf, 0, 0, 0, 0, 0)))
        send(numbered(0))
        await received.wait_for(1, ARRIVAL_TIMEOUT_S)
        assert ap.state.yaw_ned_rad is None  # a rejected ATTITUDE also forgets the old yaw
        assert ap.state.pose is None
        assert ap.state.pose_rejected_count == 2
        assert ap.state.pose_invalid
