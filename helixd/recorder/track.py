"""Track metrics from an outside observer's view (pure): how well a driven path followed the plan.

Used where the daemon's own estimate is not the judge: the built-in simulator's true pose and
real SITL's LOCAL_POSITION_NED seen on a second link. Same figures as the run summary's:

* cross-track: distance of each sampled position to the *planned polyline* (start position →
  waypoint 1 → … → last waypoint), the nearest leg; an observer does not know which leg the
  daemon considered active, so the nearest one is the honest choice. RMS is weighted by time
  (each sample stands for half the interval to each neighbour), so a 10 Hz SITL stream and a
  200 Hz simulator poll weigh the same track the same way;
* final error: distance from where the rover came to rest to the last waypoint;
* elapsed: from the last sample at rest at the start to the first sample of the final rest.
  "At rest" = within ``rest_tolerance_m`` of the first (resp. last) sample.

Total: a non-finite coordinate or time raises :class:`helixd.base.geometry.NonFiniteError`; a track
with fewer than two samples, or a polyline without a point, has no metrics (None).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from helixd.base.frames import MissionFrame
from helixd.base.geometry import require_finite

NE = tuple[float, float]  # (north_m, east_m)


@dataclass(frozen=True, slots=True)
class TrackPoint:
    t_s: float  # any monotonic clock (autopilot time for SITL, simulated time for the sim)
    north_m: float
    east_m: float


@dataclass(frozen=True, slots=True)
class TrackMetrics:
    cross_track_rms_m: float
    cross_track_max_m: float
    final_error_m: float
    elapsed_s: float
    samples: int  # in the mission window

    def line(self) -> str:
        return (
            f"cross-track rms {self.cross_track_rms_m:.3f} m max {self.cross_track_max_m:.3f} m, "
            f"final error {self.final_error_m:.3f} m, {self.elapsed_s:.1f} s "
            f"({self.samples} samples)"
        )


def planned_polyline_ned(
    points_xy_m: Sequence[tuple[float, float]], frame: MissionFrame, start_ne_m: NE
) -> list[NE]:
    """The planned legs in NED: the start position, then every waypoint through ``frame``."""
    require_finite("start position", *start_ne_m)
    return [start_ne_m, *(frame.to_ned(x, y) for x, y in points_xy_m)]


def distance_to_segment_m(p: NE, a: NE, b: NE) -> float:
    """Euclidean distance from ``p`` to the segment ``a``–``b`` (a point if a == b)."""
    require_finite("segment distance input", *p, *a, *b)
    dn, de = b[0] - a[0], b[1] - a[1]
    length_sq = dn * dn + de * de
    u = 0.0
    if length_sq > 0.0:
        u = max(0.0, min(1.0, ((p[0] - a[0]) * dn + (p[1] - a[1]) * de) / length_sq))
    return math.hypot(p[0] - (a[0] + u * dn), p[1] - (a[1] + u * de))


def distance_to_polyline_m(p: NE, polyline: Sequence[NE]) -> float:
    """Distance from ``p`` to the nearest leg of ``polyline`` (≥ 1 point)."""
    if not polyline:
        raise ValueError("empty polyline")
    if len(polyline) == 1:
        return distance_to_segment_m(p, polyline[0], polyline[0])
    return min(
        distance_to_segment_m(p, polyline[i], polyline[i + 1]) for i in range(len(polyline) - 1)
    )


def mission_window(track: Sequence[TrackPoint], rest_tolerance_m: float) -> tuple[int, int]:
    """Indices (first, last) of the driven part: last sample still at the start position, first
    sample of the final rest position. The whole track if it never moves."""
    first, last = track[0], track[-1]
    start = 0
    for i, p in enumerate(track):
        if math.hypot(p.north_m - first.north_m, p.east_m - first.east_m) > rest_tolerance_m:
            start = max(0, i - 1)
            break
    else:
        return 0, len(track) - 1
    end = len(track) - 1
    for i in range(len(track) - 1, start - 1, -1):
        p = track[i]
        if math.hypot(p.north_m - last.north_m, p.east_m - last.east_m) > rest_tolerance_m:
            break
        end = i
    return start, max(start, end)


def track_metrics(
    track: Sequence[TrackPoint], polyline: Sequence[NE], rest_tolerance_m: float = 0.05
) -> TrackMetrics | None:
    """Cross-track RMS/max against ``polyline``, final error to its last point, elapsed time."""
    for p in track:
        require_finite("track sample", p.t_s, p.north_m, p.east_m)
    for q in polyline:
        require_finite("planned point", *q)
    require_finite("rest tolerance", rest_tolerance_m)
    if len(track) < 2 or not polyline:
        return None
    i0, i1 = mission_window(track, max(0.0, rest_tolerance_m))
    window = track[i0 : i1 + 1]
    dist = [distance_to_polyline_m((p.north_m, p.east_m), polyline) for p in window]
    weights = []
    for i in range(len(window)):
        lo = window[max(0, i - 1)].t_s
        hi = window[min(len(window) - 1, i + 1)].t_s
        weights.append(max(0.0, hi - lo) / 2.0)
    total = sum(weights)
    if total > 0.0:
        rms = math.sqrt(sum(w * d * d for w, d in zip(weights, dist, strict=True)) / total)
    else:  # all samples at one instant: plain mean
        rms = math.sqrt(sum(d * d for d in dist) / len(dist))
    end = track[-1]
    goal = polyline[-1]
    return TrackMetrics(
        cross_track_rms_m=rms,
        cross_track_max_m=max(dist),
        final_error_m=math.hypot(end.north_m - goal[0], end.east_m - goal[1]),
        elapsed_s=window[-1].t_s - window[0].t_s,
        samples=len(window),
    )
