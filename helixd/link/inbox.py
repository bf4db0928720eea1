"""The bounded inbox a link plugin's adapter keeps while one exchange runs (the FTP and the
mission adapters): what the Autopilot's message listener hands it, the oldest dropped when
full, and ``get(timeout_s)`` for the exchange's ``recv``."""

from __future__ import annotations

import asyncio
from typing import Generic, TypeVar

__all__ = ["Inbox"]

T = TypeVar("T")


class Inbox(Generic[T]):
    """A queue of at most ``maxsize`` items; a put to a full inbox drops the oldest."""

    def __init__(self, maxsize: int) -> None:
        self._queue: asyncio.Queue[T] = asyncio.Queue(maxsize)
        self.dropped = 0  # items dropped because the inbox was full

    def put(self, item: T) -> None:
        if self._queue.full():
            self._queue.get_nowait()
            self.dropped += 1
        self._queue.put_nowait(item)

    async def get(self, timeout_s: float) -> T | None:
        """The next item: at once when one waits, else within ``timeout_s`` (None: none)."""
        if not self._queue.empty():
            return self._queue.get_nowait()
        if timeout_s <= 0:
            return None
        try:
            async with asyncio.timeout(timeout_s):
                return await self._queue.get()
        except TimeoutError:
            return None
