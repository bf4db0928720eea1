"""The three things helixd reads from asyncio that asyncio does not publish, in one place.

The simulated clock (:mod:`helixd.base.clock`) needs to know, from inside the loop's selector,
which timers the loop holds and how early it runs a timer; :func:`helixd.base.clock.now_s`
needs the running loop without raising outside one. asyncio keeps these as private names:

* ``asyncio._get_running_loop()`` — the running loop or ``None`` (no exception outside a loop,
  unlike ``asyncio.get_running_loop()``); listed in ``asyncio.events.__all__`` and part of
  asyncio's C accelerator, so the most stable of the three;
* ``BaseEventLoop._scheduled`` — the heap of pending ``TimerHandle``\\ s;
* ``BaseEventLoop._clock_resolution`` — how early a timer may run (``time.get_clock_info(
  'monotonic').resolution``, 1 ns on Linux).

Each is read here and nowhere else. :data:`CHECKED_PYTHON` names the versions whose asyncio
was read to confirm the names and meanings; ``tests/base/test_asyncio_internals.py`` checks on
the running interpreter that each still exists with its type and meaning, so a Python that
renames one fails that test by name instead of the simulated clock standing still.
"""

from __future__ import annotations

import asyncio

# CPython versions on which the three names were checked with their meaning (a timer made with
# call_later is in _scheduled; _clock_resolution is the monotonic clock's resolution;
# _get_running_loop is None outside a loop): 3.11.7, 3.12.1 and 3.13.0, 2026-11-28
CHECKED_PYTHON: tuple[tuple[int, int], ...] = ((3, 11), (3, 12), (3, 13))


def running_loop() -> asyncio.AbstractEventLoop | None:
    """The event loop running in this thread, or ``None`` outside one."""
    return asyncio._get_running_loop()


def scheduled_timers(loop: asyncio.AbstractEventLoop) -> list[asyncio.TimerHandle]:
    """The timers ``loop`` holds (cancelled ones included: check ``cancelled()``)."""
    timers: list[asyncio.TimerHandle] = getattr(loop, "_scheduled", [])
    return timers


def clock_resolution_s(loop: asyncio.AbstractEventLoop) -> float:
    """How far ahead of its time ``loop`` runs a due timer (s); 0 where the loop has none."""
    resolution_s: float = getattr(loop, "_clock_resolution", 0.0)
    return resolution_s


__all__ = ["CHECKED_PYTHON", "clock_resolution_s", "running_loop", "scheduled_timers"]
