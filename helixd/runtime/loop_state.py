"""The flight loop's own bookkeeping, kept in small parts so that
:class:`helixd.runtime.flight.FlightLoop` reads as what it does with them: the control-rate
ceiling (:class:`StepCeiling`), the yaw rate measured from the poses (:class:`YawRateMeter`)
and what a flight that follows the autopilot's mode keeps of the crew's commands
(:class:`CrewState`). Pure: no I/O, no clock of their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from helixd.base.angles import wrap_pi
from helixd.runtime.mode_gate import Gate

CEILING_JITTER_FRACTION = 0.25  # of the ceiling's period: early arrivals still stepped


def ceiling_next_due(
    t_s: float, last_s: float, due_s: float, period_s: float, early_s: float
) -> float | None:
    """The control-rate ceiling (pure): whether the pose of autopilot time ``t_s`` is stepped
    on — then the time the next step is due, else None (thinned out).

    Steps keep to a schedule one ``period_s`` apart. A pose is stepped on from ``early_s``
    before its step is due (sample jitter: a pose at exactly the ceiling rate that comes a
    little early is not dropped), and the next step is then due one period after this one
    was due — not one period after the pose, so a late pose does not make the next, on-time
    one look early and get dropped. A flood faster than the ceiling is thinned to the
    ceiling's rate. A pose a whole period or more after its step was due (the first pose, a
    gap in the stream) restarts the schedule from itself; so does a clock that ran backwards
    (``t_s`` before the last pose stepped on, ``last_s``: an autopilot reboot), stepped on
    at once.
    """
    if t_s < last_s:
        return t_s + period_s
    if t_s < due_s - early_s:
        return None
    if t_s < due_s + period_s:
        return due_s + period_s
    return t_s + period_s


@dataclass(slots=True)
class StepCeiling:
    """The control-rate ceiling's schedule (:func:`ceiling_next_due`). It only thins out a
    pose flood, counted in autopilot time (pose ``time_boot_ms``), so a simulator speed-up
    does not lower the control rate the rover sees."""

    period_s: float  # 1 / control.control_rate_max_hz
    early_s: float = field(init=False)
    due_s: float = -math.inf  # autopilot time the next step is due
    last_s: float = -math.inf  # autopilot time of the last pose stepped on

    def __post_init__(self) -> None:
        self.early_s = CEILING_JITTER_FRACTION * self.period_s

    def take(self, t_s: float) -> bool:
        """Whether the pose of autopilot time ``t_s`` is stepped on (and counted as taken)."""
        due_s = ceiling_next_due(t_s, self.last_s, self.due_s, self.period_s, self.early_s)
        if due_s is None:
            return False
        self.last_s, self.due_s = t_s, due_s
        return True


@dataclass(slots=True)
class YawRateMeter:
    """The yaw rate measured from successive poses (rad/s, counter-clockwise positive: the
    mission frame's sense), for the stall watchdog and the slip fit."""

    radps: float = 0.0
    previous: tuple[float, float] | None = None  # (t_boot_s, yaw_ned_rad)

    def update(self, t_s: float, yaw_ned_rad: float) -> None:
        if not math.isfinite(yaw_ned_rad):
            return  # never stored by the vehicle state; belt and braces
        if self.previous is not None:
            dt = t_s - self.previous[0]
            if dt > 0:
                self.radps = -wrap_pi(yaw_ned_rad - self.previous[1]) / dt
        self.previous = (t_s, yaw_ned_rad)


@dataclass(slots=True)
class CrewState:
    """What a flight that follows the autopilot's mode (:mod:`helixd.runtime.mode_gate`)
    keeps of the crew's commands."""

    walk_items: tuple[int, ...] = ()  # a mission with commands: each step's item, in order
    gate: Gate = Gate.DRIVE  # what the autopilot's mode lets the flight do now
    item: int | None = None  # MISSION_CURRENT.seq last seen
    step: int | None = None  # the step of the walk the autopilot's item is on
    arrived: bool = False  # a flight to the autopilot's place: it is there (holds)


__all__ = [
    "CEILING_JITTER_FRACTION",
    "CrewState",
    "StepCeiling",
    "YawRateMeter",
    "ceiling_next_due",
]
