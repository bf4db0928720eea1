"""SIGINT/SIGTERM handling in the uvicorn style: the handlers only set flags.

First signal: ask the daemon to stop (it runs the fall-back to HOLD and exits).
Second signal: stop waiting — exit as soon as the fall-back has been *sent*.
"""

from __future__ import annotations

import asyncio
import signal
from dataclasses import dataclass, field


@dataclass
class StopRequest:
    signal_name: str | None = None
    count: int = 0
    event: asyncio.Event = field(default_factory=asyncio.Event)

    @property
    def requested(self) -> bool:
        return self.count > 0

    @property
    def forced(self) -> bool:
        return self.count > 1

    def trigger(self, name: str) -> None:
        self.count += 1
        self.signal_name = self.signal_name or name
        self.event.set()


def install(loop: asyncio.AbstractEventLoop, stop: StopRequest) -> None:
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.trigger, sig.name)


def uninstall(loop: asyncio.AbstractEventLoop) -> None:
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.remove_signal_handler(sig)
