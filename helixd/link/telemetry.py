"""The telemetry plugin: what the autopilot reports, as async streams (MAVSDK's shape).

``async for pose in ap.telemetry.pose()`` yields every new valid pose;
``ap.telemetry.pose_or_tick(tick_s)`` also yields None when ``tick_s`` passes without one (a
loop that must run its watchdogs whether or not poses come); ``ap.telemetry.messages()`` yields
every message of the autopilot's system with its receive time. The latest values are always
in ``ap.state`` (:class:`helixd.link.vehicle.VehicleState`), which the link's reader updates before
any of these wake.

The control loop does not wait on a stream: ``ap.telemetry.on_pose(callback)`` has the link's
reader call it with each new valid pose as the pose is read, so the command can leave in the
same wake-up as the datagram that carried the pose (no task switch, no future, no timer).

The waits here cost one future and one timer handle each (no ``wait_for`` wrapper).
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncGenerator, Callable
from typing import Any

from helixd.base.clock import now_s
from helixd.link.vehicle import Change, PoseSample, VehicleState

MavMsg = Any
MESSAGE_QUEUE_MAX = 1024  # a stream consumer this far behind loses the oldest messages


def _resolve(fut: asyncio.Future[bool], value: bool) -> None:
    if not fut.done():
        fut.set_result(value)


class ChangeWaiters:
    """Futures woken when :meth:`VehicleState.apply` reports a given change."""

    def __init__(self) -> None:
        self._waiters: dict[int, list[asyncio.Future[bool]]] = {}

    def wake(self, changes: int) -> None:
        for flag, futures in self._waiters.items():
            if flag & changes:
                for fut in futures:
                    if not fut.done():
                        fut.set_result(True)

    async def wait(self, flag: int, timeout_s: float) -> bool:
        """True when ``flag`` happened within ``timeout_s`` (or the link closed)."""
        if timeout_s <= 0:
            return False
        loop = asyncio.get_running_loop()
        fut: asyncio.Future[bool] = loop.create_future()
        bucket = self._waiters.setdefault(flag, [])
        bucket.append(fut)
        timer = loop.call_later(timeout_s, _resolve, fut, False)
        try:
            return await fut
        finally:
            timer.cancel()
            bucket.remove(fut)

    def release_all(self) -> None:
        """Wake every waiter (on close): they re-check their condition and time out normally."""
        for futures in self._waiters.values():
            for fut in futures:
                if not fut.done():
                    fut.set_result(True)


class Telemetry:
    """Streams over the vehicle state the link keeps up to date."""

    def __init__(
        self,
        state: VehicleState,
        waiters: ChangeWaiters,
        add_listener: Callable[[Callable[[MavMsg, float], None]], None],
        remove_listener: Callable[[Callable[[MavMsg, float], None]], None],
    ) -> None:
        self._state = state
        self._waiters = waiters
        self._add_listener = add_listener
        self._remove_listener = remove_listener
        self._pose_callbacks: list[Callable[[PoseSample], None]] = []

    def on_pose(self, callback: Callable[[PoseSample], None]) -> Callable[[], None]:
        """Have ``callback(pose)`` called with every new valid pose, by the link's reader as the
        pose is read (after the vehicle state took it, before the reader reads on). The
        callback runs inside the reader: it must not raise and must not block. Returns the
        function that ends the subscription."""
        self._pose_callbacks.append(callback)

        def unsubscribe() -> None:
            if callback in self._pose_callbacks:
                self._pose_callbacks.remove(callback)

        return unsubscribe

    def pose_read(self, sample: PoseSample) -> None:
        """The link's reader read a new valid pose (the vehicle state holds it): call the
        :meth:`on_pose` subscribers."""
        for callback in tuple(self._pose_callbacks):
            callback(sample)

    async def next_pose(self, after_rx_s: float | None, timeout_s: float) -> PoseSample | None:
        """The newest pose if it was read after ``after_rx_s``, else the next one to arrive.

        ``after_rx_s=None`` waits for the next pose. None on timeout.
        """
        pose = self._state.pose
        if pose is not None and after_rx_s is not None and pose.rx_monotonic_s > after_rx_s:
            return pose
        deadline = now_s() + timeout_s
        while await self._waiters.wait(Change.POSE, deadline - now_s()):
            pose = self._state.pose
            if pose is not None and (after_rx_s is None or pose.rx_monotonic_s > after_rx_s):
                return pose
        return None

    async def wait_for(
        self, holds: Callable[[VehicleState], bool], changes: int, timeout_s: float
    ) -> bool:
        """True as soon as ``holds(state)`` is true, re-checked whenever one of the
        ``changes`` (:class:`helixd.link.vehicle.Change` bits) is applied; False when it is
        still false after ``timeout_s``."""
        deadline = now_s() + timeout_s
        while not holds(self._state):
            remaining = deadline - now_s()
            if remaining <= 0:
                return False
            await self._waiters.wait(changes, remaining)
        return True

    async def pose(self) -> AsyncGenerator[PoseSample, None]:
        """Every new valid pose read after the stream started, as it arrives (none twice)."""
        last = now_s()
        while True:
            sample = await self.next_pose(last, math.inf)
            if sample is not None:
                last = sample.rx_monotonic_s
                yield sample

    async def pose_or_tick(self, tick_s: float) -> AsyncGenerator[PoseSample | None, None]:
        """Every new valid pose read after the stream started, or None whenever ``tick_s``
        passes without one."""
        last = now_s()
        while True:
            sample = await self.next_pose(last, tick_s)
            if sample is not None:
                last = sample.rx_monotonic_s
            yield sample

    async def messages(self) -> AsyncGenerator[tuple[MavMsg, float], None]:
        """Every message of the autopilot's system with its receive time (monotonic s), from
        the moment the stream is first awaited; a consumer more than ``MESSAGE_QUEUE_MAX``
        behind loses the oldest."""
        queue: asyncio.Queue[tuple[MavMsg, float]] = asyncio.Queue(MESSAGE_QUEUE_MAX)

        def put(msg: MavMsg, rx_s: float) -> None:
            if queue.full():
                queue.get_nowait()
            queue.put_nowait((msg, rx_s))

        self._add_listener(put)
        try:
            while True:
                yield await queue.get()
        finally:
            self._remove_listener(put)
