"""Closed-loop behaviour of the Navigator on the ideal kinematic plant at 40 Hz.

The shipped missions (square, hexagon, circle) in all three motion modes from several start
poses, the scroll pipeline with saturation, and the near-goal limit cycle of the thesis's
linear law (which the Navigator must not have).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import pytest

from helixd.base.angles import shortest_angular_distance
from helixd.base.geometry import BodyVelocity, Pose2D
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.control import ControlConfig
from helixd.config.root import HelixdConfig
from helixd.config.vehicle import VehicleConfig
from helixd.control.estimate import estimate_time
from helixd.control.navigator import Navigator, NavState
from helixd.mission.model import load_mission
from helixd.mission.resolve import resolve_plan
from tests.support.ideal_plant import IdealPlant
from tests.support.paths import REPO_ROOT

POSE_RATE_HZ = 40.0  # the fastest LOCAL_POSITION_NED rate Rover grants (docs/ardupilot.md)
DT_S = 1.0 / POSE_RATE_HZ
MISSIONS = REPO_ROOT / "config" / "missions"
CONFIG = HelixdConfig()
CONTROL = CONFIG.control.model_copy(update={"guidance": "thesis"})  # the thesis law, as before
LINE = CONFIG.control.model_copy(update={"guidance": "line"})
GUIDANCE = {"thesis": CONTROL, "line": LINE}

START_POSES = {
    "yaw0": Pose2D(0.0, 0.0, 0.0),
    "yaw+90": Pose2D(0.0, 0.0, math.pi / 2),
    "yaw-90": Pose2D(0.0, 0.0, -math.pi / 2),
    "yaw180": Pose2D(0.0, 0.0, math.pi),
    "offset": Pose2D(-1.5, 2.0, 2.5),
}

# Cross-track bound (m) added to the waypoint tolerance.
#
# Each leg runs from the previous waypoint to the next, but the rover only gets to within
# `tolerance` of the previous waypoint before switching, so a leg starts up to `tolerance`
# off its own line (a square corner cut at 1 m starts the next leg 1 m beside it). From there
# ROLL/SCROLL turn in place until |e_ψ| ≤ heading_threshold (0.2 rad) and then drive at the
# goal while the yaw loop (kp = 8 /s, time constant 1/8 s) removes the remaining error; the
# lateral drift this adds is about v_max · threshold / kp = 0.6 · 0.2 / 8 ≈ 0.015 m. OMNI
# drives a straight line and adds nothing. Bearing-following then only pulls the rover back
# towards the line, so |cross-track| ≤ tolerance + 0.015 m; 0.05 m leaves margin for the
# discrete 40 Hz steps. (The loose bound tolerance + L·sin(0.2) = tolerance + 2 m for the
# square would hide a rover that drives the 0.2 rad deviation uncorrected.) Measured maxima
# are within 0.4 % of the tolerance: square 0.996/1.0, hexagon 0.398/0.4, circle 0.297/0.3.
CROSS_TRACK_MARGIN_M = 0.05


@dataclass(frozen=True)
class RunResult:
    done: bool
    duration_s: float
    arrival_errors_m: tuple[float, ...]  # plant-pose distance to each waypoint when reached
    max_cross_track_m: float
    rms_cross_track_m: float
    states: frozenset[NavState]


def load_plan(shape: str, mode: MotionMode) -> Plan:
    mission = load_mission(MISSIONS / f"{shape}.yaml", CONFIG.mission)
    plan = resolve_plan(mission, CONTROL, CONFIG.mission)
    return replace(plan, mode=mode)


def fly(
    plan: Plan,
    start: Pose2D,
    vehicle: VehicleConfig | None = None,
    limit_s: float = 400.0,
    control: ControlConfig = CONTROL,
) -> RunResult:
    nav = Navigator(plan, control)
    plant = IdealPlant(start, plan.mode, vehicle)
    arrivals: list[float] = []
    squares = 0.0
    worst = 0.0
    steps = 0
    states: set[NavState] = set()
    out = None
    while plant.t_s < limit_s:
        pose = plant.pose
        out = nav.step(pose, plant.t_s)
        states.add(out.state)
        if out.reached_index is not None:
            wp = plan.waypoints[out.reached_index]
            arrivals.append(math.hypot(wp.x_m - pose.x_m, wp.y_m - pose.y_m))
            assert out.distance_error_m == pytest.approx(arrivals[-1])
        if out.done:
            break
        worst = max(worst, abs(out.cross_track_m))
        squares += out.cross_track_m**2
        steps += 1
        plant.step(out.command, DT_S)
    assert out is not None
    return RunResult(
        done=out.done,
        duration_s=plant.t_s,
        arrival_errors_m=tuple(arrivals),
        max_cross_track_m=worst,
        rms_cross_track_m=math.sqrt(squares / max(steps, 1)),
        states=frozenset(states),
    )


def assert_mission_flown(plan: Plan, start: Pose2D, result: RunResult) -> None:
    n = len(plan.waypoints)
    assert result.done, f"not done after {result.duration_s:.0f} s"
    assert len(result.arrival_errors_m) == n
    for i, (err, wp) in enumerate(zip(result.arrival_errors_m, plan.waypoints, strict=True)):
        assert err < wp.tolerance_m, f"waypoint {i}: {err:.3f} m"
    tolerance = max(wp.tolerance_m for wp in plan.waypoints)
    assert result.max_cross_track_m <= tolerance + CROSS_TRACK_MARGIN_M
    # No orbiting or dithering: within a generous multiple of the plan's own estimate (the
    # circle's 0.5 m legs run mostly inside the slow-down ramp, hence the factor).
    estimate_s = estimate_time(plan, CONTROL, (start.x_m, start.y_m), start.yaw_rad).total_s
    assert result.duration_s < 5.0 * estimate_s + 30.0
    if plan.mode is MotionMode.OMNI:
        assert NavState.ALIGN not in result.states


@pytest.mark.parametrize("guidance", list(GUIDANCE))
@pytest.mark.parametrize("start_name", list(START_POSES))
@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("shape", ["square", "hexagon", "circle"])
def test_shipped_missions_in_every_mode(
    shape: str, mode: MotionMode, start_name: str, guidance: str
) -> None:
    plan = load_plan(shape, mode)
    start = START_POSES[start_name]
    assert_mission_flown(plan, start, fly(plan, start, control=GUIDANCE[guidance]))


# A vehicle whose scrolls top out at 60 RPM: a 1 rad/s turn in place needs ~6.1 rad/s per
# scroll, above its 0.9 · 60 RPM = 5.65 rad/s, so the pipeline's joint saturation scales
# the commands down; the navigator must still complete every mission.
WEAK_VEHICLE = VehicleConfig(max_rpm=60.0)


@pytest.mark.parametrize("guidance", list(GUIDANCE))
@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("shape", ["square", "hexagon", "circle"])
def test_missions_through_a_saturating_scroll_pipeline(
    shape: str, mode: MotionMode, guidance: str
) -> None:
    plan = load_plan(shape, mode)
    start = START_POSES["yaw180"]
    plant = IdealPlant(start, mode, WEAK_VEHICLE)
    realised = plant.realised(BodyVelocity(0.0, 0.0, CONTROL.max_yaw_rate_radps))
    if mode is not MotionMode.OMNI:
        assert realised.wz_radps < 0.95 * CONTROL.max_yaw_rate_radps  # saturation is exercised
    assert_mission_flown(plan, start, fly(plan, start, WEAK_VEHICLE, control=GUIDANCE[guidance]))


# -- the limit cycle ------------------------------------------------------------------------


def thesis_linear_law(pose: Pose2D, goal: PlanWaypoint) -> BodyVelocity:
    """Eq. 7/8 as a move-to-point law (Corke): v = kp·e_d, ω = kp·e_ψ, with the same caps,
    driving while turning, no slow-down ramp and no re-alignment once moving."""
    dx, dy = goal.x_m - pose.x_m, goal.y_m - pose.y_m
    e_d = math.hypot(dx, dy)
    e_psi = shortest_angular_distance(pose.yaw_rad, math.atan2(dy, dx))
    v = min(CONTROL.distance_pid.kp * e_d, CONTROL.max_speed_mps)
    w_max = CONTROL.max_yaw_rate_radps
    w = max(-w_max, min(w_max, CONTROL.yaw_pid.kp * e_psi))
    return BodyVelocity(v, 0.0, w)


@dataclass(frozen=True)
class Approach:
    reached: bool
    time_s: float
    closest_m: float
    revolutions: float  # how many times the rover went round the goal
    path_m: float


def approach(
    controller: str,
    goal: PlanWaypoint,
    start: Pose2D,
    mode: MotionMode,
    limit_s: float,
    control: ControlConfig = CONTROL,
) -> Approach:
    plant = IdealPlant(start, mode)
    plan = Plan("near", mode, MissionFrameKind.START, (goal,), control.max_speed_mps)
    nav = Navigator(plan, control)
    closest = math.inf
    swept = path = 0.0
    prev_bearing = math.atan2(start.y_m - goal.y_m, start.x_m - goal.x_m)
    while plant.t_s < limit_s:
        pose = plant.pose
        e_d = math.hypot(goal.x_m - pose.x_m, goal.y_m - pose.y_m)
        closest = min(closest, e_d)
        if e_d < goal.tolerance_m:
            return Approach(True, plant.t_s, closest, abs(swept) / (2 * math.pi), path)
        if controller == "navigator":
            command = nav.step(pose, plant.t_s).command
        else:
            command = thesis_linear_law(pose, goal)
        new = plant.step(command, DT_S)
        path += math.hypot(new.x_m - pose.x_m, new.y_m - pose.y_m)
        bearing = math.atan2(new.y_m - goal.y_m, new.x_m - goal.x_m)
        swept += shortest_angular_distance(prev_bearing, bearing)
        prev_bearing = bearing
    return Approach(False, plant.t_s, closest, abs(swept) / (2 * math.pi), path)


@pytest.mark.parametrize("side_m", [0.6, -0.6, 0.5])
def test_linear_law_orbits_a_goal_beside_the_rover_and_the_navigator_does_not(
    side_m: float,
) -> None:
    # A goal 0.5–0.6 m beside the rover, tolerance 0.3 m (as the shipped circle). With
    # v = 0.6 m/s and ω ≤ 1 rad/s the turning radius is 0.6 m: the goal lies inside the
    # turning circle, so the linear law circles it forever at ~0.5 m, never within 0.3 m.
    goal = PlanWaypoint(0.0, side_m, tolerance_m=0.3)
    start = Pose2D(0.0, 0.0, 0.0)
    naive = approach("thesis", goal, start, MotionMode.ROLL, limit_s=60.0)
    assert not naive.reached
    assert naive.closest_m > 0.45
    assert naive.revolutions > 5.0  # it keeps going round, it is not stuck
    assert naive.path_m > 20.0

    nav = approach("navigator", goal, start, MotionMode.ROLL, limit_s=60.0)
    assert nav.reached
    assert nav.time_s < 5.0
    assert nav.revolutions < 0.5
    assert nav.path_m < abs(side_m)  # turned in place, then straight at it


@pytest.mark.parametrize("guidance", list(GUIDANCE))
@pytest.mark.parametrize("mode", list(MotionMode))
def test_navigator_reaches_every_nearby_goal_without_orbiting(
    mode: MotionMode, guidance: str
) -> None:
    # Goals all around the rover, 0.4–1.6 m away. Inside the slow-down radius the speed is at
    # most v_cruise·e_d/r_slow = 0.3·e_d, so the turning radius v/ω_max ≤ 0.3·e_d stays below
    # e_d/2: no goal can fall inside a turning circle; ROLL/SCROLL also re-align in place
    # whenever |e_ψ| exceeds the threshold. Every goal is reached quickly, without circling.
    start = Pose2D(0.0, 0.0, 0.3)
    for distance_m in (0.4, 0.7, 1.0, 1.6):
        for k in range(12):
            bearing = 2 * math.pi * k / 12
            goal = PlanWaypoint(
                distance_m * math.cos(bearing), distance_m * math.sin(bearing), tolerance_m=0.3
            )
            result = approach("navigator", goal, start, mode, 30.0, GUIDANCE[guidance])
            where = f"goal at {distance_m} m, bearing {math.degrees(bearing):.0f}°"
            assert result.reached, where
            assert result.time_s < 15.0, where
            assert result.revolutions < 0.5, where
            assert result.path_m < distance_m + 0.2, where


@pytest.mark.parametrize("slowdown_radius_m", [CONTROL.slowdown_radius_m, 0.0])
def test_navigator_realigns_when_the_goal_falls_beside_while_tracking(
    slowdown_radius_m: float,
) -> None:
    # The same geometry as the orbit above, but reached while driving: the rover tracks a goal
    # 2 m ahead, and a slip (or a GPS jump) puts the goal 0.6 m to its left. The Navigator must
    # stop and re-align in place — also with the slow-down ramp switched off, so it is the
    # re-alignment, not only the ramp, that breaks the limit cycle.
    control = CONTROL.model_copy(update={"slowdown_radius_m": slowdown_radius_m})
    goal = PlanWaypoint(2.0, 0.0, tolerance_m=0.3)
    plan = Plan("shove", MotionMode.ROLL, MissionFrameKind.START, (goal,), control.max_speed_mps)
    nav = Navigator(plan, control)
    plant = IdealPlant(Pose2D(0.0, 0.0, 0.0), MotionMode.ROLL)
    shoved_at_s: float | None = None
    states_after: list[NavState] = []
    out = nav.step(plant.pose, plant.t_s)
    while not out.done and plant.t_s < 30.0:
        plant.step(out.command, DT_S)
        if shoved_at_s is None and plant.pose.x_m >= 1.0:
            assert out.state is NavState.TRACK and out.command.vx_mps > 0.2
            plant.pose = Pose2D(2.0, -0.6, 0.0)
            shoved_at_s = plant.t_s
        out = nav.step(plant.pose, plant.t_s)
        if shoved_at_s is not None:
            states_after.append(out.state)
    assert shoved_at_s is not None
    assert out.done
    assert states_after[0] is NavState.ALIGN
    assert plant.t_s - shoved_at_s < 5.0
    assert math.hypot(plant.pose.x_m - 2.0, plant.pose.y_m) < 0.3
