"""Waypoint generators for the shipped missions (used by tools/make_missions.py)."""

from __future__ import annotations

import math


def square(side_m: float = 10.0) -> list[tuple[float, float]]:
    """Counter-clockwise square from the start pose: forward, left, back, home."""
    return [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]


def hexagon(side_m: float = 2.0) -> list[tuple[float, float]]:
    """Regular hexagon, CCW, first edge along +x from the start point; six vertices, last = home."""
    pts: list[tuple[float, float]] = []
    x = y = 0.0
    for k in range(6):
        heading = k * math.pi / 3
        x += side_m * math.cos(heading)
        y += side_m * math.sin(heading)
        pts.append((round(x, 4) + 0.0, round(y, 4) + 0.0))
    return pts


def circle(
    radius_m: float = 2.0, centre_m: tuple[float, float] = (2.0, 2.0), count: int = 25
) -> list[tuple[float, float]]:
    """``count`` points CCW on a circle starting at angle 0; the last closes the loop."""
    cx, cy = centre_m
    return [
        (
            round(cx + radius_m * math.cos(2 * math.pi * k / (count - 1)), 4) + 0.0,
            round(cy + radius_m * math.sin(2 * math.pi * k / (count - 1)), 4) + 0.0,
        )
        for k in range(count)
    ]
