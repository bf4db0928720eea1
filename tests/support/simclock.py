"""Running a coroutine on the simulated clock (:class:`helixd.base.clock.SimulatedClockLoop`):
for time-driven code tested without waiting for the wall (trio's MockClock, as a loop)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from helixd.base.clock import SimulatedClockLoop

T = TypeVar("T")


def run_simulated(main: Callable[[], Coroutine[Any, Any, T]]) -> T:
    """``main()`` to its end on a fresh simulated-clock loop."""
    with asyncio.Runner(loop_factory=SimulatedClockLoop) as runner:
        return runner.run(main())
