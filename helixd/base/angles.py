"""Angle helpers (thesis Algorithm 1, with the sign fixed to read 'goal minus current').

Total: a non-finite angle has no direction, so these raise :class:`NonFiniteError` (a
ValueError the flight loop turns into neutral + a ``pose_invalid`` fault) instead of
returning NaN or failing inside ``math.fmod`` with "math domain error".
"""

from __future__ import annotations

import math

from helixd.base.geometry import require_finite

TWO_PI = 2.0 * math.pi


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to the half-open interval (−π, π].

    Angles already inside the interval are returned unchanged, so wrapping is idempotent
    (``(a + π) − π`` is not always ``a`` in floating point).
    """
    if -math.pi < angle_rad <= math.pi:  # the common case; NaN and ±inf compare False
        return angle_rad
    require_finite("angle", angle_rad)
    wrapped = math.fmod(angle_rad + math.pi, TWO_PI)
    if wrapped <= 0.0:
        wrapped += TWO_PI
    result = wrapped - math.pi
    # fmod rounding can land a hair outside; pin to the interval.
    if result <= -math.pi:
        return math.pi
    return min(result, math.pi)


def shortest_angular_distance(from_rad: float, to_rad: float) -> float:
    """Signed shortest rotation that takes ``from_rad`` onto ``to_rad``, in (−π, π]."""
    return wrap_pi(to_rad - from_rad)
