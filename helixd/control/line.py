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
from collections.abc import Sequence
from dataclasses import dataclass

from helixd.base.angles import shortest_angular_distance, wrap_pi
from helixd.base.geometry import Pose2D, require_finite
from helixd.base.plan import PlanWaypoint
from helixd.control.params import NavigatorParams

MIN_LEG_M = 1e-6  # shorter legs have no direction: they are flown as a point
COLLINEAR_RAD = 2e-6  # a corner turning less than this is a straight line (no arc needed)


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


@dataclass(frozen=True, slots=True)
class CornerArc:
    """The circular arc a flown-through corner is rounded with, tangent to both legs.

    The arc starts ``tangent_m`` before the vertex on the leg in and ends ``tangent_m`` after
    it on the leg out; its middle passes ``corner_error_m`` from the vertex (on the bisector,
    inside the turn). ``turn_rad`` is signed (+ left, counter-clockwise)."""

    vertex_xy_m: tuple[float, float]
    center_xy_m: tuple[float, float]
    radius_m: float
    tangent_m: float
    turn_rad: float
    speed_mps: float
    corner_error_m: float
    # u_in + u_out: (p − vertex)·this ≥ 0 once p is past the bisector (the arc's middle)
    mean_course_xy: tuple[float, float]

    @property
    def curvature_per_m(self) -> float:
        """Signed curvature 1/R (+ left)."""
        return math.copysign(1.0 / self.radius_m, self.turn_rad)


def corner_arc(
    a_xy_m: tuple[float, float],
    b_xy_m: tuple[float, float],
    c_xy_m: tuple[float, float],
    corner_error_m: float,
    cruise_mps: float,
    max_lateral_accel_mps2: float,
    max_yaw_rate_radps: float | None,
    min_speed_mps: float,
) -> CornerArc | None:
    """The arc that rounds the corner b of a → b → c, or None where the corner must be a stop.

    Radius: the largest of the arcs that (1) pass at most ``corner_error_m`` from the vertex,
    R·(1/cos(θ/2) − 1) ≤ e, (2) fit on half of each leg, R·tan(θ/2) ≤ min(|ab|, |bc|)/2, so
    the arcs of neighbouring corners never overlap, and (3) are no larger than needed to pass
    at cruise, R ≤ max(v²/a_lat, v/ω_max) (a larger one only moves farther from the corner).
    Speed: v = min(cruise, √(a_lat·R), ω_max·R) (``max_yaw_rate_radps`` None: no turn-rate
    limit).
    None when the corner is collinear (θ ≈ 0: no arc needed), a reversal (θ ≈ π), a leg is
    degenerate, or the arc could only be flown below ``min_speed_mps``: too sharp for the
    budget, a pivot is the better turn. Non-finite input → None.
    """
    values = (*a_xy_m, *b_xy_m, *c_xy_m, corner_error_m, cruise_mps, max_lateral_accel_mps2)
    if not all(math.isfinite(x) for x in values) or corner_error_m <= 0.0 or cruise_mps <= 0.0:
        return None
    l1x, l1y = b_xy_m[0] - a_xy_m[0], b_xy_m[1] - a_xy_m[1]
    l2x, l2y = c_xy_m[0] - b_xy_m[0], c_xy_m[1] - b_xy_m[1]
    len1, len2 = math.hypot(l1x, l1y), math.hypot(l2x, l2y)
    if len1 < MIN_LEG_M or len2 < MIN_LEG_M:
        return None
    u1 = (l1x / len1, l1y / len1)
    u2 = (l2x / len2, l2y / len2)
    turn = math.atan2(u1[0] * u2[1] - u1[1] * u2[0], u1[0] * u2[0] + u1[1] * u2[1])
    half = abs(turn) / 2.0
    if abs(turn) < COLLINEAR_RAD or half > math.pi / 2 - 1e-6:
        return None
    radius = min(
        corner_error_m / (1.0 / math.cos(half) - 1.0),
        0.5 * min(len1, len2) / math.tan(half),
    )
    yaw = max_yaw_rate_radps
    useful = cruise_mps**2 / max_lateral_accel_mps2 if max_lateral_accel_mps2 > 0.0 else math.inf
    if yaw is not None and math.isfinite(yaw) and yaw > 0.0:
        useful = max(useful, cruise_mps / yaw)
    radius = min(radius, useful)
    speed = min(cruise_mps, math.sqrt(max(0.0, max_lateral_accel_mps2 * radius)))
    if yaw is not None:
        speed = min(speed, max(0.0, yaw) * radius if math.isfinite(yaw) else 0.0)
    if not (math.isfinite(radius) and radius > 0.0) or speed < max(min_speed_mps, 1e-6):
        return None
    # The centre lies on the inner bisector (direction u_out − u_in) at R/cos(θ/2).
    nx, ny = u2[0] - u1[0], u2[1] - u1[1]
    norm = math.hypot(nx, ny)
    dist = radius / math.cos(half)
    center = (b_xy_m[0] + nx / norm * dist, b_xy_m[1] + ny / norm * dist)
    return CornerArc(
        vertex_xy_m=b_xy_m,
        center_xy_m=center,
        radius_m=radius,
        tangent_m=radius * math.tan(half),
        turn_rad=turn,
        speed_mps=speed,
        corner_error_m=dist - radius,
        mean_course_xy=(u1[0] + u2[0], u1[1] + u2[1]),
    )


def past_corner(arc: CornerArc, pose: Pose2D) -> bool:
    """True once ``pose`` is past the corner's bisector (the middle of its arc)."""
    mx, my = arc.mean_course_xy
    return (pose.x_m - arc.vertex_xy_m[0]) * mx + (pose.y_m - arc.vertex_xy_m[1]) * my >= 0.0


def arc_errors(arc: CornerArc, pose: Pose2D) -> tuple[float, float]:
    """(course of the arc's tangent at the point nearest ``pose``, signed cross-track error,
    + left of the direction of travel) — the arc's counterparts of :func:`leg_errors`."""
    require_finite("arc input", pose.x_m, pose.y_m)
    dx, dy = pose.x_m - arc.center_xy_m[0], pose.y_m - arc.center_xy_m[1]
    rho = math.hypot(dx, dy)
    side = 1.0 if arc.turn_rad > 0.0 else -1.0
    if rho < 1e-9:  # at the centre every direction is as near: the mean course
        course = math.atan2(arc.mean_course_xy[1], arc.mean_course_xy[0])
    else:
        course = wrap_pi(math.atan2(dy, dx) + side * math.pi / 2)
    return course, side * (arc.radius_m - rho)


def arc_ramp_m(arc: CornerArc, yaw_accel_radps2: float) -> float:
    """Distance over which the yaw rate ramps between 0 and the arc's v/R at the yaw
    acceleration limit α: d = v · (v/R) / α (0 with no limit)."""
    if not (math.isfinite(yaw_accel_radps2) and yaw_accel_radps2 > 0.0):
        return 0.0
    return arc.speed_mps**2 * abs(arc.curvature_per_m) / yaw_accel_radps2


def arc_blend(arc: CornerArc, into_m: float, left_m: float, ramp_m: float) -> tuple[float, float]:
    """(share of the arc's yaw rate to feed forward, heading offset) near the ends of ``arc``.

    The yaw rate cannot step to v/R where the arc meets a leg: it ramps over ``ramp_m``
    (:func:`arc_ramp_m`), centred on each end — the path flown is a clothoid-like blend that
    starts turning ``ramp_m``/2 before the arc and keeps turning ``ramp_m``/2 past it. Its
    heading leads the arc's tangent on the way in by κ·(d/2·w² − max(0, s)) (w = ½ + s/d, s
    the distance past the arc's start, ``into_m``) and lags it on the way out by the same
    amount (s: ``left_m``, the distance still to go to the arc's end); the offset is 0 once
    the ramp is done. Steering onto tangent + offset with v·κ·w fed forward leaves the heading
    loop nothing to correct on a perfect plant. Non-finite input → (0, 0)."""
    if not (math.isfinite(into_m) and math.isfinite(left_m) and math.isfinite(ramp_m)):
        return 0.0, 0.0
    k = arc.curvature_per_m
    if ramp_m <= 1e-9:
        return (1.0 if into_m >= 0.0 and left_m >= 0.0 else 0.0), 0.0

    def ramp(s_m: float) -> tuple[float, float]:
        if s_m >= ramp_m / 2.0:
            return 1.0, 0.0
        w = max(0.0, min(1.0, 0.5 + s_m / ramp_m))
        return w, k * (ramp_m / 2.0 * w * w - max(0.0, s_m))

    w_in, lead = ramp(into_m)
    w_out, lag = ramp(left_m)
    return min(w_in, w_out), lead - lag


def waypoint_speed_limits(
    points_xy_m: list[tuple[float, float]],
    stop_at: list[bool],
    cruise_mps: float,
    pivot_angle_rad: float,
    lookahead_m: float,
    max_lateral_accel_mps2: float,
    max_yaw_rate_radps: float,
    arcs: list[CornerArc | None] | None = None,
) -> tuple[list[float], list[bool]]:
    """For each waypoint: the speed to pass it at, and whether it is a stop (pivot/final).

    ``points_xy_m[0]`` is the start of the first leg. The last waypoint and those flagged in
    ``stop_at`` (final heading) are stops. Without ``arcs`` (no corner error budget) a corner
    turning more than ``pivot_angle_rad`` is a stop (pivot) and the rest are flown at
    :func:`corner_speed_mps`. With ``arcs`` a corner with an arc is
    passed at the arc's speed, a collinear one at cruise, and any other is a stop (pivot).
    (``arcs``: one :func:`corner_arc` or None per waypoint, as the navigator plans them.)
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
        if arcs is not None:
            arc = arcs[i]
            if arc is not None:
                stops[i], speeds[i] = False, arc.speed_mps
            elif turn < COLLINEAR_RAD:
                stops[i], speeds[i] = False, max(0.0, cruise_mps)
            continue
        if turn > pivot_angle_rad:
            continue
        stops[i] = False
        speeds[i] = corner_speed_mps(
            turn, cruise_mps, lookahead_m, max_lateral_accel_mps2, max_yaw_rate_radps
        )
    return speeds, stops


@dataclass(frozen=True, slots=True)
class CornerPlan:
    """How line guidance takes each waypoint of a path (one entry per waypoint).

    ``arcs``: the arc its corner is rounded with (None: no arc); ``speeds_mps``: the speed to
    pass it at (0 at a stop); ``stops``: stopped at (pivot corner, final heading, a hold, the
    last waypoint); ``early_m``: how far before the waypoint its pass speed must be reached
    (an arc's start, a flown-through waypoint's tolerance, 0 at a stop)."""

    arcs: list[CornerArc | None]
    speeds_mps: list[float]
    stops: list[bool]
    early_m: list[float]


def waypoint_corners(
    points_xy_m: list[tuple[float, float]],
    waypoints: Sequence[PlanWaypoint],
    peak_speed_mps: float,
    control: NavigatorParams,
) -> CornerPlan:
    """:func:`plan_corners` of a plan's ``waypoints`` (``points_xy_m``: the start, then
    theirs): each one's tolerance, a stop where a final heading or a hold follows."""
    tolerances_m = [w.tolerance_m for w in waypoints]
    stop_at = [w.final_yaw_rad is not None or w.stop for w in waypoints]
    return plan_corners(points_xy_m, tolerances_m, stop_at, peak_speed_mps, control)


def plan_corners(
    points_xy_m: list[tuple[float, float]],
    tolerances_m: list[float],
    stop_at: list[bool],
    peak_speed_mps: float,
    control: NavigatorParams,
) -> CornerPlan:
    """The navigator's corner decisions for the path ``points_xy_m`` (start first, then the
    waypoints with their ``tolerances_m``; ``stop_at``: a final heading or a hold follows).

    With a corner error budget (``control.corner_error_m`` > 0) every corner that is not a
    stop gets its :func:`corner_arc` with the budget capped by the waypoint's tolerance,
    planned for ``peak_speed_mps`` (the highest cruise the mission may set);
    :func:`waypoint_speed_limits` then gives the pass speeds and stops. The navigator flies by
    this plan and the time estimate integrates it.

    OMNI does not turn, but its direction of travel does, and no faster than
    ``max_yaw_rate_radps`` either (v ≤ ω·R): a tighter arc cannot be followed through the
    scrolls' lag (a 164° corner got a 0.04 m arc at 0.11 m/s, v/R = 2.7 rad/s, and the rover
    orbited it for ever), so such a corner is a stop, as in ROLL and SCROLL."""
    n = len(points_xy_m) - 1
    arcs: list[CornerArc | None] | None = None
    if control.corner_error_m > 0.0:
        arcs = [
            corner_arc(
                points_xy_m[i],
                points_xy_m[i + 1],
                points_xy_m[i + 2],
                min(control.corner_error_m, tolerances_m[i]),
                peak_speed_mps,
                control.max_lateral_accel_mps2,
                control.max_yaw_rate_radps,
                control.min_speed_mps,
            )
            if i + 1 < n and not stop_at[i]
            else None
            for i in range(n)
        ]
    speeds, stops = waypoint_speed_limits(
        points_xy_m,
        stop_at,
        peak_speed_mps,
        control.pivot_angle_rad,
        control.lookahead_m,
        control.max_lateral_accel_mps2,
        control.max_yaw_rate_radps,
        arcs,
    )
    planned: list[CornerArc | None] = arcs if arcs is not None else [None] * n
    early = [
        0.0 if stop else (arc.tangent_m if arc is not None else tolerance)
        for stop, arc, tolerance in zip(stops, planned, tolerances_m, strict=True)
    ]
    return CornerPlan(planned, speeds, stops, early)


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
    horizon_m: float = math.inf,
) -> float:
    """Speed allowed now so that every coming waypoint j ≥ index is passed at ≤ speeds[j],
    already ``early_m[j]`` before it (a flown-through waypoint ends its leg at its
    pass-through radius, so its corner speed must be reached there).

    Waypoints farther than ``horizon_m`` along the path are not looked at: with
    horizon ≥ v_max²/(2a) + max(early_m) none of them could limit a speed ≤ v_max (a path of
    flown-through corners would otherwise cost a loop over every remaining waypoint per step)."""
    if not (math.isfinite(along_to_go_m) and math.isfinite(accel_mps2)):
        return 0.0
    wps = points_xy_m[1:]
    best = math.inf
    distance = max(0.0, along_to_go_m)
    for j in range(index, len(speeds_mps)):
        if j > index:
            a, b = wps[j - 1], wps[j]
            distance += math.hypot(b[0] - a[0], b[1] - a[1])
            if distance > horizon_m:
                break
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


def lookahead_horizon_m(
    peak_speed_mps: float, early_m: Sequence[float], cfg: NavigatorParams
) -> float:
    """How far along the path the speed profile and the distance to the next stop need to
    look: a waypoint farther than v²/(2·a_brake) + its early distance cannot limit a speed
    ≤ v, and the distance loop's output kp·e − |I| − |D| exceeds v once e ≥
    (v + I_max + kd·v)/kp (its D term only rises when the distance jumps up). Infinite
    when the loop has no proportional gain."""
    v = peak_speed_mps
    profile_m = v * v / (2.0 * cfg.braking_accel_mps2) + max(early_m, default=0.0)
    gains = cfg.distance_pid
    if gains.kp <= 0.0:
        return math.inf
    pid_m = (v + abs(gains.integral_limit) + abs(gains.kd) * v) / gains.kp
    return max(profile_m, pid_m) + 1.0


def arc_length_m(arc: CornerArc) -> float:
    """The length of a corner's arc (m)."""
    return arc.radius_m * abs(arc.turn_rad)


def distance_to_m(pose: Pose2D, goal: PlanWaypoint) -> float:
    """Straight-line distance from ``pose`` to ``goal`` (m)."""
    return math.hypot(goal.x_m - pose.x_m, goal.y_m - pose.y_m)
