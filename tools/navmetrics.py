"""Navigation metrics for the benchmark: how far a driven path strays from the planned polygon.

Pure: numbers in, numbers out (no files, clocks or sockets). Used by ``bench_navigation.py``
on the simulator's TRUE pose; the geometry is :mod:`helixd.recorder.track`'s (the SITL
observer's nearest-leg distance) and :class:`helixd.base.frames.MissionFrame`.

* :func:`frame_from_flight` recovers the mission frame the daemon used (mission → NED) from the
  recorded estimated NED pose and mission-frame pose of ``flight.csv``;
* :func:`polyline_distance_m` is the distance of a point to the nearest leg of the planned path;
* :func:`path_metrics` gives RMS / max of that distance along a sampled path and the final error;
* :func:`scroll_effort` integrates Σ|scroll fraction| dt over the four scrolls.

Non-finite inputs are skipped (never propagated into a figure); an empty input gives None.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from helixd.base.frames import MissionFrame, NedPose
from helixd.recorder.track import distance_to_polyline_m, distance_to_segment_m
from helixd.recorder.track import planned_polyline_ned as track_polyline_ned

Point = tuple[float, float]


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def segment_distance_m(a: Point, b: Point, p: Point) -> float:
    """Unsigned distance of ``p`` to the segment a–b; NaN if any coordinate is not finite.

    The geometry is :func:`helixd.recorder.track.distance_to_segment_m` (the SITL observer's);
    this wrapper only turns a non-finite sample into NaN so a path can skip it.
    """
    if not _finite(*a, *b, *p):
        return math.nan
    return distance_to_segment_m(p, a, b)


def polyline_distance_m(polyline: Sequence[Point], p: Point) -> float:
    """Distance of ``p`` to the nearest segment of ``polyline`` (to the point if only one).

    ValueError on an empty polyline; NaN for a non-finite point.
    """
    if not polyline:
        raise ValueError("empty polyline")
    if not _finite(*p) or not all(_finite(*q) for q in polyline):
        return math.nan
    return distance_to_polyline_m(p, polyline)


@dataclass(frozen=True, slots=True)
class PathMetrics:
    samples: int  # finite path points measured
    xt_rms_m: float | None  # RMS distance to the planned legs
    xt_max_m: float | None  # max distance to the planned legs
    final_error_m: float | None  # last finite path point to the final waypoint


def path_metrics(path: Sequence[Point], polyline: Sequence[Point]) -> PathMetrics:
    """RMS/max distance of each finite path point to ``polyline``; final error to its end.

    Samples are weighted equally, so sample the path evenly in time (as the control loop and
    the simulator do).
    """
    if not polyline or not all(_finite(*q) for q in polyline):
        raise ValueError("polyline must be non-empty and finite")
    sq = 0.0
    worst = 0.0
    n = 0
    last: Point | None = None
    for p in path:
        d = polyline_distance_m(polyline, p)
        if not math.isfinite(d):
            continue
        sq += d * d
        worst = max(worst, d)
        n += 1
        last = p
    if n == 0 or last is None:
        return PathMetrics(0, None, None, None)
    end = polyline[-1]
    return PathMetrics(
        samples=n,
        xt_rms_m=math.sqrt(sq / n),
        xt_max_m=worst,
        final_error_m=math.hypot(last[0] - end[0], last[1] - end[1]),
    )


def frame_from_flight(
    north_m: Sequence[float],
    east_m: Sequence[float],
    yaw_ned_rad: Sequence[float],
    x_m: Sequence[float],
    y_m: Sequence[float],
    yaw_rad: Sequence[float],
) -> MissionFrame | None:
    """The mission frame (mission → NED) the daemon used, from the pose it recorded both ways.

    Every helixd mission frame maps ``(x, y)`` to NED by a reflection about an axis at yaw
    ``o`` plus an offset: ``N = oN + x cos o + y sin o``, ``E = oE + x sin o − y cos o`` with
    ``o = yaw_ned + yaw`` (see :class:`MissionFrame`; the ENU frames are ``o = π/2`` at the
    origin). Each finite row gives one estimate; the circular mean of ``o`` and the mean
    offset are returned (None without a finite row).
    """
    sin_sum = cos_sum = 0.0
    rows: list[tuple[float, float, float, float]] = []
    for n, e, yn, x, y, yw in zip(north_m, east_m, yaw_ned_rad, x_m, y_m, yaw_rad, strict=True):
        if not _finite(n, e, yn, x, y, yw):
            continue
        o = yn + yw
        sin_sum += math.sin(o)
        cos_sum += math.cos(o)
        rows.append((n, e, x, y))
    if not rows or math.hypot(sin_sum, cos_sum) < 1e-9 * len(rows):
        return None
    o = math.atan2(sin_sum, cos_sum)
    c, s = math.cos(o), math.sin(o)
    on = sum(n - (x * c + y * s) for n, _, x, y in rows) / len(rows)
    oe = sum(e - (x * s - y * c) for _, e, x, y in rows) / len(rows)
    return MissionFrame.start_at(NedPose(on, oe, o))


def planned_polyline_ned(
    frame: MissionFrame, start_xy_m: Point, waypoints_xy_m: Sequence[Point]
) -> list[Point]:
    """The planned legs in NED (north, east): the start pose, then every waypoint."""
    return track_polyline_ned(waypoints_xy_m, frame, frame.to_ned(*start_xy_m))


def scroll_effort(t_s: Sequence[float], fractions: Sequence[Sequence[float]]) -> float | None:
    """∫ Σ_i |fraction_i| dt over the scrolls (fraction-seconds; 4 scrolls flat out for 1 s = 4).

    ``fractions`` holds one sequence per scroll, each as long as ``t_s``. Each step holds the
    command of its row until the next row (zero-order hold, as the override is held). A step
    with a non-finite or non-increasing time is skipped; a non-finite fraction counts 0.
    None with fewer than two rows.
    """
    if len(t_s) < 2:
        return None
    for column in fractions:
        if len(column) != len(t_s):
            raise ValueError("every scroll column must be as long as the time column")
    total = 0.0
    for i in range(len(t_s) - 1):
        dt = t_s[i + 1] - t_s[i]
        if not math.isfinite(dt) or dt <= 0.0:
            continue
        total += dt * sum(abs(col[i]) for col in fractions if math.isfinite(col[i]))
    return total


def clip_to_window(
    samples: Sequence[tuple[float, float, float]], t_first_s: float, t_last_s: float
) -> list[Point]:
    """``(t, north, east)`` samples within [t_first, t_last] → (north, east) points."""
    return [(n, e) for t, n, e in samples if t_first_s <= t <= t_last_s]


def ratio(new: float | None, base: float | None) -> float | None:
    """new / base, None if either is missing or the base is not positive."""
    if new is None or base is None or not _finite(new, base) or base <= 0.0:
        return None
    return new / base


__all__ = [
    "PathMetrics",
    "clip_to_window",
    "frame_from_flight",
    "path_metrics",
    "planned_polyline_ned",
    "polyline_distance_m",
    "ratio",
    "scroll_effort",
    "segment_distance_m",
]
