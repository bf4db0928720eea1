"""A vehicle state fed as the link's reader feeds it (apply, wake the waiters, call the
listeners), for tests of the telemetry plugin and of what waits on it."""

from __future__ import annotations

import asyncio
import time
from typing import Any

from helixd.link.telemetry import ChangeWaiters, Telemetry
from helixd.link.vehicle import VehicleState


async def still_pending(fut: asyncio.Future[Any], window_s: float = 0.01) -> bool:
    """Wait on ``fut`` for ``window_s``: True if it did not complete (lets it start, too)."""
    done, _ = await asyncio.wait({fut}, timeout=window_s)
    return not done


class Feed:
    """The reader's part: apply a message, wake the waiters, call the listeners."""

    def __init__(self) -> None:
        self.state = VehicleState()
        self.waiters = ChangeWaiters()
        self.listeners: list[Any] = []
        self.telemetry = Telemetry(
            self.state, self.waiters, self.listeners.append, self.listeners.remove
        )

    def rx(self, msg: Any) -> None:
        rx_s = time.monotonic()
        self.waiters.wake(self.state.apply(msg, rx_s))
        for cb in list(self.listeners):
            cb(msg, rx_s)
