"""The daemon's event loop: the standard asyncio loop, or uvloop when configured and installed.

Measured (tools/bench_control_loop.py runs both loops in the same run; bench/results): uvloop's
C loop does a UDP pose → override round trip through the loop in a third of the instructions
of asyncio's selector loop (98 500 → 32 600, callgrind micro-benchmark), but that part is a
few percent of a control step, and on the whole daemon the two loops measured within noise of
each other (CPU per step −1 % … +2 %, the autopilot's round-trip p99 better or worse by turns)
on this shared 2-core machine. Not a win, so not the default: ``link.event_loop: uvloop``
selects it (``pip install 'helixd[fast]'``; wheels for x86-64 and aarch64), and without the
package helixd says so and runs on the standard loop.
"""

from __future__ import annotations

import asyncio
import gc
import importlib.util
from collections.abc import Callable, Coroutine
from typing import Any, Literal, TypeVar

import structlog

from helixd.base.clock import SimulatedClockLoop

log = structlog.get_logger(__name__)
T = TypeVar("T")
EventLoopChoice = Literal["asyncio", "uvloop"]


def uvloop_available() -> bool:
    return importlib.util.find_spec("uvloop") is not None


def loop_factory(choice: EventLoopChoice) -> tuple[Callable[[], asyncio.AbstractEventLoop], str]:
    """(a new-loop factory, the loop's name) for ``choice``; uvloop falls back to the standard
    loop when it is not installed."""
    if choice == "uvloop" and uvloop_available():
        import uvloop

        return uvloop.new_event_loop, "uvloop"
    return asyncio.new_event_loop, "asyncio"


def run(
    coro: Coroutine[Any, Any, T], choice: EventLoopChoice = "asyncio", simulated: bool = False
) -> T:
    """``asyncio.run(coro)`` on the loop ``choice`` selects, or (``simulated``) on a
    :class:`helixd.base.clock.SimulatedClockLoop` whatever ``choice`` says."""
    factory, name = loop_factory(choice)
    if simulated:
        factory, name = SimulatedClockLoop, "simulated clock"
        log.info("event_loop", loop=name)
    elif name != choice:
        log.warning("event_loop_fallback", wanted=choice, loop=name, reason="uvloop not installed")
    else:
        log.info("event_loop", loop=name)
    settle_collector()
    with asyncio.Runner(loop_factory=factory) as runner:
        return runner.run(coro)


def settle_collector() -> None:
    """Collect once, then move everything alive (the imported modules, pymavlink's dialect,
    the validated config: ~110 000 objects) out of the collector's reach: its full passes in
    flight then scan only what the flight allocates. Without it a full pass over the startup
    heap stalls every task of the process for 0.05–0.4 s (measured on the 2-core build box),
    as long as the pose watchdog's whole budget when the simulator shares the process."""
    gc.collect()
    gc.freeze()


__all__ = ["EventLoopChoice", "loop_factory", "run", "settle_collector", "uvloop_available"]
