"""The daemon's event loop: uvloop when it is installed, the standard asyncio loop otherwise.

Measured (tools/bench_control_loop.py, the same run, and a UDP round-trip micro-benchmark
counted with callgrind): uvloop's C loop does a pose → override round trip in about a third
of the instructions of asyncio's selector loop. It is an optional dependency (``pip install
'helixd[fast]'``; wheels for x86-64 and aarch64), so helixd runs on the standard loop wherever
it is missing; ``link.event_loop: asyncio`` forces the standard loop.
"""

from __future__ import annotations

import asyncio
import importlib.util
from collections.abc import Callable, Coroutine
from typing import Any, Literal, TypeVar

import structlog

log = structlog.get_logger(__name__)
T = TypeVar("T")
EventLoopChoice = Literal["auto", "asyncio"]


def uvloop_available() -> bool:
    return importlib.util.find_spec("uvloop") is not None


def loop_factory(choice: EventLoopChoice) -> tuple[Callable[[], asyncio.AbstractEventLoop], str]:
    """(a new-loop factory, the loop's name) for ``choice``: ``auto`` is uvloop when installed."""
    if choice == "auto" and uvloop_available():
        import uvloop

        return uvloop.new_event_loop, "uvloop"
    return asyncio.new_event_loop, "asyncio"


def run(coro: Coroutine[Any, Any, T], choice: EventLoopChoice = "auto") -> T:
    """``asyncio.run(coro)`` on the loop ``choice`` selects."""
    factory, name = loop_factory(choice)
    log.info("event_loop", loop=name, choice=choice)
    with asyncio.Runner(loop_factory=factory) as runner:
        return runner.run(coro)


__all__ = ["EventLoopChoice", "loop_factory", "run", "uvloop_available"]
