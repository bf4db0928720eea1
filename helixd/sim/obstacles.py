"""Obstacles the simulated rover can run into: keep-out polygons and circles in local NED.

A contact is what happens in a pond: the rover's body (a disc of ``contact_radius_m``, by
default half its width, ``vehicle.ly_m / 2 + scroll_radius_m``) touches the pontoon and stops
there — the step that would move it closer is refused, its translation is zeroed, it may still
turn. That is all the simulator does about it on the wire, because that is all ArduPilot does:
Rover's only collision detector, ``crash_check()`` (Rover/crash_check.cpp, FS_CRASH_CHECK), runs
only in autopilot modes (AUTO, GUIDED, …) and returns at once in MANUAL, HOLD and ACRO, so while
helixd drives the scrolls through RC overrides in MANUAL no "Crash: Going to HOLD" STATUSTEXT
is ever sent. The fault is reported by the rover stopping: helixd's stall watchdog
(``safety.stall``: commanded speed, no measured speed) fires and the daemon stops the scrolls,
releases the overrides and asks for HOLD. For tests the simulator logs a ``contact`` history
event (not on the wire) with where it happened.

Pure: numbers in, numbers out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Annotated

from pydantic import AfterValidator, Field

from helixd.config import InputModel, KeepOutCircleConfig

if TYPE_CHECKING:  # physics imports sim.config, which imports this module
    from helixd.sim.physics import PhysicsState

PointNE = tuple[float, float]
CONTACT_RELEASE_M = 0.05  # a contact ends once the body is this far clear of the obstacle


def _polygons(
    value: tuple[tuple[PointNE, ...], ...],
) -> tuple[tuple[PointNE, ...], ...]:
    for i, poly in enumerate(value):
        if len(poly) < 3:
            raise ValueError(f"polygon {i}: needs at least 3 (north_m, east_m) vertices")
        if not all(math.isfinite(n) and math.isfinite(e) for n, e in poly):
            raise ValueError(f"polygon {i}: every vertex must be finite")
    return value


class SimObstacles(InputModel):
    polygons_ne_m: Annotated[tuple[tuple[PointNE, ...], ...], AfterValidator(_polygons)] = Field(
        (), max_length=1000, description="solid polygons, (north_m, east_m) vertices"
    )
    circles: tuple[KeepOutCircleConfig, ...] = Field(
        (), max_length=10_000, description="solid discs (north_m, east_m, radius_m)"
    )
    contact_radius_m: float = Field(
        0.429,
        gt=0.0,
        le=5.0,
        description="rover body radius for contact: half-width ly/2 + scroll radius (m)",
    )

    @property
    def empty(self) -> bool:
        return not (self.polygons_ne_m or self.circles)


def _inside(poly: Sequence[PointNE], n: float, e: float) -> bool:
    inside = False
    j = len(poly) - 1
    for i in range(len(poly)):
        (ni, ei), (nj, ej) = poly[i], poly[j]
        if (ei > e) != (ej > e) and n < (nj - ni) * (e - ei) / (ej - ei) + ni:
            inside = not inside
        j = i
    return inside


def _segment_distance(n: float, e: float, a: PointNE, b: PointNE) -> float:
    dn, de = b[0] - a[0], b[1] - a[1]
    seg2 = dn * dn + de * de
    t = 0.0 if seg2 == 0.0 else ((n - a[0]) * dn + (e - a[1]) * de) / seg2
    t = min(max(t, 0.0), 1.0)
    return math.hypot(n - a[0] - t * dn, e - a[1] - t * de)


def distance_m(obstacles: SimObstacles, north_m: float, east_m: float) -> float:
    """Distance from the point to the nearest obstacle (0 inside one; inf with none)."""
    best = math.inf
    for c in obstacles.circles:
        best = min(best, max(math.hypot(north_m - c.north_m, east_m - c.east_m) - c.radius_m, 0.0))
    for poly in obstacles.polygons_ne_m:
        if _inside(poly, north_m, east_m):
            return 0.0
        for i in range(len(poly)):
            best = min(best, _segment_distance(north_m, east_m, poly[i], poly[(i + 1) % len(poly)]))
    return best


def in_contact(obstacles: SimObstacles, state: PhysicsState) -> bool:
    return distance_m(obstacles, state.north_m, state.east_m) < obstacles.contact_radius_m


def constrain(
    obstacles: SimObstacles, before: PhysicsState, after: PhysicsState
) -> tuple[PhysicsState, bool]:
    """``after`` unless its body touches an obstacle and the step brought it closer: then the
    rover stays where it was (turning allowed), translation zeroed. Returns (state, contact)."""
    if obstacles.empty:
        return after, False
    d_after = distance_m(obstacles, after.north_m, after.east_m)
    if d_after >= obstacles.contact_radius_m:
        return after, False
    d_before = distance_m(obstacles, before.north_m, before.east_m)
    if d_after > d_before:  # moving away from the obstacle it touches: let it go
        return after, True
    blocked = replace(
        after,
        north_m=before.north_m,
        east_m=before.east_m,
        vx_body_mps=0.0,
        vy_body_mps=0.0,
        odometer_m=before.odometer_m,
    )
    return blocked, True


def contact_step(
    obstacles: SimObstacles, before: PhysicsState, after: PhysicsState, was_in_contact: bool
) -> tuple[PhysicsState, bool, tuple[str, dict[str, float]] | None]:
    """:func:`constrain` plus the history event (kind, details) when a contact starts or
    ends."""
    state, contact = constrain(obstacles, before, after)
    if was_in_contact and not contact:  # still pressed against it: no flicker of events
        gap = distance_m(obstacles, state.north_m, state.east_m)
        contact = gap < obstacles.contact_radius_m + CONTACT_RELEASE_M
    event: tuple[str, dict[str, float]] | None = None
    if contact and not was_in_contact:
        event = (
            "contact",
            {
                "north_m": round(state.north_m, 3),
                "east_m": round(state.east_m, 3),
                "distance_m": round(distance_m(obstacles, state.north_m, state.east_m), 3),
            },
        )
    elif was_in_contact and not contact:
        event = ("contact_end", {"north_m": state.north_m, "east_m": state.east_m})
    return state, contact, event
