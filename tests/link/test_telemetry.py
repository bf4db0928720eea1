"""The telemetry plugin's streams, driven by a vehicle state as the link's reader drives it."""

from __future__ import annotations

import asyncio
import time

from helixd.link.vehicle import PoseSample
from tests.support.feed import Feed, still_pending
from tests.support.mavmsgs import att, lpn
from tests.support.peer import linked, until


def test_pose_stream_yields_each_new_pose_once() -> None:
    async def main() -> None:
        f = Feed()
        poses = f.telemetry.pose()
        nxt = asyncio.ensure_future(anext(poses))
        assert await still_pending(nxt)  # waiting for a pose
        f.rx(att(1000, 0.1))
        assert not nxt.done()  # an attitude alone is no pose
        f.rx(lpn(1000, 1.0, 2.0))
        first = await asyncio.wait_for(nxt, 1.0)
        assert (first.ned.north_m, first.time_boot_ms) == (1.0, 1000)
        nxt = asyncio.ensure_future(anext(poses))
        assert await still_pending(nxt)  # the same pose is not yielded again
        f.rx(att(1020, 0.1))
        f.rx(lpn(1020, 1.5, 2.0))
        assert (await asyncio.wait_for(nxt, 1.0)).ned.north_m == 1.5
        await poses.aclose()

    asyncio.run(main())


def test_pose_or_tick_yields_none_without_poses() -> None:
    async def main() -> None:
        f = Feed()
        ticks = f.telemetry.pose_or_tick(0.02)
        t0 = time.monotonic()
        assert await anext(ticks) is None
        assert time.monotonic() - t0 >= 0.015  # a tick, not a busy loop
        f.rx(att(1000, 0.2))
        f.rx(lpn(1000, 3.0, 4.0))
        pose = await anext(ticks)  # the pose that arrived meanwhile
        assert pose is not None and pose.ned.east_m == 4.0
        assert await anext(ticks) is None  # not again
        await ticks.aclose()

    asyncio.run(main())


def test_messages_stream_and_listener_removed_on_close() -> None:
    async def main() -> None:
        f = Feed()
        msgs = f.telemetry.messages()
        nxt = asyncio.ensure_future(anext(msgs))
        assert await still_pending(nxt)  # no message yet; the stream has started listening
        assert len(f.listeners) == 1
        f.rx(att(1000, 0.2))
        msg, rx_s = await asyncio.wait_for(nxt, 1.0)
        assert msg.get_type() == "ATTITUDE" and rx_s > 0
        await msgs.aclose()
        assert f.listeners == []

    asyncio.run(main())


async def test_pose_subscribers_are_called_by_the_reader_with_each_new_pose() -> None:
    """Over a real UDP link: every new valid pose reaches an ``on_pose`` subscriber in the
    reader, as the vehicle state holds it (one call per pose, in order), and none after the
    subscription ended."""
    async with linked() as (ap, _peer):
        await ap.request_streams()
        seen: list[tuple[PoseSample, PoseSample | None]] = []

        def on_pose(sample: PoseSample) -> None:
            seen.append((sample, ap.state.pose))

        unsubscribe = ap.telemetry.on_pose(on_pose)
        await until(lambda: len(seen) >= 5, 5.0, "five poses through the subscription")
        unsubscribe()
        unsubscribe()  # twice is harmless
        n = len(seen)
        assert all(sample is state_pose for sample, state_pose in seen)  # the pose just read
        times = [sample.time_boot_ms for sample, _ in seen]
        assert times == sorted(set(times))  # each new pose once, in order
        last_ms = times[-1]
        await until(
            lambda: (p := ap.state.pose) is not None and p.time_boot_ms > last_ms + 100,
            5.0,
            "more poses read after the subscription ended",
        )
        assert len(seen) == n
