"""Never command what the ground cannot deliver: a speed cap per medium and mode. Pure.

Where the ground profile (:mod:`helixd.control.ground_fit`) knows what a medium delivers in a
mode, the speed the navigator commands there is capped (docs/physics.md, "The speed cap").
The scrolls turn at most ``output_clamp`` · ``max_rpm``, so a mode's axis moves at most

    v_full = r · ω_max · output_clamp                       (eq. 1, all four scrolls at full)

without slip, and a ground that delivers the fraction f of it at most f · v_full. The slip
feed-forward multiplies the navigator's command v by g(f) = min(max_gain, 1/f) (1 below
``stuck_fraction``: :func:`helixd.control.slip.feed_forward_gain`) before it reaches the
scrolls, and the rover moves at v · min(1, f · g). The cap keeps the scrolls' demand v · g
inside ``margin`` · v_full:

    v_cap = margin · v_full / g(f)

Where the feed-forward makes the slip up (f ≥ 1/max_gain) that is margin · f · v_full: the
command is at most the share ``margin`` of what the ground delivers at full speed. Where it
cannot (f < 1/max_gain) the command is delivered only f · g of it whatever its size, and a
lower cap would only slow the rover further; the cap then keeps the scrolls out of saturation
(margin · v_full / max_gain). A leg gets the lowest cap of the media it crosses
(:func:`leg_cap_mps`); the navigator and the time estimate fly the leg's cruise at most at it
(:func:`leg_cruise_mps`, :func:`capped_leg_speeds_mps`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

from helixd.base.media import Medium
from helixd.base.plan import MotionMode, Plan, PlanWaypoint
from helixd.control.ground_fit import DRIVEN
from helixd.control.kinematics import rpm_to_radps
from helixd.control.params import SlipParams, VehicleParams
from helixd.control.slip import feed_forward_gain


def full_speed_mps(vehicle: VehicleParams) -> float:
    """v_full: a mode's axis with all four scrolls at ``output_clamp`` · ``max_rpm`` and no
    slip (eq. 1: v = r · ω along the driven axis)."""
    return vehicle.scroll_radius_m * rpm_to_radps(vehicle.max_rpm) * vehicle.output_clamp


def speed_cap_mps(
    fraction: float, full_speed: float, margin: float, slip: SlipParams
) -> float | None:
    """v_cap = margin · v_full / g(f) for a ground that delivers ``fraction`` of the no-slip
    motion (module docstring); None where the fraction says nothing (not finite, ≤ 0)."""
    if not (math.isfinite(fraction) and fraction > 0.0):
        return None
    gain = feed_forward_gain(fraction, slip) if slip.enabled else 1.0
    return margin * full_speed / gain


def leg_cap_mps(
    media: Iterable[Medium],
    mode: MotionMode,
    fraction_of: Callable[[Medium, str], float | None],
    full_speed: float,
    margin: float,
    slip: SlipParams,
) -> float | None:
    """The lowest cap over the ``media`` a leg flown in ``mode`` crosses, each on the axes
    that mode drives; ``fraction_of(medium, axis)`` is what the profile knows (None: too
    little, no cap from it). None: nothing known on the leg."""
    caps = []
    for medium in media:
        for axis in DRIVEN[mode]:
            fraction = fraction_of(medium, axis)
            if fraction is None:
                continue
            cap = speed_cap_mps(fraction, full_speed, margin, slip)
            if cap is not None:
                caps.append(cap)
    return min(caps) if caps else None


def leg_cruise_mps(cruise_mps: float, waypoint: PlanWaypoint) -> float:
    """The cruise on the leg to ``waypoint``: at most its ground's cap."""
    cap = waypoint.speed_cap_mps
    return cruise_mps if cap is None else min(cruise_mps, cap)


def capped_leg_speeds_mps(plan: Plan) -> list[float]:
    """Per leg the cruise the program sets (:meth:`Plan.leg_speeds_mps`), at most its cap."""
    return [
        leg_cruise_mps(cruise, wp)
        for cruise, wp in zip(plan.leg_speeds_mps(), plan.waypoints, strict=True)
    ]


__all__ = [
    "capped_leg_speeds_mps",
    "full_speed_mps",
    "leg_cap_mps",
    "leg_cruise_mps",
    "speed_cap_mps",
]
