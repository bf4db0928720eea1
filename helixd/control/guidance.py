"""Guidance: from (pose, goal) to errors and a body-velocity command, per motion mode.

Pure functions (the thesis's Algorithm 2, eq. 3–6; docs/physics.md, guidance):

    Δx, Δy = x_ref − x, y_ref − y
    e_d    = hypot(Δx, Δy)                                  (eq. 6)
    β      = atan2(Δy, Δx)                                  (eq. 3, bearing to the goal)
    ψ_ref  = β − axis(mode)        axis: ROLL 0 (+x), SCROLL π/2 (+y)
    e_ψ    = wrap(ψ_ref − ψ)       in (−π, π]               (eq. 4/5, shortest distance)

SCROLL drives along +y, which points at ψ + π/2: measuring the heading from that axis
("+π/2 offset") gives the body heading ψ_ref = β − π/2 that aligns +y with the goal.
OMNI holds its heading (ω_z = 0) and drives straight at the goal: the world-frame error is
rotated into the body frame, v = speed · (Δx_b, Δy_b) / e_d.

This is the thesis law (``control.guidance: thesis``); the default line-tracking law, which
follows the leg instead of the point, is in :mod:`helixd.control.line` and reuses
:func:`driving_axis_rad`, :func:`world_to_body` and :func:`compute_command` from here.

These functions never decide to stop: zero output and timeouts belong to the supervisor.

Total: geometry from a non-finite pose or goal raises :class:`NonFiniteError`; the command
and speed laws turn any non-finite input into zero (neutral), never into their limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from helixd.base.angles import shortest_angular_distance, wrap_pi
from helixd.base.geometry import BodyVelocity, Pose2D, require_finite
from helixd.base.plan import MotionMode, PlanWaypoint


@dataclass(frozen=True, slots=True)
class GuidanceResult:
    """Errors of one pose with respect to one goal."""

    distance_error_m: float  # e_d
    bearing_rad: float  # β, world-frame direction from the rover to the goal
    heading_goal_rad: float  # ψ_ref, body yaw that points the mode's driving axis at the goal
    heading_error_rad: float  # e_ψ = wrap(ψ_ref − ψ); 0 in OMNI (heading not steered)
    direction_body_x: float  # unit vector to the goal in the body frame (0, 0 at the goal)
    direction_body_y: float


def driving_axis_rad(mode: MotionMode) -> float:
    """Angle of the axis the mode drives along, from body +x (ROLL +x, SCROLL +y)."""
    return math.pi / 2 if mode is MotionMode.SCROLL else 0.0


def world_to_body(dx_m: float, dy_m: float, yaw_rad: float) -> tuple[float, float]:
    """Rotate a world-frame vector into the body frame: R(−ψ) · [dx, dy]."""
    require_finite("world_to_body input", dx_m, dy_m, yaw_rad)
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return c * dx_m + s * dy_m, -s * dx_m + c * dy_m


def compute_errors(
    pose: Pose2D, goal: PlanWaypoint, mode: MotionMode, reverse: bool = False
) -> GuidanceResult:
    """Distance and heading errors of ``pose`` towards ``goal`` in ``mode`` (``reverse``: the
    driving axis points away from the goal, DO_SET_REVERSE)."""
    require_finite("pose", pose.x_m, pose.y_m, pose.yaw_rad)
    require_finite("goal", goal.x_m, goal.y_m)
    dx = goal.x_m - pose.x_m
    dy = goal.y_m - pose.y_m
    require_finite("goal - pose", dx, dy)
    e_d = math.hypot(dx, dy)
    require_finite("distance", e_d)
    bearing = math.atan2(dy, dx)
    if mode is MotionMode.OMNI:
        heading_goal = pose.yaw_rad
        e_psi = 0.0
    else:
        axis = driving_axis_rad(mode) + (math.pi if reverse else 0.0)
        heading_goal = wrap_pi(bearing - axis)
        e_psi = shortest_angular_distance(pose.yaw_rad, heading_goal)
    bx, by = world_to_body(dx, dy, pose.yaw_rad)
    ux, uy = (bx / e_d, by / e_d) if e_d > 0.0 else (0.0, 0.0)
    return GuidanceResult(
        distance_error_m=e_d,
        bearing_rad=bearing,
        heading_goal_rad=heading_goal,
        heading_error_rad=e_psi,
        direction_body_x=ux,
        direction_body_y=uy,
    )


def compute_command(
    errors: GuidanceResult, mode: MotionMode, speed_mps: float, yaw_rate_radps: float
) -> BodyVelocity:
    """Turn a scalar speed along the mode's driving axis and a yaw rate into a body command.

    ROLL: (v, 0, ω).  SCROLL: (0, v, ω).  OMNI: v · (u_x, u_y) towards the goal, ω = 0.
    A non-finite speed or yaw rate (or direction) is commanded as 0.
    """
    speed_mps = _finite_or_zero(speed_mps)
    yaw_rate_radps = _finite_or_zero(yaw_rate_radps)
    if mode is MotionMode.ROLL:
        return BodyVelocity(speed_mps, 0.0, yaw_rate_radps)
    if mode is MotionMode.SCROLL:
        return BodyVelocity(0.0, speed_mps, yaw_rate_radps)
    return BodyVelocity(
        _finite_or_zero(speed_mps * errors.direction_body_x),
        _finite_or_zero(speed_mps * errors.direction_body_y),
    )


def _finite_or_zero(value: float) -> float:
    return value if math.isfinite(value) else 0.0


def track_speed_mps(
    pid_speed_mps: float,
    distance_error_m: float,
    tolerance_m: float,
    cruise_speed_mps: float,
    slowdown_radius_m: float,
    min_speed_mps: float,
) -> float:
    """Forward speed while tracking: the distance PID's output, limited.

    v = clamp(v_pid, ≤ v_cruise · min(1, e_d / r_slow)), at least v_min while e_d ≥ tolerance
    (so the rover does not creep), never negative, never above v_cruise.
    Any non-finite input gives 0: ``min(1, nan)`` is 1, i.e. full speed, so it is checked first.
    """
    inputs = (
        pid_speed_mps,
        distance_error_m,
        tolerance_m,
        cruise_speed_mps,
        slowdown_radius_m,
        min_speed_mps,
    )
    if not all(math.isfinite(x) for x in inputs):
        return 0.0
    ramp = 1.0 if slowdown_radius_m <= 0.0 else min(1.0, distance_error_m / slowdown_radius_m)
    v = min(pid_speed_mps, cruise_speed_mps * ramp)
    if distance_error_m >= tolerance_m:
        v = max(v, min_speed_mps)
    return max(0.0, min(v, cruise_speed_mps))


def cross_track_m(
    start_xy_m: tuple[float, float], end_xy_m: tuple[float, float], pose: Pose2D
) -> float:
    """Signed distance of ``pose`` from the line start → end (m), positive to its left.

    A degenerate leg (start = end) returns the distance to that point.
    """
    ax, ay = start_xy_m
    bx, by = end_xy_m
    require_finite("cross-track input", ax, ay, bx, by, pose.x_m, pose.y_m)
    lx, ly = bx - ax, by - ay
    length = math.hypot(lx, ly)
    px, py = pose.x_m - ax, pose.y_m - ay
    if length < 1e-9:
        return math.hypot(px, py)
    return (lx * py - ly * px) / length


def run_out_m(
    points_xy_m: list[tuple[float, float]],
    stop_at: list[bool],
    corner_slowdown_rad: float,
) -> list[float]:
    """For each waypoint i, the path length beyond it that can be flown without slowing.

    The speed law sees ``e_d + run_out[i]``: the rover only slows down for the last waypoint,
    a waypoint with a final heading (``stop_at``), or a corner sharper than
    ``corner_slowdown_rad``. ``points_xy_m[0]`` is the start of the first leg.
    """
    for point in points_xy_m:
        require_finite("path point", *point)
    wps = points_xy_m[1:]
    n = len(wps)
    out = [0.0] * n
    for i in range(n - 2, -1, -1):
        prev = points_xy_m[i]
        here, nxt = wps[i], wps[i + 1]
        turn = abs(
            shortest_angular_distance(
                math.atan2(here[1] - prev[1], here[0] - prev[0]),
                math.atan2(nxt[1] - here[1], nxt[0] - here[0]),
            )
        )
        if stop_at[i] or turn > corner_slowdown_rad:
            continue
        out[i] = math.hypot(nxt[0] - here[0], nxt[1] - here[1]) + out[i + 1]
    return out
