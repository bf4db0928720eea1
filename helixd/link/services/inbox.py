"""What the link plugins' sans-IO exchanges (the mission transfer, MAVLink FTP) share: the
bounded inbox an adapter keeps while one exchange runs (what the Autopilot's message listener
hands it, the oldest dropped when full, and ``get(timeout_s)`` for the exchange's ``recv``),
and the loop that drives an exchange over a link (:func:`drive`)."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any, Generic, Protocol, Self, TypeVar

__all__ = ["Exchange", "Inbox", "ListenerHost", "Listening", "drive"]

T = TypeVar("T")


class Exchange(Protocol):
    """A sans-IO exchange: what it sends first, what is due when nothing came in time, done
    and its error (None: it succeeded)."""

    @property
    def done(self) -> bool: ...

    @property
    def deadline_s(self) -> float: ...

    @property
    def error(self) -> Exception | None: ...

    def start(self, now_s: float) -> list[Any]: ...

    def on_time(self, now_s: float) -> list[Any]: ...


async def drive(
    exchange: Exchange,
    send: Callable[[Any], None],
    recv: Callable[[float], Awaitable[Any | None]],
    on_answer: Callable[[Any, float], list[Any]],
    clock: Callable[[], float],
) -> None:
    """Drive ``exchange`` over a link (``send``, ``recv`` with a timeout) until it ends, each
    answer to ``on_answer``; raises its error if it failed."""
    for first in exchange.start(clock()):
        send(first)
    while not exchange.done:
        wait_s = max(0.0, exchange.deadline_s - clock())
        answer = await recv(wait_s)
        t = clock()
        out = on_answer(answer, t) if answer is not None else []
        out += exchange.on_time(t)
        for nxt in out:
            send(nxt)
    if exchange.error is not None:
        raise exchange.error


class ListenerHost(Protocol):
    """Where an adapter hears the autopilot's messages (the Autopilot)."""

    def add_message_listener(self, callback: Callable[[Any, float], None]) -> None: ...

    def remove_message_listener(self, callback: Callable[[Any, float], None]) -> None: ...


class Listening:
    """A link adapter that hears the autopilot's messages (``_put``) while its ``with`` block
    runs, so the listener is removed after the exchange."""

    def __init__(self, host: ListenerHost) -> None:
        self._host = host

    def _put(self, msg: Any, rx_s: float) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        self._host.add_message_listener(self._put)
        return self

    def __exit__(self, *exc: object) -> None:
        self._host.remove_message_listener(self._put)


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
