"""The one clock helixd times itself by: the running event loop's.

Everything the daemon times (watchdogs, timeouts, the control period, heartbeats, stream
intervals, retries, progress, the recorder's ``t_mono_s``) reads :func:`now_s` and waits
with ``asyncio.sleep``/``asyncio.wait_for``; both follow the loop the program was started on,
chosen once at the top (``helixd.runtime.eventloop.run``), as trio's ``current_time()``
follows its run's clock:

* in production the standard loop (or uvloop), whose time is the monotonic clock;
* ``helixd run --sim --sim-clock simulated`` and the tests flying on it, a
  :class:`SimulatedClockLoop`: the simulator and the daemon share one loop, and its time jumps
  to the next timer whenever every task is waiting and no byte is ready on any socket. A
  flight then takes the CPU time it needs, not the minutes it lasts, and the same inputs
  give the same flight.

No module reads ``time.monotonic()`` for timing on its own (``tests/base/test_clock.py``
guards it). Calendar time that stamps a record of the flight (a .tlog) reads :func:`unix_s`;
dates that only name things (run directories) and MAVLink signing timestamps, which the
protocol ties to the calendar, stay on ``time.time()``/``datetime``.
"""

from __future__ import annotations

import asyncio
import selectors
import time
from typing import Any

from helixd.base.asyncio_internals import clock_resolution_s, running_loop, scheduled_timers

# where a simulated clock starts (s): like a monotonic clock, not at zero, so a "never"
# timestamp of 0.0 stays far in the past
SIMULATED_START_S = 1000.0
# wall seconds a simulated clock may stand still while the loop runs: longer means a task
# spins at one instant (it never waits), and the run is stopped with an error, not left hung
STUCK_WALL_S = 30.0
# ... over at least this many polls (one long computation between two polls is not a spin)
STUCK_POLLS = 1000


def unix_s() -> float:
    """Calendar seconds (Unix time) on the run's clock: the wall's in production; on a
    simulated clock the wall's when the loop was made plus the simulated time since, so a
    record stamped with it (a .tlog) replays at the pace it was flown."""
    loop = running_loop()
    return loop.unix_s() if isinstance(loop, SimulatedClockLoop) else time.time()


def on_simulated_clock() -> bool:
    """Is the running loop a :class:`SimulatedClockLoop` (``run --sim --sim-clock
    simulated``)? Its "monotonic" seconds are then simulated ones, not the wall's."""
    return isinstance(running_loop(), SimulatedClockLoop)


def now_s() -> float:
    """Seconds on the run's monotonic clock: the running loop's time; outside a loop (a
    thread, a synchronous command) the monotonic clock, which is the standard loop's time."""
    loop = running_loop()
    return time.monotonic() if loop is None else loop.time()


class _JumpingSelector(selectors.DefaultSelector):
    """The loop's selector: a poll first; when nothing is ready and the loop would wait for
    its next timer, the simulated clock jumps to that timer instead of the wall waiting."""

    def __init__(self) -> None:
        super().__init__()
        self.now_s = SIMULATED_START_S
        self.jumps = 0
        self.loop: asyncio.AbstractEventLoop | None = None  # set by the loop it serves
        self._moved_wall_s = time.monotonic()  # when the clock last moved (wall)
        self._still_polls = 0  # polls since

    def select(self, timeout: float | None = None) -> list[tuple[selectors.SelectorKey, int]]:
        ready = super().select(0)
        before_s = self.now_s
        if not ready and timeout is None:  # no timer at all: only another thread can wake it
            ready = super().select(None)
            self._moved_wall_s = time.monotonic()
            self._still_polls = 0
        elif not ready and timeout is not None and timeout > 0:
            self.now_s += timeout
            self.jumps += 1
        self._reach_due_timers()
        if self.now_s != before_s:
            self._moved_wall_s = time.monotonic()
            self._still_polls = 0
            return ready
        self._still_polls += 1
        if self._still_polls > STUCK_POLLS and time.monotonic() - self._moved_wall_s > STUCK_WALL_S:
            raise RuntimeError(
                f"the simulated clock stood still at {self.now_s!r} s for {STUCK_WALL_S:.0f} s "
                "of wall time: a task spins without ever waiting"
            )
        return ready

    def _reach_due_timers(self) -> None:
        """After a select asyncio runs every timer due within its clock resolution (1 ns),
        slightly before its time: a real clock gets there a moment later, a simulated one
        would stand still. The clock is moved to the latest such timer, so a task a timer
        wakes never reads a time before it (else a task waiting out ``deadline - now_s()``
        in steps would spin at one instant, its remainder never reaching zero)."""
        loop = self.loop
        if loop is None:
            return
        resolution_s = clock_resolution_s(loop)
        timers = scheduled_timers(loop)
        while True:
            due_s = latest_due_s(timers, self.now_s, self.now_s + resolution_s)
            if due_s is None:
                return
            self.now_s = due_s


def latest_due_s(
    timers: list[asyncio.TimerHandle], after_s: float, before_s: float
) -> float | None:
    """The latest time of a timer that is not cancelled, after ``after_s`` and before
    ``before_s`` (None: no such timer). ``timers`` is the loop's heap (a timer's children are
    due no earlier than it), so only the timers due before ``before_s`` are looked at, not
    every timer the loop holds: this runs at every poll of the loop."""
    latest_s: float | None = None
    count = len(timers)
    todo = [0] if count else []
    while todo:
        i = todo.pop()
        timer = timers[i]
        when_s = timer.when()
        if when_s >= before_s:
            continue  # neither it nor any timer below it in the heap
        if when_s > after_s and not timer.cancelled() and (latest_s is None or when_s > latest_s):
            latest_s = when_s
        left = 2 * i + 1
        if left < count:
            todo.append(left)
            if left + 1 < count:
                todo.append(left + 1)
    return latest_s


class SimulatedClockLoop(asyncio.SelectorEventLoop):
    """An asyncio loop on simulated time (see the module docstring). Its sockets are real;
    only waiting is skipped. Every task that times itself must run on this loop: a thread
    that sleeps on the wall clock does not hold simulated time back."""

    def __init__(self, start_s: float = SIMULATED_START_S) -> None:
        self._jumping = _JumpingSelector()
        self._jumping.now_s = start_s
        self._epoch_unix_s = time.time() - start_s
        super().__init__(self._jumping)
        self._jumping.loop = self

    def time(self) -> float:
        return self._jumping.now_s

    def unix_s(self) -> float:
        return self._epoch_unix_s + self._jumping.now_s

    @property
    def jumps(self) -> int:
        """How many times the clock jumped ahead (each a wait the wall did not make)."""
        return self._jumping.jumps

    def run_in_executor(  # type: ignore[override]
        self, executor: Any, func: Any, *args: Any
    ) -> asyncio.Future[Any]:
        raise RuntimeError(
            "a thread's work has no simulated duration: nothing on a simulated clock may use "
            "an executor (give hosts as IP addresses)"
        )


__all__ = ["SIMULATED_START_S", "SimulatedClockLoop", "now_s", "on_simulated_clock", "unix_s"]
