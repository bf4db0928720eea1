"""When the map is wrong: notice from commanded against measured motion that the ground under
the rover is not what the media map says, and name the mode that works there. Pure.

The modes are the mode policy's (:class:`helixd.planning.media_modes.ModePolicy`, passed in
as ``firm_mode`` and ``soft_mode``: its modes for hard ground and for mud; ROLL and SCROLL
as the config ships). The rover flies the firm mode where the map says firm ground. Rolling
in mud delivers about 0.3 of the command and on hard ground 0.95 (docs/physics.md, the
traction table), whatever the slip feed-forward multiplies the command by: the check compares
the motion measured along the driving axis with the no-slip motion actually sent, over the
last ``window_m`` metres of commanded travel (commanded, so a rover that barely moves still
fills the window quickly). When the firm mode's delivered fraction over a full window falls
below ``roll_fraction`` the ground is soft: :meth:`GroundCheck.update` answers the soft mode,
once. A policy with one mode for both judges nothing (there is nothing to change to).

Back on firm ground, scrolling delivers less than in mud (hard 0.45, mud 0.85): while the
rover flies the soft mode because of the check, a full window below ``scroll_fraction -
hysteresis`` answers the firm mode (the planned mode) again. Only samples while the rover
drives along its axis count (a turn in place, a stop or an OMNI stretch do not), and a
change of mode starts a new window.

It does not flip back and forth on one ground (scrolling in water delivers about 0.6, close to
the firm threshold): a change back needs the fraction ``hysteresis`` below its threshold; after
a change the rover must have travelled ``min_change_m`` (delivered, not commanded) before the
check changes the mode again; and "firm again" is never answered where the caller says the
media map has ground the planned mode cannot move in (``firm_vetoed``: water, mud).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode

MIN_AXIS_SPEED_MPS = 0.05  # slower commands are a start or a stop, not a judgement of ground


@dataclass(frozen=True, slots=True)
class GroundCheckParams:
    firm_mode: MotionMode  # the policy's mode on firm ground: judged, and come back to
    soft_mode: MotionMode  # the policy's mode on soft ground: taken where the map is wrong
    window_m: float = 1.5  # commanded travel judged at once (m)
    roll_fraction: float = 0.6  # the firm mode delivering less than this: softer than mapped
    scroll_fraction: float = 0.55  # the soft mode (the check's) delivering less: firm again
    hysteresis: float = 0.05  # "firm again" needs the fraction this far below scroll_fraction
    min_change_m: float = 5.0  # travelled (delivered) after a change before the next one (m)


@dataclass(frozen=True, slots=True)
class GroundVerdict:
    """The check's answer: fly ``mode`` from now on (``soft``: the ground is softer than the
    map says; else firm again); ``fraction``: delivered over the window that decided, flown
    in ``judged``."""

    mode: MotionMode
    soft: bool
    fraction: float
    judged: MotionMode


class GroundCheck:
    """Feeds on (mode, the no-slip command sent, the body velocity measured, dt)."""

    def __init__(self, params: GroundCheckParams) -> None:
        self.params = params
        self._window: deque[tuple[float, float]] = deque()  # (commanded m, delivered m)
        self.reset()

    def reset(self) -> None:
        """A new leg, or the planned mode changed: start afresh."""
        self._window.clear()
        self._commanded_m = self._delivered_m = 0.0
        self._mode: MotionMode | None = None
        self.switched = False  # the rover flies the soft mode because of the check
        self._since_change_m = math.inf  # delivered since the check's last change

    def update(
        self,
        mode: MotionMode,
        sent: BodyVelocity,
        measured: BodyVelocity,
        dt_s: float,
        firm_vetoed: bool = False,
    ) -> GroundVerdict | None:
        """One control step; a verdict when the mode should change (else None).
        ``firm_vetoed``: the media map says the ground here (or within ``min_change_m``
        ahead) is one the planned mode cannot move in: never "firm again" there."""
        firm, soft = self.params.firm_mode, self.params.soft_mode
        if mode is MotionMode.OMNI or firm is soft or mode not in (firm, soft):
            return None
        if not (math.isfinite(dt_s) and 0.0 < dt_s < 1.0):
            return None
        if mode is not self._mode:
            self._window.clear()
            self._commanded_m = self._delivered_m = 0.0
            self._mode = mode
        scroll = mode is MotionMode.SCROLL
        cmd = sent.vy_mps if scroll else sent.vx_mps
        got = measured.vy_mps if scroll else measured.vx_mps
        if not (math.isfinite(cmd) and math.isfinite(got)) or abs(cmd) < MIN_AXIS_SPEED_MPS:
            return None
        commanded_m = abs(cmd) * dt_s
        delivered_m = max(0.0, got * math.copysign(1.0, cmd)) * dt_s
        self._window.append((commanded_m, delivered_m))
        self._since_change_m += delivered_m
        self._commanded_m += commanded_m
        self._delivered_m += delivered_m
        window_m = self.params.window_m
        while self._window and self._commanded_m - self._window[0][0] >= window_m:
            c, d = self._window.popleft()
            self._commanded_m -= c
            self._delivered_m -= d
        if self._commanded_m < window_m * 0.999 or self._since_change_m < self.params.min_change_m:
            return None
        fraction = self._delivered_m / self._commanded_m
        verdict: GroundVerdict | None = None
        if mode is firm and not self.switched and fraction < self.params.roll_fraction:
            verdict = GroundVerdict(soft, True, fraction, firm)
        firm_below = self.params.scroll_fraction - self.params.hysteresis
        if mode is soft and self.switched and not firm_vetoed and fraction < firm_below:
            verdict = GroundVerdict(firm, False, fraction, soft)
        if verdict is not None:
            self.switched = verdict.soft
            self._since_change_m = 0.0
        return verdict


__all__ = ["MIN_AXIS_SPEED_MPS", "GroundCheck", "GroundCheckParams", "GroundVerdict"]
