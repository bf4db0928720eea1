"""The two clocks of a recorded run, and how to convert between them. Pure: no I/O.

* *autopilot time*: the autopilot's ``time_boot_ms`` (``flight.csv`` ``t_boot_s``). The
  mission's own clock; under a simulator speed-up it runs faster than the wall.
* *wall time*: the companion's monotonic clock (``flight.csv`` ``t_mono_s``; every event's
  ``t_mono_s``).

:class:`ClockMap` puts any monotonic instant (an event) on the autopilot clock, both measured
in seconds from the first control step, so ``helixd replay``, the plots and the result table
share one zero and one clock.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence


def autopilot_axis_s(t_boot_s: Sequence[float], t_mono_s: Sequence[float]) -> list[float] | None:
    """Autopilot time since the first row, non-decreasing; None without any autopilot time.

    Sums the autopilot clock's forward steps; a step that is not finite or goes back (an
    autopilot reboot) is bridged with the wall clock's step, so the axis never jumps back.
    """
    if len(t_boot_s) == 0 or not any(math.isfinite(t) for t in t_boot_s):
        return None
    axis = [0.0]
    for k in range(1, len(t_boot_s)):
        d_boot = t_boot_s[k] - t_boot_s[k - 1]
        if not math.isfinite(d_boot) or d_boot < 0:
            d_wall = t_mono_s[k] - t_mono_s[k - 1]
            d_boot = d_wall if math.isfinite(d_wall) and d_wall > 0 else 0.0
        axis.append(axis[-1] + d_boot)
    return axis


class ClockMap:
    """Monotonic instant → (autopilot s, wall s) since the first control step.

    Piecewise linear between recorded rows; outside them (setup before the first step, the
    stop after the last) a straight line with the run's average autopilot/wall rate — exact
    for a constant simulator speed-up, and 1:1 on a real autopilot.
    """

    def __init__(self, t_mono_s: Sequence[float], t_boot_s: Sequence[float]) -> None:
        pairs = [(m, b) for m, b in zip(t_mono_s, t_boot_s, strict=True) if math.isfinite(m)]
        pairs.sort(key=lambda p: p[0])
        self._mono = [m for m, _ in pairs]
        axis = autopilot_axis_s([b for _, b in pairs], self._mono)
        self._ap = axis
        self.has_rows = bool(self._mono)
        self.has_autopilot = axis is not None
        span_m = self._mono[-1] - self._mono[0] if self._mono else 0.0
        rate = (axis[-1] / span_m) if axis is not None and span_m > 0 else 1.0
        self.rate = rate if math.isfinite(rate) and rate > 0 else 1.0  # autopilot s per wall s

    @property
    def zero_mono_s(self) -> float | None:
        """Monotonic time of the first control step (None: nothing was recorded)."""
        return self._mono[0] if self._mono else None

    def wall_s(self, t_mono_s: float) -> float | None:
        zero = self.zero_mono_s
        return None if zero is None or not math.isfinite(t_mono_s) else t_mono_s - zero

    def autopilot_s(self, t_mono_s: float) -> float | None:
        """Autopilot seconds since the first control step at monotonic ``t_mono_s``."""
        ap, mono = self._ap, self._mono
        if ap is None or not mono or not math.isfinite(t_mono_s):
            return None
        if t_mono_s <= mono[0]:
            return (t_mono_s - mono[0]) * self.rate
        if t_mono_s >= mono[-1]:
            return ap[-1] + (t_mono_s - mono[-1]) * self.rate
        k = bisect.bisect_right(mono, t_mono_s)
        m0, m1 = mono[k - 1], mono[k]
        if m1 <= m0:
            return ap[k]
        return ap[k - 1] + (ap[k] - ap[k - 1]) * (t_mono_s - m0) / (m1 - m0)


__all__ = ["ClockMap", "autopilot_axis_s"]
