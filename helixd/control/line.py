"""Line-tracking guidance: follow the leg (previous waypoint → waypoint), not the point.

Pure functions, stepped with numbers only.

Law (lookahead / line-of-sight family). With the leg direction χ_leg, the signed cross-track
error e (m, + left of the leg) and a lookahead distance L:

    χ_d = χ_leg − atan(e / L)

is the course the mode's driving axis is steered onto (ROLL: +x, ψ_ref = χ_d; SCROLL: +y,
ψ_ref = χ_d − π/2). OMNI holds its heading and moves along χ_d: its velocity is the leg speed
along the leg plus a lateral component −v·e/√(e² + L²) that removes the cross-track error.

Why this law (measured on the ideal plant, tests/unit/test_line_guidance.py):
* on a kinematic plant following χ_d exactly, de/ds = −e/√(e² + L²): the error decays
  monotonically (never crosses the line, so no overshoot and no limit cycle) — from 2 m it is
  under 0.10 m after ≈ 3.8 m of travel with L = 1 m; the yaw loop (kp 8 /s) adds a lag of
  ≈ v/kp = 0.075 m, well inside L;
* it is bounded for any error: far from the line χ_d tends to the perpendicular, never past it
  (a vector field has the same shape but one more gain to tune; Stanley's law needs the speed
  and divides by it, which is ill-defined at the v ≈ 0 the pivot turns start from);
* it reduces to "drive along the leg" on the line, so collinear waypoints are flown through.

Total: non-finite geometry raises :class:`NonFiniteError`; speed/rate helpers return 0
(neutral) for non-finite input, never their limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.angles import shortest_angular_distance, wrap_pi
from helixd.base.geometry import Pose2D, require_finite

MIN_LEG_M = 1e-6  # shorter legs have no direction: they are flown as a point


@dataclass(frozen=True, slots=True)
class LegErrors:
    """Where the rover is with respect to the leg start → end."""

    course_rad: float  # χ_leg, world direction of the leg (or of the bearing if degenerate)
    cross_track_m: float  # + left of the leg
    along_to_go_m: float  # distance to the end, measured along the leg (< 0: past its end)
    length_m: float


def leg_errors(
    start_xy_m: tuple[float, float], end_xy_m: tuple[float, float], pose: Pose2D
) -> LegErrors:
    """Errors of ``pose`` on the leg. A degenerate leg is replaced by the pose → end line."""
    ax, ay = start_xy_m
    bx, by = end_xy_m
    require_finite("leg input", ax, ay, bx, by, pose.x_m, pose.y_m)
    lx, ly = bx - ax, by - ay
    length = math.hypot(lx, ly)
    require_finite("leg length", length)
    if length < MIN_LEG_M:
        dx, dy = bx - pose.x_m, by - pose.y_m
        dist = math.hypot(dx, dy)
        require_finite("distance", dist)
        course = math.atan2(dy, dx) if dist > 0.0 else 0.0
        return LegErrors(course, 0.0, dist, 0.0)
    ux, uy = lx / length, ly / length
    px, py = pose.x_m - ax, pose.y_m - ay
    cross = ux * py - uy * px
    along = length - (ux * px + uy * py)
    require_finite("leg errors", cross, along)
    return LegErrors(math.atan2(ly, lx), cross, along, length)


def line_course_rad(leg_course_rad: float, cross_track_m: float, lookahead_m: float) -> float:
    """χ_d = χ_leg − atan(e / L): the course that converges on the line."""
    require_finite("line course input", leg_course_rad, cross_track_m, lookahead_m)
    if lookahead_m <= 0.0:
        raise ValueError(f"lookahead must be > 0, got {lookahead_m}")
    return wrap_pi(leg_course_rad - math.atan2(cross_track_m, lookahead_m))


def turn_angle_rad(
    a_xy_m: tuple[float, float], b_xy_m: tuple[float, float], c_xy_m: tuple[float, float]
) -> float:
    """|direction change| at b of the path a → b → c, in [0, π]; 0 if a leg is degenerate."""
    require_finite("turn input", *a_xy_m, *b_xy_m, *c_xy_m)
    l1 = (b_xy_m[0] - a_xy_m[0], b_xy_m[1] - a_xy_m[1])
    l2 = (c_xy_m[0] - b_xy_m[0], c_xy_m[1] - b_xy_m[1])
    if math.hypot(*l1) < MIN_LEG_M or math.hypot(*l2) < MIN_LEG_M:
        return 0.0
    return abs(shortest_angular_distance(math.atan2(l1[1], l1[0]), math.atan2(l2[1], l2[0])))


def corner_speed_mps(
    turn_rad: float,
    cruise_mps: float,
    lookahead_m: float,
    max_lateral_accel_mps2: float,
    max_yaw_rate_radps: float,
) -> float:
    """Speed a gentle corner can be flown at.

    The lookahead law rounds a corner of turn θ with an arc tangent to both legs about L
    from the vertex: R = L / tan(θ/2). Lateral acceleration v²/R ≤ a_lat and yaw rate
    v/R ≤ ω_max give v ≤ min(v_cruise, √(a_lat·R), ω_max·R). θ = 0 (collinear) → v_cruise.
    """
    inputs = (turn_rad, cruise_mps, lookahead_m, max_lateral_accel_mps2, max_yaw_rate_radps)
    if not all(math.isfinite(x) for x in inputs):
        return 0.0
    half = min(abs(turn_rad), math.pi) / 2.0
    if half < 1e-9:
        return max(0.0, cruise_mps)
    radius = lookahead_m / math.tan(half) if half < math.pi / 2 else 0.0
    v = min(
        cruise_mps,
        math.sqrt(max(0.0, max_lateral_accel_mps2 * radius)),
        max_yaw_rate_radps * radius,
    )
    return max(0.0, v)


def waypoint_speed_limits(
    points_xy_m: list[tuple[float, float]],
    stop_at: list[bool],
    cruise_mps: float,
    pivot_angle_rad: float,
    lookahead_m: float,
    max_lateral_accel_mps2: float,
    max_yaw_rate_radps: float,
) -> tuple[list[float], list[bool]]:
    """For each waypoint: the speed to pass it at, and whether it is a stop (pivot/final).

    ``points_xy_m[0]`` is the start of the first leg. The last waypoint and those flagged in
    ``stop_at`` (final heading) are stops; a corner turning more than ``pivot_angle_rad`` is
    a stop (pivot); the rest are flown at :func:`corner_speed_mps`.
    """
    for point in points_xy_m:
        require_finite("path point", *point)
    wps = points_xy_m[1:]
    n = len(wps)
    speeds = [0.0] * n
    stops = [True] * n
    for i in range(n - 1):
        if stop_at[i]:
            continue
        turn = turn_angle_rad(points_xy_m[i], wps[i], wps[i + 1])
        if turn > pivot_angle_rad:
            continue
        stops[i] = False
        speeds[i] = corner_speed_mps(
            turn, cruise_mps, lookahead_m, max_lateral_accel_mps2, max_yaw_rate_radps
        )
    return speeds, stops


def braking_speed_mps(distance_m: float, end_speed_mps: float, accel_mps2: float) -> float:
    """Highest speed from which ``end_speed`` is reached within ``distance`` at ``accel``:
    √(v_end² + 2·a·d). Non-finite input → 0."""
    if not (
        math.isfinite(distance_m) and math.isfinite(end_speed_mps) and math.isfinite(accel_mps2)
    ):
        return 0.0
    return math.sqrt(max(0.0, end_speed_mps**2 + 2.0 * max(0.0, accel_mps2) * max(0.0, distance_m)))


def profile_speed_mps(
    along_to_go_m: float,
    index: int,
    points_xy_m: list[tuple[float, float]],
    speeds_mps: list[float],
    accel_mps2: float,
    early_m: list[float] | None = None,
) -> float:
    """Speed allowed now so that every coming waypoint j ≥ index is passed at ≤ speeds[j],
    already ``early_m[j]`` before it (a flown-through waypoint ends its leg at its
    pass-through radius, so its corner speed must be reached there)."""
    if not (math.isfinite(along_to_go_m) and math.isfinite(accel_mps2)):
        return 0.0
    wps = points_xy_m[1:]
    best = math.inf
    distance = max(0.0, along_to_go_m)
    for j in range(index, len(speeds_mps)):
        if j > index:
            a, b = wps[j - 1], wps[j]
            distance += math.hypot(b[0] - a[0], b[1] - a[1])
        early = early_m[j] if early_m is not None else 0.0
        best = min(best, braking_speed_mps(distance - early, speeds_mps[j], accel_mps2))
        if speeds_mps[j] <= 0.0:
            break  # a stop: nothing beyond it matters yet
    return best if math.isfinite(best) else 0.0


def step_toward(previous: float, target: float, max_step: float) -> float:
    """``target`` reached from ``previous`` by at most ``max_step``; non-finite → 0."""
    if not (math.isfinite(previous) and math.isfinite(target) and math.isfinite(max_step)):
        return 0.0
    step = max(0.0, max_step)
    return max(previous - step, min(previous + step, target))


def step_toward_2d(
    previous: tuple[float, float], target: tuple[float, float], max_step: float
) -> tuple[float, float]:
    """Velocity ``target`` approached from ``previous`` with the acceleration limit applied
    in the target's own frame: the component along the target direction and the one across
    it each change by at most ``max_step`` (a new direction is entered along a straight line,
    and the old velocity across it is shed at the full rate: no drift past an OMNI corner).
    A zero target is approached along the previous direction. Non-finite → (0, 0)."""
    if not (
        math.isfinite(previous[0])
        and math.isfinite(previous[1])
        and math.isfinite(target[0])
        and math.isfinite(target[1])
        and math.isfinite(max_step)
    ):
        return 0.0, 0.0
    step = max(0.0, max_step)
    norm = math.hypot(*target)
    if not math.isfinite(norm):
        return 0.0, 0.0
    if norm < 1e-12:
        prev_norm = math.hypot(*previous)
        if not math.isfinite(prev_norm) or prev_norm <= step:
            return 0.0, 0.0
        k = (prev_norm - step) / prev_norm
        return previous[0] * k, previous[1] * k
    ux, uy = target[0] / norm, target[1] / norm
    along = step_toward(previous[0] * ux + previous[1] * uy, norm, step)
    across = step_toward(-previous[0] * uy + previous[1] * ux, 0.0, step)
    # never faster than both the previous and the target velocity
    cap = max(norm, math.hypot(*previous))
    size = math.hypot(along, across)
    if size > cap > 0.0:
        along, across = along * cap / size, across * cap / size
    return along * ux - across * uy, along * uy + across * ux


def stoppable_yaw_rate_radps(
    rate_radps: float, heading_error_rad: float, yaw_accel_radps2: float
) -> float:
    """Cap a yaw-rate command so the turn can brake within the heading error at the yaw
    acceleration limit: |ω| ≤ √(2·α·|e_ψ|). Non-finite → 0."""
    if not (
        math.isfinite(rate_radps)
        and math.isfinite(heading_error_rad)
        and math.isfinite(yaw_accel_radps2)
    ):
        return 0.0
    cap = math.sqrt(2.0 * max(0.0, yaw_accel_radps2) * abs(heading_error_rad))
    return max(-cap, min(cap, rate_radps))
