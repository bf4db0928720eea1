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


def survey_block(
    transects: int = 6, length_m: float = 30.0, spacing_m: float = 3.0
) -> list[tuple[float, float]]:
    """A lawn-mower survey block from the start pose: ``transects`` parallel lines along +x,
    ``length_m`` long and ``spacing_m`` apart (stepping left, +y), joined by short crossovers;
    the turns alternate left-left, right-right. The first transect starts at the start pose."""
    pts = [(length_m, 0.0)]
    for k in range(1, transects):
        x_start = length_m if k % 2 == 1 else 0.0
        pts += [(x_start, k * spacing_m), (length_m - x_start, k * spacing_m)]
    return pts
