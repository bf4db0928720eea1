"""Guidance: errors per mode, body commands, speed law, cross-track."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.geometry import Pose2D
from helixd.base.plan import MotionMode, PlanWaypoint
from helixd.control import guidance
from helixd.control.guidance import (
    GuidanceResult,
    compute_command,
    compute_errors,
    cross_track_m,
    track_speed_mps,
    world_to_body,
)
from tests.support.ideal_plant import integrate

coords = st.floats(-50.0, 50.0, allow_nan=False)
yaws = st.floats(-math.pi, math.pi, allow_nan=False)
poses = st.builds(Pose2D, coords, coords, yaws)
goals = st.builds(PlanWaypoint, coords, coords, st.just(0.5))


def wp(x: float, y: float) -> PlanWaypoint:
    return PlanWaypoint(x_m=x, y_m=y, tolerance_m=0.5)


def test_distance_error_is_euclidean() -> None:
    errors = compute_errors(Pose2D(1.0, 2.0, 0.3), wp(4.0, 6.0), MotionMode.ROLL)
    assert errors.distance_error_m == pytest.approx(5.0)


def test_roll_heading_goal_is_the_bearing() -> None:
    errors = compute_errors(Pose2D(0.0, 0.0, 0.0), wp(1.0, 1.0), MotionMode.ROLL)
    assert errors.heading_goal_rad == pytest.approx(math.pi / 4)
    assert errors.heading_error_rad == pytest.approx(math.pi / 4)


def test_scroll_aligns_plus_y_with_the_goal() -> None:
    # Goal straight ahead (+x): the +y axis must turn onto it, so the body turns −π/2.
    errors = compute_errors(Pose2D(0.0, 0.0, 0.0), wp(3.0, 0.0), MotionMode.SCROLL)
    assert errors.heading_goal_rad == pytest.approx(-math.pi / 2)
    assert errors.heading_error_rad == pytest.approx(-math.pi / 2)
    # Goal to the left (+y): already aligned.
    aligned = compute_errors(Pose2D(0.0, 0.0, 0.0), wp(0.0, 3.0), MotionMode.SCROLL)
    assert aligned.heading_error_rad == pytest.approx(0.0)


def test_heading_error_wraps_the_short_way() -> None:
    # Facing 170°, goal bearing −170°: turn +20°, not −340°.
    pose = Pose2D(0.0, 0.0, math.radians(170))
    goal = wp(math.cos(math.radians(-170)), math.sin(math.radians(-170)))
    errors = compute_errors(pose, goal, MotionMode.ROLL)
    assert errors.heading_error_rad == pytest.approx(math.radians(20))


def test_omni_holds_heading() -> None:
    errors = compute_errors(Pose2D(0.0, 0.0, 1.0), wp(-5.0, 2.0), MotionMode.OMNI)
    assert errors.heading_error_rad == 0.0
    assert errors.heading_goal_rad == 1.0


@settings(deadline=None)
@given(poses, goals, st.sampled_from(list(MotionMode)))
def test_heading_error_is_in_range(pose: Pose2D, goal: PlanWaypoint, mode: MotionMode) -> None:
    e = compute_errors(pose, goal, mode).heading_error_rad
    assert -math.pi < e <= math.pi


@settings(deadline=None)
@given(poses, goals, st.sampled_from(list(MotionMode)))
def test_an_aligned_command_moves_straight_at_the_goal(
    pose: Pose2D, goal: PlanWaypoint, mode: MotionMode
) -> None:
    """After turning by e_ψ, the mode's drive command points the world velocity at the goal."""
    errors = compute_errors(pose, goal, mode)
    if errors.distance_error_m < 1e-6:
        return
    aligned = Pose2D(pose.x_m, pose.y_m, pose.yaw_rad + errors.heading_error_rad)
    errors = compute_errors(aligned, goal, mode)
    command = compute_command(errors, mode, 1.0, 0.0)
    moved = integrate(aligned, command, 1e-3)
    vx, vy = (moved.x_m - aligned.x_m) / 1e-3, (moved.y_m - aligned.y_m) / 1e-3
    assert math.hypot(vx, vy) == pytest.approx(1.0, rel=1e-6)
    assert vx == pytest.approx(math.cos(errors.bearing_rad), abs=1e-6)
    assert vy == pytest.approx(math.sin(errors.bearing_rad), abs=1e-6)


def test_commands_respect_the_mode() -> None:
    errors = compute_errors(Pose2D(0.0, 0.0, 0.0), wp(1.0, 1.0), MotionMode.ROLL)
    roll = compute_command(errors, MotionMode.ROLL, 0.5, 0.2)
    assert (roll.vx_mps, roll.vy_mps, roll.wz_radps) == (0.5, 0.0, 0.2)
    scroll = compute_command(errors, MotionMode.SCROLL, 0.5, 0.2)
    assert (scroll.vx_mps, scroll.vy_mps, scroll.wz_radps) == (0.0, 0.5, 0.2)
    omni_errors = compute_errors(Pose2D(0.0, 0.0, 0.0), wp(1.0, 1.0), MotionMode.OMNI)
    omni = compute_command(omni_errors, MotionMode.OMNI, 0.5, 0.2)
    assert omni.wz_radps == 0.0
    assert omni.vx_mps == pytest.approx(0.5 / math.sqrt(2))
    assert omni.vy_mps == pytest.approx(0.5 / math.sqrt(2))


def test_omni_at_the_goal_commands_nothing() -> None:
    errors = compute_errors(Pose2D(2.0, 3.0, 0.0), wp(2.0, 3.0), MotionMode.OMNI)
    command = compute_command(errors, MotionMode.OMNI, 0.5, 0.0)
    assert (command.vx_mps, command.vy_mps) == (0.0, 0.0)


@settings(deadline=None)
@given(coords, coords, yaws)
def test_world_to_body_preserves_length_and_inverts_rotation(
    dx: float, dy: float, yaw: float
) -> None:
    bx, by = world_to_body(dx, dy, yaw)
    assert math.hypot(bx, by) == pytest.approx(math.hypot(dx, dy), abs=1e-9)
    c, s = math.cos(yaw), math.sin(yaw)
    assert c * bx - s * by == pytest.approx(dx, abs=1e-9)
    assert s * bx + c * by == pytest.approx(dy, abs=1e-9)


# -- speed law ---------------------------------------------------------------------------------


def speed(pid: float, e_d: float) -> float:
    return track_speed_mps(
        pid,
        e_d,
        tolerance_m=0.3,
        cruise_speed_mps=0.6,
        slowdown_radius_m=2.0,
        min_speed_mps=0.1,
    )


def test_speed_is_capped_by_cruise_far_away() -> None:
    assert speed(5.0, 10.0) == 0.6


def test_speed_ramps_down_inside_the_slowdown_radius() -> None:
    assert speed(5.0, 1.0) == pytest.approx(0.3)  # 0.6 · 1.0 / 2.0
    assert speed(5.0, 0.5) == pytest.approx(0.15)


def test_speed_has_a_floor_outside_tolerance_only() -> None:
    assert speed(0.01, 0.35) == pytest.approx(0.1)
    assert speed(0.01, 0.2) == pytest.approx(0.01)
    assert speed(-1.0, 0.2) == 0.0  # never backwards


def test_speed_follows_a_small_pid_output() -> None:
    assert speed(0.2, 5.0) == pytest.approx(0.2)


@settings(deadline=None)
@given(st.floats(-5.0, 5.0), st.floats(0.0, 100.0))
def test_speed_is_within_zero_and_cruise(pid: float, e_d: float) -> None:
    assert 0.0 <= speed(pid, e_d) <= 0.6


def test_no_slowdown_radius_means_no_ramp() -> None:
    v = track_speed_mps(5.0, 0.5, 0.3, 0.6, slowdown_radius_m=0.0, min_speed_mps=0.1)
    assert v == 0.6


# -- cross-track -------------------------------------------------------------------------------


def test_cross_track_is_signed_left_positive() -> None:
    assert cross_track_m((0.0, 0.0), (10.0, 0.0), Pose2D(3.0, 2.0, 0.0)) == pytest.approx(2.0)
    assert cross_track_m((0.0, 0.0), (10.0, 0.0), Pose2D(3.0, -1.5, 0.0)) == pytest.approx(-1.5)
    # A diagonal leg.
    d = cross_track_m((0.0, 0.0), (1.0, 1.0), Pose2D(0.0, 1.0, 0.0))
    assert d == pytest.approx(math.sqrt(0.5))


def test_cross_track_of_a_degenerate_leg_is_the_distance() -> None:
    assert cross_track_m((1.0, 1.0), (1.0, 1.0), Pose2D(4.0, 5.0, 0.0)) == pytest.approx(5.0)


def test_guidance_result_is_frozen() -> None:
    errors = compute_errors(Pose2D(0.0, 0.0, 0.0), wp(1.0, 0.0), MotionMode.ROLL)
    assert isinstance(errors, GuidanceResult)
    with pytest.raises(AttributeError):
        errors.distance_error_m = 0.0  # type: ignore[misc]


def test_run_out_flies_through_gentle_corners_and_stops_at_sharp_ones() -> None:
    # start (0,0) → (1,0) → (2,0.1) gentle → (2,2) sharp 90° → (3,2) last
    pts = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.1), (2.0, 2.0), (3.0, 2.0)]
    out = guidance.run_out_m(pts, [False] * 4, corner_slowdown_rad=0.5)
    assert out[3] == 0.0  # last waypoint: stop
    assert out[2] == 0.0  # 90° corner ahead: slow down
    assert out[1] == 0.0  # the turn at (2, 0.1) toward (2, 2) is sharp too
    assert math.isclose(out[0], math.hypot(1.0, 0.1))  # gentle 5.7° kink: fly through
    # a final heading forces a stop even on a straight line
    straight = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)]
    assert guidance.run_out_m(straight, [False, False, False], 0.5) == [2.0, 1.0, 0.0]
    assert guidance.run_out_m(straight, [False, True, False], 0.5) == [1.0, 0.0, 0.0]
