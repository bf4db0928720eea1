"""Is the machine keeping the asked speed-up? (pure; the wall-clock shell feeds it)

On the wall clock the simulator wakes once per loop of simulated time (``dt_s``) divided by
the speed-up, and runs the loops that fell due since. On time that is one loop per wake-up.
A machine that cannot keep up — the simulator's thread starved by the daemon beside it (one
interpreter: ``run --sim``), by the control loop's work, by other processes — wakes late and
runs several loops at once: the poses go out in bursts, the control loop answers them late in
simulated time, and the flight is another flight (at ``--sim-speedup 10`` an
amphibious survey flew 898 s against a 548 s estimate, 0.76 m cross-track RMS instead of 0.03,
loops in the water, mode flips on the bank; the same at 4× or on the simulated clock was
right). So simulated time is judged per window: when the loops per wake-up (each counted up to
``loops_cap``, so one stall — a garbage collection — does not weigh like a slow machine)
average more than ``late_loops``, or simulated time advanced at less than ``slow_fraction``
of the asked rate, in ``windows`` windows in a row, the speed-up is lowered to what the
machine kept, and the shell says so at once (two windows of 2 simulated seconds: 0.4 s of
wall time at speed-up 10).

Measured on the shared 2-core build machine, the square at ``--sim-speedup`` 1 / 4 / 10
(``helixd run --sim``, the simulator's thread beside the daemon): loops per wake-up, each
counted up to 5, averaged 1.03 / 1.10 / 1.85 over the flight; the flight took 71.0 / 70.8 /
80.0-125.0 s of autopilot time (71 s is the flight: at 10x it was another one).

Judged only while the rover is armed (a flight: what a late loop would change), so a busy
start (the daemon importing, connecting, checking) does not count. At speed-up 1 nothing is
lowered: the judge says once that even real time is not kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# the lowest speed-up a lowering goes to: real time, as ArduPilot SITL runs by default
MIN_SPEEDUP = 1.0


@dataclass(frozen=True)
class PaceVerdict:
    """One window that did not keep the pace: what was asked, what was kept, what to run at
    now (``speedup`` equal to ``asked``: nothing lower to go to)."""

    asked: float
    speedup: float
    loops_per_wakeup: float
    achieved: float  # simulated seconds per wall second in the window

    def reason(self) -> str:
        return (
            f"{self.loops_per_wakeup:.1f} simulator loops per wake-up (1 on time), simulated "
            f"time at {self.achieved:.1f}x the wall: this machine cannot keep "
            f"speed-up {self.asked:g}"
        )


@dataclass
class PaceJudge:
    """Feed :meth:`wake` with every wake-up of the simulator's wall-clock loop."""

    dt_s: float  # one simulator loop (simulated s)
    window_sim_s: float = 2.0  # judged per this much simulated time
    late_loops: float = 1.5  # mean loops per wake-up above this: behind
    loops_cap: int = 5  # a wake-up's loops counted up to this many
    slow_fraction: float = 0.8  # simulated time below this fraction of the asked rate: behind
    windows: int = 2  # this many windows behind in a row: not kept
    _start_sim_s: float | None = None
    _start_wall_s: float = 0.0
    _loops: int = 0
    _wakeups: int = 0
    _behind: int = 0  # windows behind in a row
    _kept: float = math.inf  # the lowest pace kept in those windows

    def restart(self) -> None:
        self._start_sim_s = None
        self._behind = 0
        self._kept = math.inf

    def wake(
        self, wall_s: float, sim_s: float, loops: int, speedup: float, flying: bool
    ) -> PaceVerdict | None:
        """One wake-up at ``wall_s`` (after its ``loops`` loops: simulated time ``sim_s``) at
        ``speedup``; at the end of a window that was behind, the verdict (None otherwise)."""
        if not flying or not (math.isfinite(wall_s) and math.isfinite(sim_s)):
            self.restart()
            return None
        if self._start_sim_s is None:
            self._start_sim_s, self._start_wall_s = sim_s, wall_s
            self._loops = self._wakeups = 0
            return None
        self._loops += min(loops, self.loops_cap)
        self._wakeups += 1
        span_sim = sim_s - self._start_sim_s
        span_wall = wall_s - self._start_wall_s
        if span_sim < self.window_sim_s:
            return None
        wakeups, loops_sum = self._wakeups, self._loops
        self._start_sim_s, self._start_wall_s = sim_s, wall_s
        self._loops = self._wakeups = 0
        if span_wall <= 0.0:
            return None
        mean = loops_sum / wakeups
        achieved = span_sim / span_wall
        if mean <= self.late_loops and achieved >= self.slow_fraction * speedup:
            self._behind, self._kept = 0, math.inf
            return None
        self._behind += 1
        self._kept = min(self._kept, achieved, speedup / mean)
        if self._behind < self.windows:
            return None
        kept, self._behind, self._kept = self._kept, 0, math.inf
        lower = max(MIN_SPEEDUP, math.floor(kept * 10.0) / 10.0)
        return PaceVerdict(speedup, min(lower, speedup), mean, achieved)


__all__ = ["MIN_SPEEDUP", "PaceJudge", "PaceVerdict"]
