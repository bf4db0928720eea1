"""Navigator state machine: transitions, per-mode rules, timing, outputs."""

from __future__ import annotations

import math

import pytest

from helixd.base.geometry import Pose2D
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.control import ControlConfig
from helixd.control.navigator import Navigator, NavOutput, NavState
from tests.support.ideal_plant import IdealPlant, integrate

DT = 1.0 / 40.0
CONTROL = ControlConfig(guidance="thesis")  # the thesis law, as before; line: test_line_guidance.py


def make_plan(
    mode: MotionMode, *points: tuple[float, float] | tuple[float, float, float], tol: float = 0.3
) -> Plan:
    waypoints = tuple(PlanWaypoint(p[0], p[1], tol, p[2] if len(p) == 3 else None) for p in points)
    return Plan("test", mode, MissionFrameKind.START, waypoints, speed_mps=0.6)


def fly(nav: Navigator, start: Pose2D, limit_s: float = 120.0) -> tuple[list[NavOutput], Pose2D]:
    """Run the navigator on the ideal plant until DONE (plus two more steps)."""
    plant = IdealPlant(start, nav.plan.mode)
    outputs: list[NavOutput] = []
    extra = 0
    while plant.t_s < limit_s and extra < 3:
        out = nav.step(plant.pose, plant.t_s)
        outputs.append(out)
        extra += out.done
        plant.step(out.command, DT)
    return outputs, plant.pose


def collapsed(outputs: list[NavOutput]) -> list[NavState]:
    states: list[NavState] = []
    for out in outputs:
        if not states or states[-1] is not out.state:
            states.append(out.state)
    return states


def test_idle_align_track_reached_done() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0)), CONTROL)
    assert Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0)), CONTROL).state is NavState.IDLE
    outputs, pose = fly(nav, Pose2D(0.0, 0.0, math.pi / 2))
    assert collapsed(outputs) == [NavState.ALIGN, NavState.TRACK, NavState.REACHED, NavState.DONE]
    first = outputs[0]
    assert first.command.vx_mps == 0.0 and first.command.wz_radps < 0.0  # turn right, in place
    assert math.hypot(pose.x_m - 5.0, pose.y_m) < 0.3
    assert nav.state is NavState.DONE and nav.done


def test_reached_is_reported_once_per_waypoint_and_counts() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (3.0, 0.0), (3.0, 3.0), (0.0, 3.0)), CONTROL)
    outputs, _ = fly(nav, Pose2D(0.0, 0.0, 0.0))
    reached = [(i, o) for i, o in enumerate(outputs) if o.state is NavState.REACHED]
    assert [o.reached_index for _, o in reached] == [0, 1, 2]
    assert [o.waypoints_reached for _, o in reached] == [1, 2, 3]
    for i, o in reached:
        # The REACHED row describes the arrival: that waypoint and its (in-tolerance) error.
        assert o.target_index == o.reached_index
        assert o.distance_error_m < 0.3
        assert outputs[i + 1].state is not NavState.REACHED
    assert all(o.reached_index is None for o in outputs if o.state is not NavState.REACHED)
    targets = [o.target_index for o in outputs]
    assert targets == sorted(targets) and targets[-1] == 2
    assert nav.target_index == 2
    assert outputs[-1].waypoints_reached == 3


def test_pids_are_reset_on_waypoint_switch() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (3.0, 0.0), (3.0, 3.0)), CONTROL)
    outputs, _ = fly(nav, Pose2D(0.0, 0.0, 0.0))
    switch = next(o for o in outputs if o.reached_index == 0)
    # The step's command is for the next waypoint, computed by freshly reset PIDs: no D yet.
    assert switch.yaw_pid.d == 0.0 and switch.distance_pid.d == 0.0
    assert switch.distance_pid.i == 0.0
    assert switch.command.vx_mps == 0.0  # next leg is 90° left: turn in place first


def test_command_continues_through_a_gentle_waypoint_switch() -> None:
    # Three collinear points: the step that reaches the first already drives to the second.
    nav = Navigator(make_plan(MotionMode.ROLL, (3.0, 0.0), (6.0, 0.0)), CONTROL)
    outputs, _ = fly(nav, Pose2D(0.0, 0.0, 0.0))
    switch = next(o for o in outputs if o.reached_index == 0)
    assert switch.command.vx_mps > 0.3


def test_final_heading_only_when_the_waypoint_has_one() -> None:
    with_yaw = Navigator(make_plan(MotionMode.ROLL, (4.0, 0.0, math.pi / 2)), CONTROL)
    outputs, pose = fly(with_yaw, Pose2D(0.0, 0.0, 0.0))
    assert collapsed(outputs) == [
        NavState.TRACK,
        NavState.REACHED,
        NavState.FINAL_HEADING,
        NavState.DONE,
    ]
    assert abs(pose.yaw_rad - math.pi / 2) <= CONTROL.final_heading_tolerance_rad
    turning = [o for o in outputs if o.state is NavState.FINAL_HEADING]
    assert all(o.command.vx_mps == 0.0 and o.command.vy_mps == 0.0 for o in turning)

    without = Navigator(make_plan(MotionMode.ROLL, (4.0, 0.0)), CONTROL)
    outputs, _ = fly(without, Pose2D(0.0, 0.0, 0.0))
    assert NavState.FINAL_HEADING not in collapsed(outputs)


def test_final_heading_on_an_intermediate_waypoint_then_continues() -> None:
    plan = make_plan(MotionMode.SCROLL, (0.0, 3.0, math.pi), (0.0, 6.0))
    nav = Navigator(plan, CONTROL)
    outputs, pose = fly(nav, Pose2D(0.0, 0.0, 0.0))
    states = collapsed(outputs)
    fh = states.index(NavState.FINAL_HEADING)
    assert NavState.REACHED in states[fh + 1 :]  # the second waypoint is flown afterwards
    assert states[-1] is NavState.DONE
    assert math.hypot(pose.x_m, pose.y_m - 6.0) < 0.3
    at_turn_end = next(
        o
        for i, o in enumerate(outputs)
        if o.state is not NavState.FINAL_HEADING
        and i > 0
        and outputs[i - 1].state is NavState.FINAL_HEADING
    )
    assert at_turn_end.target_index == 1


def test_final_heading_already_met_is_skipped() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (4.0, 0.0, 0.0)), CONTROL)
    outputs, _ = fly(nav, Pose2D(0.0, 0.0, 0.0))
    assert NavState.FINAL_HEADING not in collapsed(outputs)


@pytest.mark.parametrize("yaw", [0.0, math.pi / 2, math.pi, -2.0])
def test_omni_never_aligns_and_holds_heading(yaw: float) -> None:
    plan = make_plan(MotionMode.OMNI, (-3.0, 1.0), (2.0, -2.0, 1.0))
    nav = Navigator(plan, CONTROL)
    outputs, pose = fly(nav, Pose2D(0.0, 0.0, yaw))
    states = set(collapsed(outputs))
    assert NavState.ALIGN not in states
    assert NavState.FINAL_HEADING not in states  # ω_z is forbidden in OMNI
    assert all(o.command.wz_radps == 0.0 for o in outputs)
    assert pose.yaw_rad == pytest.approx(yaw)
    assert outputs[-1].done and outputs[-1].waypoints_reached == 2


@pytest.mark.parametrize("mode", list(MotionMode))
def test_commands_obey_mode_and_limits(mode: MotionMode) -> None:
    plan = make_plan(mode, (4.0, 3.0), (-2.0, 1.0, 2.0), (0.0, -3.0))
    nav = Navigator(plan, CONTROL)
    outputs, _ = fly(nav, Pose2D(1.0, 1.0, 2.5))
    assert outputs[-1].done
    for o in outputs:
        c = o.command
        if mode is MotionMode.ROLL:
            assert c.vy_mps == 0.0
        elif mode is MotionMode.SCROLL:
            assert c.vx_mps == 0.0
        else:
            assert c.wz_radps == 0.0
        assert math.hypot(c.vx_mps, c.vy_mps) <= plan.speed_mps + 1e-12
        assert abs(c.wz_radps) <= CONTROL.max_yaw_rate_radps
        assert -math.pi < o.heading_error_rad <= math.pi
        if o.state is NavState.ALIGN:
            assert (c.vx_mps, c.vy_mps) == (0.0, 0.0)


def test_track_realigns_in_place_when_the_goal_falls_beside() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (3.0, 0.0)), CONTROL)
    assert nav.step(Pose2D(0.0, 0.0, 0.0), 0.0).state is NavState.TRACK
    assert nav.step(Pose2D(0.01, 0.0, 0.0), DT).state is NavState.TRACK
    # A disturbance leaves the goal 0.6 m to the left: re-align, do not drive an arc round it.
    out = nav.step(Pose2D(3.0, -0.6, 0.0), 2 * DT)
    assert out.state is NavState.ALIGN
    assert out.command.vx_mps == 0.0 and out.command.wz_radps > 0.0


def test_done_is_zero_forever() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (1.0, 0.0)), CONTROL)
    nav.step(Pose2D(0.9, 0.0, 0.0), 0.0)  # reached at once
    for k in range(1, 50):
        out = nav.step(Pose2D(5.0, 5.0, 1.0), k * DT)  # even if it is pushed away
        assert out.state is NavState.DONE and out.done
        assert (out.command.vx_mps, out.command.vy_mps, out.command.wz_radps) == (0.0, 0.0, 0.0)
        assert out.target_index == 0 and out.waypoints_reached == 1


def test_reaching_the_last_waypoint_reports_reached_then_done() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (1.0, 0.0)), CONTROL)
    first = nav.step(Pose2D(0.9, 0.0, 0.0), 0.0)
    assert first.state is NavState.REACHED and first.reached_index == 0 and not first.done
    assert nav.step(Pose2D(0.9, 0.0, 0.0), DT).state is NavState.DONE


def test_cross_track_is_measured_from_the_start_pose() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (10.0, 0.0)), CONTROL)
    nav.step(Pose2D(0.0, 0.0, 0.0), 0.0)
    out = nav.step(Pose2D(5.0, 0.4, 0.0), DT)
    assert out.cross_track_m == pytest.approx(0.4)
    # Leg start captured at the first step, not the origin.
    nav2 = Navigator(make_plan(MotionMode.ROLL, (10.0, 0.0)), CONTROL)
    nav2.step(Pose2D(0.0, 2.0, 0.0), 0.0)
    out2 = nav2.step(Pose2D(5.0, 1.0, 0.0), DT)
    assert out2.cross_track_m == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("gap_s", [CONTROL.max_dt_s + 0.1, 0.0, -5.0])
def test_bad_time_steps_restart_pid_memory(gap_s: float) -> None:
    # Unsaturated yaw loop with an integral, so both memories visibly build up.
    yaw_pid = CONTROL.yaw_pid.model_copy(update={"kp": 1.0, "ki": 1.0})
    control = CONTROL.model_copy(update={"yaw_pid": yaw_pid, "max_yaw_rate_radps": 5.0})
    nav = Navigator(make_plan(MotionMode.ROLL, (0.0, 20.0)), control)
    t = 0.0
    yaw = 0.0
    for _ in range(20):  # aligning: integral and derivative memory build up
        out = nav.step(Pose2D(0.0, 0.0, yaw), t)
        t += DT
        yaw += 0.01
    assert out.state is NavState.ALIGN and out.yaw_pid.i != 0.0 and out.yaw_pid.d != 0.0
    out = nav.step(Pose2D(0.0, 0.0, yaw + 0.3), t - DT + gap_s)
    assert out.yaw_pid.d == 0.0 and out.yaw_pid.i == 0.0
    assert all(math.isfinite(v) for v in (out.command.vx_mps, out.command.wz_radps))
    assert out.state is NavState.ALIGN


def test_navigator_exposes_target_index() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (1.0, 0.0), (1.0, 5.0)), CONTROL)
    assert nav.target_index == 0
    nav.step(Pose2D(0.95, 0.0, 0.0), 0.0)
    assert nav.target_index == 1 and nav.waypoints_reached == 1


def test_empty_plan_is_refused() -> None:
    plan = Plan("empty", MotionMode.ROLL, MissionFrameKind.START, (), speed_mps=0.6)
    with pytest.raises(ValueError, match="no waypoints"):
        Navigator(plan, CONTROL)


# -- line guidance: the leg-switching rules -----------------------------------------------------

LINE = ControlConfig(guidance="line")
NO_ARCS = ControlConfig(guidance="line", corner_error_m=0.0)  # corners: pivots (before arcs)


def test_line_leg_ends_on_crossing_the_perpendicular_far_beside_a_pass_through_waypoint() -> None:
    # Leg (0,0) → (5,0) → (5,5). Crossing x = 5 at y = 0.8 (outside the 0.3 m radius) ends the
    # leg to waypoint 0 (a 90° pivot corner, within its 1 m tolerance): no orbit back to it.
    nav = Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0), (5.0, 5.0), tol=1.0), NO_ARCS)
    nav.step(Pose2D(0.0, 0.0, 0.0), 0.0)
    before = nav.step(Pose2D(4.99, 0.8, 0.0), DT)
    assert before.reached_index is None
    out = nav.step(Pose2D(5.01, 0.8, 0.0), 2 * DT)
    assert out.reached_index == 0
    assert nav.target_index == 1


def test_line_arc_corner_ends_on_its_bisector_not_at_its_radius() -> None:
    # Leg (0,0) → (5,0) → (5,5), a 90° corner rounded on an arc (a 0.25 m budget, the
    # default, set explicitly): its leg ends where the rover crosses the corner's bisector,
    # x − 5 + y = 0 (the arc's middle), not on entering the waypoint's 1 m radius nor on the
    # perpendicular.
    arcs = LINE.model_copy(update={"corner_error_m": 0.25})
    nav = Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0), (5.0, 5.0), tol=1.0), arcs)
    nav.step(Pose2D(0.0, 0.0, 0.0), 0.0)
    assert nav.step(Pose2D(4.5, 0.0, 0.0), DT).reached_index is None  # inside 1 m
    assert nav.step(Pose2D(5.05, -0.1, 0.0), 2 * DT).reached_index is None  # past x = 5
    out = nav.step(Pose2D(4.95, 0.06, 0.5), 3 * DT)
    assert out.reached_index == 0
    assert nav.target_index == 1


def test_line_final_waypoint_needs_the_stop_tolerance_not_its_radius() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0), tol=1.0), LINE)
    nav.step(Pose2D(0.0, 0.0, 0.0), 0.0)
    # inside the waypoint's 1 m radius, not yet on the perpendicular line: still flying
    assert nav.step(Pose2D(4.5, 0.0, 0.0), DT).reached_index is None
    # on the line but 0.5 m beside: a precise stop is not over, it is flown to as a point
    beside = nav.step(Pose2D(5.0, 0.5, 0.0), 2 * DT)
    assert beside.reached_index is None and not beside.done
    # crossing within stop_tolerance_m of it ends the mission
    out = nav.step(Pose2D(5.0, 0.05, 0.0), 3 * DT)
    assert out.reached_index == 0
    assert nav.step(Pose2D(5.0, 0.05, 0.0), 4 * DT).done


def test_line_collinear_waypoint_ends_at_its_radius_without_slowing() -> None:
    nav = Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0), (10.0, 0.0), tol=0.3), LINE)
    outputs, end = fly(nav, Pose2D(0.0, 0.0, 0.0))
    reached = [o for o in outputs if o.reached_index == 0]
    assert len(reached) == 1 and reached[0].distance_error_m < 0.3
    assert reached[0].command.vx_mps == pytest.approx(0.6)
    assert math.hypot(end.x_m - 10.0, end.y_m) <= LINE.stop_tolerance_m


def test_line_start_beside_the_leg_aligns_then_tracks() -> None:
    # From a pose with the leg 90° off: ALIGN (turn in place), then TRACK, never ALIGN again.
    nav = Navigator(make_plan(MotionMode.ROLL, (0.0, 6.0)), LINE)
    outputs, _ = fly(nav, Pose2D(0.0, 0.0, 0.0))
    states = collapsed(outputs)
    assert states[:2] == [NavState.ALIGN, NavState.TRACK]
    assert states.count(NavState.ALIGN) == 1


def test_guidance_field_rejects_unknown_law() -> None:
    with pytest.raises(ValueError, match="guidance"):
        ControlConfig(guidance="pure_pursuit")
    with pytest.raises(ValueError, match="braking_accel_mps2"):
        ControlConfig(max_accel_mps2=0.1, braking_accel_mps2=0.2)


def test_line_arc_yaw_feed_forward_counts_the_delivered_speed() -> None:
    # A rover delivering 0.9 of the commanded speed (SCROLL on hard ground, the slip
    # feed-forward capped) turns on a 0.9·R circle at the yaw rate v/R of the commanded v:
    # the arc's yaw rate is fed forward at the delivered speed instead.
    def yaw_rates(fraction: float | None) -> list[float]:
        nav = Navigator(make_plan(MotionMode.ROLL, (5.0, 0.0), (5.0, 5.0), tol=1.0), LINE)
        if fraction is not None:
            nav.set_delivered_fraction(fraction)
        outputs, _ = fly(nav, Pose2D(0.0, 0.0, 0.0))
        return [o.command.wz_radps for o in outputs]

    full, slow = yaw_rates(None), yaw_rates(0.9)
    first = next(i for i, (a, b) in enumerate(zip(full, slow, strict=False)) if a != b)
    assert 0.0 < slow[first] < full[first]  # the same history until the arc's feed-forward
    for nonsense in (0.0, -1.0, 1.5, math.nan, math.inf):
        assert yaw_rates(nonsense) == full


def test_a_plan_with_a_mode_per_waypoint_flies_each_leg_in_its_mode() -> None:
    # roll 10 m north, stop, turn in place, scroll 10 m on (the mode follows the medium)
    wps = (
        PlanWaypoint(0.0, 10.0, 0.5, stop=True, via=True, mode=MotionMode.ROLL),
        PlanWaypoint(0.0, 20.0, 0.5, mode=MotionMode.SCROLL),
    )
    nav = Navigator(Plan("m", MotionMode.ROLL, MissionFrameKind.START, wps, 0.5), ControlConfig())
    end, t_s = Pose2D(0.0, 0.0, math.pi / 2), 0.0
    outputs: list[NavOutput] = []
    while t_s < 120.0 and not nav.done:  # an ideal plant that moves as commanded, any mode
        outputs.append(nav.step(end, t_s))
        end, t_s = integrate(end, outputs[-1].command, DT), t_s + DT
    assert nav.done and math.hypot(end.x_m, end.y_m - 20.0) < 0.5
    first = [o for o in outputs if o.target_index == 0 and o.state is NavState.TRACK]
    second = [o for o in outputs if o.target_index == 1 and o.state is NavState.TRACK]
    assert first and all(o.command.vy_mps == 0.0 for o in first)  # ROLL: along +x only
    assert second and all(o.command.vx_mps == 0.0 for o in second)  # SCROLL: along +y only
    assert any(o.command.vy_mps > 0.1 for o in second)
    # between them a turn in place: aligned, not driven
    turn = [o for o in outputs if o.target_index == 1 and o.state is NavState.ALIGN]
    assert turn and all(o.command.vx_mps == 0.0 and o.command.vy_mps == 0.0 for o in turn)
    assert abs(end.yaw_rad) < 0.3  # SCROLL's +y points north: the body faces east


def test_a_change_of_mode_passed_during_a_pause_is_taken_where_the_rover_stands() -> None:
    """The crew paused just before the roll → scroll stop and the rover coasted 0.6 m past it:
    on resume the stop is reached where it stands and the next leg's turn starts there; a
    step without the resume flies back to the stop (the old behaviour), as it still does when
    the rover stands farther past than the stop's tolerance."""
    wps = (
        PlanWaypoint(0.0, 10.0, 1.0, stop=True, via=True, mode=MotionMode.ROLL, media_stop=True),
        PlanWaypoint(0.0, 30.0, 1.0, mode=MotionMode.SCROLL),
    )
    plan = Plan("m", MotionMode.ROLL, MissionFrameKind.START, wps, 0.6)

    def first_step_after_a_pause(north_m: float, resume: bool) -> NavOutput:
        nav = Navigator(plan, ControlConfig())
        pose, t_s = Pose2D(0.0, 0.0, math.pi / 2), 0.0
        while pose.y_m < 9.0:  # rolled up to a metre before the stop
            out = nav.step(pose, t_s)
            pose, t_s = integrate(pose, out.command, DT), t_s + DT
        if resume:
            nav.resume()
        return nav.step(Pose2D(0.0, north_m, math.pi / 2), t_s + 5.0)  # held 5 s, past it

    out = first_step_after_a_pause(10.6, resume=True)
    assert out.reached_index == 0 and out.target_index == 0 and out.distance_error_m < 0.7
    assert out.command.vx_mps == 0.0 and out.command.vy_mps == 0.0  # the turn in place
    assert first_step_after_a_pause(10.6, resume=False).reached_index is None  # flies back
    assert first_step_after_a_pause(11.5, resume=True).reached_index is None  # too far past
    assert first_step_after_a_pause(9.5, resume=True).reached_index is None  # not there yet


def test_a_change_of_mode_waits_for_the_measured_speed_scrolls_stopped() -> None:
    """A late pose let the rover reach the roll → scroll stop at 0.43 m/s (real SITL under
    load): the mode changed while it still ran. Now the stop holds, scrolls stopped and the
    mode unchanged, until the measured speed is at most mode_change_speed_mps (or
    mode_change_wait_s has passed), even as the rover coasts past the stop's tolerance."""
    wps = (
        PlanWaypoint(0.0, 10.0, 1.0, stop=True, via=True, mode=MotionMode.ROLL, media_stop=True),
        PlanWaypoint(0.0, 30.0, 1.0, mode=MotionMode.SCROLL),
    )
    plan = Plan("m", MotionMode.ROLL, MissionFrameKind.START, wps, 0.6)
    control = ControlConfig(mode_change_speed_mps=0.2, mode_change_wait_s=2.0)

    def at_the_stop(measured_mps: float) -> tuple[Navigator, float]:
        nav = Navigator(plan, control)
        pose, t_s = Pose2D(0.0, 0.0, math.pi / 2), 0.0
        while nav.target_index == 0 and t_s < 120.0:
            nav.set_measured_speed(measured_mps)
            out = nav.step(pose, t_s)
            if out.state is NavState.REACHED and out.target_index == 0:
                return nav, t_s
            pose, t_s = integrate(pose, out.command, DT), t_s + DT
        raise AssertionError("never held at the stop")

    nav, t_s = at_the_stop(0.43)
    for k in range(1, 10):  # coasting on past the stop: still held, nothing driven
        nav.set_measured_speed(0.43)
        out = nav.step(Pose2D(0.0, 10.0 + 0.05 * k, math.pi / 2), t_s + k * DT)
        assert out.state is NavState.REACHED and out.target_index == 0
        assert nav.mode is MotionMode.ROLL
        assert (out.command.vx_mps, out.command.vy_mps, out.command.wz_radps) == (0.0, 0.0, 0.0)
    nav.set_measured_speed(0.15)  # at rest enough: the change happens
    out = nav.step(Pose2D(0.0, 10.5, math.pi / 2), t_s + 10 * DT)
    assert out.reached_index == 0 and nav.mode is MotionMode.SCROLL

    nav, t_s = at_the_stop(0.43)  # a current keeps it moving: changes after the wait anyway
    steps = 0
    while nav.mode is MotionMode.ROLL:
        steps += 1
        nav.set_measured_speed(0.43)
        nav.step(Pose2D(0.0, 10.05, math.pi / 2), t_s + steps * DT)
        assert steps * DT <= 2.0 + 2 * DT
    assert steps * DT >= 2.0 - DT

    # unknown speed (None, NaN) or slow enough: no wait, as before
    for measured in (None, math.nan, 0.1):
        nav = Navigator(plan, control)
        pose, t_s = Pose2D(0.0, 0.0, math.pi / 2), 0.0
        while nav.mode is MotionMode.ROLL and t_s < 120.0:
            nav.set_measured_speed(measured)
            out = nav.step(pose, t_s)
            pose, t_s = integrate(pose, out.command, DT), t_s + DT
        assert nav.mode is MotionMode.SCROLL and 9.8 < pose.y_m < 10.3
