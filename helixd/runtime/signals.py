"""SIGINT/SIGTERM handling in the uvicorn style: the handlers only set flags.

First signal: ask the daemon to stop (it runs the fall-back to HOLD and exits).
Second signal: stop waiting — exit as soon as the fall-back has been *sent*.
"""

from __future__ import annotations

import asyncio
import signal
from dataclasses import dataclass, field

from helixd.safety.watchdogs import Fault, FaultCause


@dataclass
class StopRequest:
    """A request to end the flight: a signal (SIGINT/SIGTERM), or ``helixd serve``'s pause
    (the start switch low, DO_PAUSE_CONTINUE 0), which ends it the same way — scrolls stopped,
    overrides released, HOLD — but as a pause the service can continue from."""

    signal_name: str | None = None
    count: int = 0
    event: asyncio.Event = field(default_factory=asyncio.Event)
    paused: bool = False  # the first request was a pause, not a signal

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

    def pause(self, why: str) -> None:
        """End the flight as a pause (``why``: who asked, e.g. "start switch RC7 low")."""
        if self.count == 0:
            self.paused = True
        self.trigger(why)

    def fault(self) -> Fault:
        """How the flight ends on this request."""
        if self.paused:
            return Fault(FaultCause.PAUSED, f"{self.signal_name}")
        return Fault(FaultCause.SIGNAL, f"{self.signal_name} received")


def install(loop: asyncio.AbstractEventLoop, stop: StopRequest) -> None:
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.trigger, sig.name)


def uninstall(loop: asyncio.AbstractEventLoop) -> None:
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.remove_signal_handler(sig)
