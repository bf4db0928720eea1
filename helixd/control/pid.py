"""PID controller with output limits, anti-windup and derivative on measurement.

    e(t) = wrap(setpoint − measurement)            (wrap only for angles)
    P    = kp · e
    I    = ki · ∫ e dt,  |I| ≤ integral_limit,  grown only until u reaches its limit (no windup)
    D    = −kd · d(measurement)/dt                 (no kick when the setpoint jumps)
    u    = clamp(P + I + D, ±output_limit)

Pure: the caller supplies dt (seconds); no clocks in here.

Total: a non-finite setpoint or measurement gives a zero (neutral) output and leaves the
controller's memory untouched; a non-finite sum of terms is never clamped to the limit
(``max(-l, min(l, nan))`` is the limit) but gives zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.angles import wrap_pi
from helixd.control.params import PidGainsParams


@dataclass(frozen=True, slots=True)
class PidTerms:
    """One PID update, split into its terms (for the flight recorder)."""

    p: float
    i: float
    d: float
    output: float

    @staticmethod
    def zero() -> PidTerms:
        return PidTerms(0.0, 0.0, 0.0, 0.0)


def _clamp(value: float, limit: float) -> float:
    """``value`` limited to ±``limit``; NaN → 0 (a NaN must never become the limit)."""
    if math.isnan(value):
        return 0.0
    return max(-limit, min(limit, value))


class PID:
    """Textbook PID for one scalar loop (parallel form, derivative on measurement).

    ``angular=True`` wraps the error and the measurement difference to (−π, π], so a yaw
    loop crossing ±π neither takes the long way round nor sees a 2π derivative spike.
    """

    def __init__(
        self, gains: PidGainsParams, output_limit: float, *, angular: bool = False
    ) -> None:
        if not output_limit > 0.0:
            raise ValueError(f"output_limit must be > 0, got {output_limit}")
        self.gains = gains
        self.output_limit = output_limit
        self.angular = angular
        self._integral = 0.0  # ki·∫e dt, already in output units
        self._prev_measurement: float | None = None

    def reset(self) -> None:
        """Forget the integral and the previous measurement (e.g. on a waypoint switch)."""
        self._integral = 0.0
        self._prev_measurement = None

    @property
    def integral(self) -> float:
        """The current integral term ki·∫e dt (output units)."""
        return self._integral

    def _difference(self, a: float, b: float) -> float:
        """a − b (wrapped to (−π, π] when angular); NaN when it overflows (huge finite a, b)."""
        diff = a - b
        if not math.isfinite(diff):
            return math.nan
        return wrap_pi(diff) if self.angular else diff

    def _integrate(self, increment: float, p_plus_d: float) -> float:
        """I + ki·e·dt, clamped to ±integral_limit, and grown only until the output reaches
        its limit (conditional integration): a saturated loop does not wind up, and the
        integral still moves freely back towards zero."""
        i_old = self._integral
        i_new = _clamp(i_old + increment, self.gains.integral_limit)
        if increment > 0.0:
            i_new = min(i_new, max(i_old, self.output_limit - p_plus_d))
        elif increment < 0.0:
            i_new = max(i_new, min(i_old, -self.output_limit - p_plus_d))
        return i_new

    def update(self, setpoint: float, measurement: float, dt_s: float) -> PidTerms:
        """One control step. With dt_s ≤ 0 (or not finite) only P and the held I act.

        A non-finite setpoint or measurement: zero output, state unchanged."""
        if not (math.isfinite(setpoint) and math.isfinite(measurement)):
            return PidTerms.zero()
        kp, ki, kd = self.gains.kp, self.gains.ki, self.gains.kd
        error = self._difference(setpoint, measurement)
        if not math.isfinite(error):
            return PidTerms.zero()  # the error itself overflows: neutral, state unchanged
        dt_ok = math.isfinite(dt_s) and dt_s > 0.0

        p = kp * error

        d = 0.0
        if dt_ok and self._prev_measurement is not None:
            d = -kd * self._difference(measurement, self._prev_measurement) / dt_s
            if not math.isfinite(d):
                d = 0.0  # a jump too large to differentiate: no derivative kick
        self._prev_measurement = measurement

        if dt_ok and ki > 0.0:
            increment = ki * error * dt_s
            if math.isfinite(increment) and math.isfinite(p + d):
                self._integral = self._integrate(increment, p + d)
        i = self._integral

        total = p + i + d
        output = _clamp(total, self.output_limit) if math.isfinite(total) else 0.0
        return PidTerms(p=p, i=i, d=d, output=output)
