"""Line-tracking guidance (control.guidance = "line") on the ideal kinematic plant at 40 Hz.

The rover follows the leg (previous waypoint → waypoint), not the point: it converges on the
line, does not cut corners, stops precisely at the end, and its commands respect the
acceleration limits. The pure helpers of helixd.control.line are checked with numbers.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.base.geometry import BodyVelocity, NonFiniteError, Pose2D
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.control import ControlConfig
from helixd.config.root import HelixdConfig
from helixd.control import line
from helixd.control.navigator import Navigator, NavState
from helixd.mission.model import load_mission
from helixd.mission.resolve import resolve_plan
from helixd.mission.shapes import survey_block
from tests.support.ideal_plant import IdealPlant
from tests.support.paths import REPO_ROOT

DT_S = 1.0 / 40.0
CONFIG = HelixdConfig()
# corner arcs (control.corner_error_m, default 0.25 m): these tests fly them at 0.25 m, set
# explicitly so they keep doing so whatever the default.
# The ideal plant responds at once: no scroll lag for the OMNI arcs' course lead to cancel.
LINE = CONFIG.control.model_copy(
    update={
        "guidance": "line",
        "corner_error_m": 0.25,
        "slip": CONFIG.control.slip.model_copy(update={"command_lag_s": 0.0}),
    }
)
THESIS = CONFIG.control.model_copy(update={"guidance": "thesis"})
MISSIONS = REPO_ROOT / "config" / "missions"
AXIS_RAD = {MotionMode.ROLL: 0.0, MotionMode.SCROLL: math.pi / 2, MotionMode.OMNI: 0.0}


def test_line_is_the_default() -> None:
    assert ControlConfig().guidance == "line"


# -- a flight with an observer against the planned polygon -----------------------------------


@dataclass
class Flight:
    done: bool
    time_s: float
    poses: list[Pose2D]
    commands: list[BodyVelocity]
    states: list[NavState]
    reached: list[tuple[int, float]]  # (index, distance from the plant pose)


def fly(
    plan: Plan,
    start: Pose2D,
    control: ControlConfig = LINE,
    limit_s: float = 300.0,
    nav: Navigator | None = None,
) -> Flight:
    nav = nav or Navigator(plan, control)
    plant = IdealPlant(start, plan.mode)
    flight = Flight(False, 0.0, [], [], [], [])
    while plant.t_s < limit_s:
        out = nav.step(plant.pose, plant.t_s)
        flight.poses.append(plant.pose)
        flight.commands.append(out.command)
        flight.states.append(out.state)
        if out.reached_index is not None:
            wp = plan.waypoints[out.reached_index]
            err = math.hypot(wp.x_m - plant.pose.x_m, wp.y_m - plant.pose.y_m)
            flight.reached.append((out.reached_index, err))
        if out.done:
            flight.done = True
            break
        plant.step(out.command, DT_S)
    flight.time_s = plant.t_s
    return flight


def distance_to_polyline_m(pose: Pose2D, points: list[tuple[float, float]]) -> float:
    best = math.inf
    for (ax, ay), (bx, by) in itertools.pairwise(points):
        lx, ly = bx - ax, by - ay
        l2 = lx * lx + ly * ly
        t = (
            0.0
            if l2 == 0
            else max(0.0, min(1.0, ((pose.x_m - ax) * lx + (pose.y_m - ay) * ly) / l2))
        )
        best = min(best, math.hypot(pose.x_m - ax - t * lx, pose.y_m - ay - t * ly))
    return best


def shipped(shape: str, mode: MotionMode) -> Plan:
    mission = load_mission(MISSIONS / f"{shape}.yaml", CONFIG.mission)
    return replace(resolve_plan(mission, LINE, CONFIG.mission), mode=mode)


def start_pose(mode: MotionMode, course_rad: float = 0.0) -> Pose2D:
    """A pose whose driving axis points along ``course_rad``."""
    return Pose2D(0.0, 0.0, course_rad - AXIS_RAD[mode])


# -- convergence on the line ------------------------------------------------------------------


def straight_leg(name: str, mode: MotionMode, length_m: float) -> Plan:
    """Waypoint 0 on the start pose, then one leg along x to ``length_m`` (at cruise)."""
    wps = (PlanWaypoint(0.0, 0.0, 0.5), PlanWaypoint(length_m, 0.0, 0.5))
    return Plan(name, mode, MissionFrameKind.START, wps, LINE.max_speed_mps)


@pytest.mark.parametrize("heading_rel_rad", [0.0, math.pi / 2, -math.pi / 2, math.pi, 0.6])
@pytest.mark.parametrize("side_m", [2.0, -2.0])
@pytest.mark.parametrize("mode", list(MotionMode))
def test_from_2_m_beside_the_line_within_0_10_m_after_5_m_and_stays(
    mode: MotionMode, side_m: float, heading_rel_rad: float
) -> None:
    # Leg (0, 0) → (20, 0): waypoint 0 sits on the start pose (reached on the first step),
    # then the rover is put 2 m beside the second leg, pointing anywhere.
    plan = straight_leg("beside", mode, 20.0)
    nav = Navigator(plan, LINE)
    first = nav.step(start_pose(mode), 0.0)
    assert first.reached_index == 0
    plant = IdealPlant(Pose2D(0.0, side_m, heading_rel_rad - AXIS_RAD[mode]), mode, t_s=DT_S)
    travelled_m = 0.0
    worst_after_5_m = 0.0
    out = first
    while not out.done and plant.t_s < 120.0:
        out = nav.step(plant.pose, plant.t_s)
        if not out.done:
            assert abs(out.cross_track_m - plant.pose.y_m) < 1e-9  # the leg is the x axis
        if travelled_m >= 5.0:
            worst_after_5_m = max(worst_after_5_m, abs(plant.pose.y_m))
        before = plant.pose
        after = plant.step(out.command, DT_S)
        travelled_m += math.hypot(after.x_m - before.x_m, after.y_m - before.y_m)
    assert out.done
    assert travelled_m > 15.0  # the check above covered most of the leg
    assert worst_after_5_m <= 0.10


@pytest.mark.parametrize("mode", list(MotionMode))
def test_convergence_is_monotonic_no_crossing_of_the_line(mode: MotionMode) -> None:
    # de/ds = −e/√(e² + L²) on the ideal plant: the rover approaches from its side and does
    # not overshoot by more than the yaw loop's lag (v/kp ≈ 0.075 m at cruise; here 0.05 m
    # is asserted since the approach is made at a shallow angle).
    plan = straight_leg("side", mode, 30.0)
    nav = Navigator(plan, LINE)
    nav.step(start_pose(mode), 0.0)
    flight = fly(plan, Pose2D(0.0, 2.0, -AXIS_RAD[mode]), nav=nav)
    assert flight.done
    assert min(p.y_m for p in flight.poses) > -0.05


# -- the shipped missions: their goals --------------------------------------------------


# Corner bounds with the default corner error budget e (0.25 m): each corner that is not a
# stop is an arc tangent to both legs whose middle passes e from the vertex, i.e. e·cos(θ/2)
# from the nearest leg (square θ = 90°: 0.177 m; hexagon θ = 60°: its 2 m sides cap the arc
# at T = 1 m, R = 1.73 m, 0.155 m from the legs), plus 0.02 m of tracking error allowed on
# the ideal plant (measured: the rover stays within 0.003–0.018 m of the designed path,
# test_shipped_missions_fly_the_designed_path). The circle's corners (15°) are limited by half
# its 0.52 m chords: R ≈ 2 m, 0.017 m from the vertex; its first corner, from the start leg,
# turns 117° with e capped at the circle's 0.3 m tolerance... measured 0.10 m; bound 0.12 m.
ARC_BOUND_M = {
    "square": LINE.corner_error_m * math.cos(math.pi / 4) + 0.02,
    "hexagon": LINE.corner_error_m * math.cos(math.pi / 6) + 0.02,
    "circle": 0.12,
}
# Without arcs (corner_error_m = 0, the behaviour before corner arcs): a pivot corner (square
# 90°, hexagon 60° > pivot 45°) is driven onto the perpendicular line at min_speed
# v_min = 0.1 m/s and braked at a = 0.3 m/s², so it runs past by at most v_min²/(2a) =
# 0.017 m plus one 40 Hz step (v_min·dt = 0.0025 m): 0.02 m. The gentle circle corners (15°)
# are rounded by the lookahead law on an arc about L from the vertex, R = L/tan(θ/2); its
# distance from the vertex is L·tan(θ/4) = 0.066 m for L = 1 m, and the rover re-converges on
# each 0.52 m chord from there: 0.10 m.
PIVOT_BOUND_M = {"square": 0.02, "hexagon": 0.02, "circle": 0.10}
NO_ARCS = LINE.model_copy(update={"corner_error_m": 0.0})


def polyline_errors(flight: Flight, plan: Plan, start: Pose2D) -> list[float]:
    points = [(start.x_m, start.y_m)] + [(w.x_m, w.y_m) for w in plan.waypoints]
    return [distance_to_polyline_m(p, points) for p in flight.poses]


@pytest.mark.parametrize(("control", "bound_m"), [(LINE, ARC_BOUND_M), (NO_ARCS, PIVOT_BOUND_M)])
@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("shape", ["square", "hexagon", "circle"])
def test_shipped_missions_follow_the_polygon(
    shape: str, mode: MotionMode, control: ControlConfig, bound_m: dict[str, float]
) -> None:
    plan = shipped(shape, mode)
    start = start_pose(mode)
    flight = fly(plan, start, control)
    assert flight.done
    errors = polyline_errors(flight, plan, start)
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    assert max(errors) <= bound_m[shape]
    assert rms <= 0.10
    assert [i for i, _ in flight.reached] == list(range(len(plan.waypoints)))
    final = plan.waypoints[-1]
    final_error_m = math.hypot(final.x_m - flight.poses[-1].x_m, final.y_m - flight.poses[-1].y_m)
    assert final_error_m <= control.stop_tolerance_m
    if mode is MotionMode.OMNI:
        assert NavState.ALIGN not in flight.states


def designed_path(plan: Plan, start: Pose2D, control: ControlConfig) -> list[tuple[float, float]]:
    """The path the navigator plans, densely sampled: the legs with every corner that is not a
    stop replaced by its arc (from the arc's start on the leg in to its end on the leg out)."""
    points = [(start.x_m, start.y_m)] + [(w.x_m, w.y_m) for w in plan.waypoints]
    yaw = control.max_yaw_rate_radps  # OMNI: the turn rate of its direction of travel
    path = [points[0]]
    for a, b, c in zip(points, points[1:], points[2:], strict=False):
        tol = next(w.tolerance_m for w in plan.waypoints if (w.x_m, w.y_m) == b)
        arc = line.corner_arc(
            a, b, c, min(control.corner_error_m, tol), plan.speed_mps,
            control.max_lateral_accel_mps2, yaw, control.min_speed_mps,
        )  # fmt: skip
        if arc is None:
            path.append(b)
            continue
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        begin = (
            b[0] - (b[0] - a[0]) / length * arc.tangent_m,
            b[1] - (b[1] - a[1]) / length * arc.tangent_m,
        )
        cx, cy = arc.center_xy_m
        phi = math.atan2(begin[1] - cy, begin[0] - cx)
        path += [
            (
                cx + arc.radius_m * math.cos(phi + arc.turn_rad * k / 50),
                cy + arc.radius_m * math.sin(phi + arc.turn_rad * k / 50),
            )
            for k in range(51)
        ]
    path.append(points[-1])
    return path


@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("shape", ["square", "hexagon", "circle", "survey"])
def test_shipped_missions_fly_the_designed_path(shape: str, mode: MotionMode) -> None:
    # Legs and corner arcs: with the yaw rate fed forward and ramped at the yaw-acceleration
    # limit across the arcs' ends, the rover stays within 0.03 m of the planned path (measured
    # 0.003–0.018 m), turns in place nowhere (it starts facing the first leg) and passes every
    # corner within its budget of the vertex.
    plan = shipped(shape, mode)
    start = start_pose(mode)
    flight = fly(plan, start, limit_s=600.0)
    assert flight.done
    path = designed_path(plan, start, LINE)
    assert max(distance_to_polyline_m(p, path) for p in flight.poses) <= 0.03
    assert NavState.ALIGN not in flight.states
    for i, wp in enumerate(plan.waypoints[:-1]):
        closest = min(math.hypot(p.x_m - wp.x_m, p.y_m - wp.y_m) for p in flight.poses)
        assert closest <= min(LINE.corner_error_m, wp.tolerance_m) + 0.02, i


@pytest.mark.parametrize("mode", list(MotionMode))
def test_square_meets_its_goals_and_beats_the_thesis_law(mode: MotionMode) -> None:
    # The targets: RMS ≤ 0.10 m, max ≤ 0.40 m, final ≤ 0.15 m, time ≤ 100 s.
    plan = shipped("square", mode)
    start = start_pose(mode)
    points = [(0.0, 0.0)] + [(w.x_m, w.y_m) for w in plan.waypoints]
    results = {}
    for name, control in (("line", LINE), ("thesis", THESIS)):
        flight = fly(plan, start, control)
        assert flight.done
        errors = [distance_to_polyline_m(p, points) for p in flight.poses]
        end = flight.poses[-1]
        results[name] = (
            math.sqrt(sum(e * e for e in errors) / len(errors)),
            max(errors),
            math.hypot(end.x_m, end.y_m),
            flight.time_s,
        )
    rms, worst, final, time_s = results["line"]
    assert rms <= 0.10 and worst <= 0.40 and final <= 0.15 and time_s <= 100.0
    assert results["thesis"][0] > 4 * rms  # the thesis law cuts the corners (rms ≈ 0.45 m)


# -- stops, corners, straight lines ------------------------------------------------------------


def corner_plan(turn_rad: float, mode: MotionMode) -> Plan:
    """(0, 0) → (10, 0) → 10 m on at ``turn_rad`` to the left."""
    far = (10.0 + 10.0 * math.cos(turn_rad), 10.0 * math.sin(turn_rad))
    wps = (PlanWaypoint(10.0, 0.0, 1.0), PlanWaypoint(*far, 1.0))
    return Plan("corner", mode, MissionFrameKind.START, wps, LINE.max_speed_mps)


def speeds_near(flight: Flight, xy: tuple[float, float], radius_m: float) -> list[float]:
    return [
        math.hypot(c.vx_mps, c.vy_mps)
        for p, c in zip(flight.poses, flight.commands, strict=True)
        if math.hypot(p.x_m - xy[0], p.y_m - xy[1]) < radius_m
    ]


@pytest.mark.parametrize("mode", [MotionMode.ROLL, MotionMode.SCROLL])
@pytest.mark.parametrize(
    ("control", "plan"),
    [
        (NO_ARCS, "square"),  # no budget: every 90° corner of the square is a pivot
        (LINE, "sharp"),  # 150°: its arc could only be flown below min_speed_mps
    ],
)
def test_sharp_corner_is_a_pivot_turn_in_place(
    mode: MotionMode, control: ControlConfig, plan: str
) -> None:
    flown = shipped("square", mode) if plan == "square" else corner_plan(math.radians(150), mode)
    flight = fly(flown, start_pose(mode), control)
    assert flight.done
    # Right after each corner the rover turns in place (ALIGN) with no translation.
    align_cmds = [
        c for c, s in zip(flight.commands, flight.states, strict=True) if s is NavState.ALIGN
    ]
    assert align_cmds
    assert max(math.hypot(c.vx_mps, c.vy_mps) for c in align_cmds) <= 0.1 + 1e-9
    # Each corner is arrived at within stop tolerance (the line through it).
    assert all(err <= control.stop_tolerance_m + 1e-9 for _, err in flight.reached)


@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("turn_deg", [30, 60, 90, 120])
def test_corner_within_the_budget_is_an_arc_flown_at_its_speed(
    mode: MotionMode, turn_deg: int
) -> None:
    flown = corner_plan(math.radians(turn_deg), mode)
    flight = fly(flown, start_pose(mode))
    assert flight.done
    yaw = LINE.max_yaw_rate_radps  # OMNI: the turn rate of its direction of travel
    arc = line.corner_arc(
        (0.0, 0.0), (10.0, 0.0), (flown.waypoints[1].x_m, flown.waypoints[1].y_m),
        LINE.corner_error_m, LINE.max_speed_mps, LINE.max_lateral_accel_mps2, yaw,
        LINE.min_speed_mps,
    )  # fmt: skip
    assert arc is not None
    assert NavState.ALIGN not in flight.states  # no turn in place
    # on the arc: nearer the vertex than its ends (T from it); the speed may rise after it
    at_corner = speeds_near(flight, (10.0, 0.0), 0.9 * arc.tangent_m)
    assert at_corner and max(at_corner) <= arc.speed_mps + 0.01  # a_lat and yaw rate held
    assert min(at_corner) >= 0.9 * arc.speed_mps  # flown through, not stopped
    closest = min(math.hypot(p.x_m - 10.0, p.y_m) for p in flight.poses)
    assert abs(closest - arc.corner_error_m) <= 0.02  # the budget, used and kept
    assert arc.corner_error_m <= LINE.corner_error_m + 1e-9
    if mode is not MotionMode.OMNI:  # |ω| = v/R within the yaw-rate limit
        assert max(abs(c.wz_radps) for c in flight.commands) <= LINE.max_yaw_rate_radps + 1e-9


@pytest.mark.parametrize("mode", list(MotionMode))
def test_survey_block_arcs_beat_the_pivots(mode: MotionMode) -> None:
    # The shipped survey block (10 corners of 90°): flown on arcs it takes ≥ 15 s less than
    # with stop-and-pivot corners on the ideal plant (measured 18 s; on the sitl_skid plant,
    # whose speed lags the command, 79 s: tests/integration/test_skid_plant_flights.py).
    plan = shipped("survey", mode)
    arcs = fly(plan, start_pose(mode), limit_s=600.0)
    pivots = fly(plan, start_pose(mode), NO_ARCS, limit_s=600.0)
    assert arcs.done and pivots.done
    assert arcs.time_s <= pivots.time_s - 15.0
    assert NavState.ALIGN not in arcs.states


def test_speed_profile_looks_only_as_far_as_it_can_matter(monkeypatch: pytest.MonkeyPatch) -> None:
    # A lawn-mower of 41 flown-through arc corners: without a horizon the speed profile and the
    # distance to the next stop would loop over every remaining waypoint at every step. With
    # it: the same commands, and a handful of waypoints looked at per step.
    plan = Plan(
        "mower", MotionMode.ROLL, MissionFrameKind.START,
        tuple(PlanWaypoint(*xy, 1.0) for xy in survey_block(21, 6.0, 2.0)), LINE.max_speed_mps,
    )  # fmt: skip
    calls: list[int] = []
    real = line.braking_speed_mps

    def counted(d: float, v: float, a: float) -> float:
        calls.append(1)
        return real(d, v, a)

    monkeypatch.setattr(line, "braking_speed_mps", counted)
    bounded = fly(plan, start_pose(MotionMode.ROLL), limit_s=900.0)
    per_step = len(calls) / len(bounded.commands)
    monkeypatch.setattr(line, "lookahead_horizon_m", lambda v, early, cfg: math.inf)
    calls.clear()
    unbounded = fly(plan, start_pose(MotionMode.ROLL), limit_s=900.0)
    assert bounded.done and unbounded.done
    assert bounded.commands == unbounded.commands
    assert per_step <= 4.0 < len(calls) / len(unbounded.commands)


def fly_lagged(
    nav: Navigator,
    start: Pose2D,
    tau_s: float,
    until_s: float,
    track: list[Pose2D] | None = None,
) -> tuple[Any, float]:
    """Fly ``nav`` in OMNI on an ideal plant whose velocity follows the command through a
    first-order lag ``tau_s`` (the simulator's scroll motors) until done or ``until_s``;
    ``track`` collects the pose after each plant step. The last output and the plant's time."""
    plant = IdealPlant(start, MotionMode.OMNI)
    applied = BodyVelocity.zero()
    while plant.t_s < until_s:
        out = nav.step(plant.pose, plant.t_s)
        if out.done:
            break
        k = DT_S / tau_s
        applied = BodyVelocity(
            applied.vx_mps + k * (out.command.vx_mps - applied.vx_mps),
            applied.vy_mps + k * (out.command.vy_mps - applied.vy_mps),
            0.0,
        )
        plant.step(applied, DT_S)
        if track is not None:
            track.append(plant.pose)
    return out, plant.t_s


def test_omni_arc_course_lead_cancels_the_scroll_lag() -> None:
    # A plant whose velocity follows the command through a first-order lag τ = 0.3 s (the
    # simulator's scroll motors): flown without the lead the rover drifts out of each arc by
    # ≈ L·(v/R)·τ; with control.slip.command_lag_s = τ the course leads by (v/R)·τ.
    tau_s = 0.3
    plan = shipped("hexagon", MotionMode.OMNI)
    start = start_pose(MotionMode.OMNI)
    path = designed_path(plan, start, LINE)
    worst = {}
    for lag_s in (0.0, tau_s):
        slip = LINE.slip.model_copy(update={"command_lag_s": lag_s})
        nav = Navigator(plan, LINE.model_copy(update={"slip": slip}))
        poses: list[Pose2D] = []
        out, _ = fly_lagged(nav, start, tau_s, 120.0, poses)
        assert out.done
        worst[lag_s] = max(distance_to_polyline_m(pose, path) for pose in poses)
    assert worst[tau_s] <= 0.5 * worst[0.0], worst
    assert worst[tau_s] <= 0.07, worst  # measured 0.055 m


def test_sharp_omni_corners_are_stops_not_orbits() -> None:
    # OMNI turns its direction of travel, not its heading, on an arc; without a bound on that
    # turn rate a 164° corner got a 0.04 m arc at √(a_lat·R) = 0.11 m/s (v/R = 2.7 rad/s) the
    # rover could not follow through the scrolls' lag: it orbited the corner for ever. The
    # direction turns no faster than max_yaw_rate_radps (v ≤ ω·R, as ROLL and SCROLL turn):
    # such corners are stops, the gentler ones keep their arcs. (A random plan of
    # tests/control/test_estimate.py, flown through a first-order lag τ = 0.3 s with the
    # matching course lead.)
    tau_s = 0.3
    start = Pose2D(-1.4146166416610395, 1.7093702905833879, -0.4008862589170521)
    xy_tol = [
        (6.059613429428733, 2.1849273230620128, 0.3),
        (-14.645650523529612, 3.8140958018370377, 0.3),
        (10.60378977674323, -5.558938139354142, 1.0),
        (-3.897284085029108, 10.234422776966333, 0.3),
        (-2.3159035270609643, -13.388647229132589, 1.0),
    ]
    wps = tuple(PlanWaypoint(x, y, tol) for x, y, tol in xy_tol)
    plan = Plan("sharp-omni", MotionMode.OMNI, MissionFrameKind.START, wps, 1.0)
    control = LINE.model_copy(
        update={"slip": LINE.slip.model_copy(update={"command_lag_s": tau_s})}
    )
    points = [(start.x_m, start.y_m)] + [(w.x_m, w.y_m) for w in wps]
    corners = line.plan_corners(
        points, [w.tolerance_m for w in wps], [False] * len(wps), 1.0, control
    )
    for arc in corners.arcs:
        if arc is not None:
            assert arc.speed_mps <= control.max_yaw_rate_radps * arc.radius_m + 1e-9
    # 172°, 164° and 153° corners are stops; the 141° one keeps an arc (R 0.12 m, 0.12 m/s)
    assert corners.stops[:3] == [True, True, True] and corners.arcs[3] is not None
    out, t_s = fly_lagged(Navigator(plan, control), start, tau_s, 300.0)
    assert out.done, (t_s, out.target_index)  # measured: done in 125 s


def test_waypoint_with_a_heading_is_a_stop_even_where_an_arc_would_fit() -> None:
    heading = PlanWaypoint(10.0, 0.0, 1.0, final_yaw_rad=math.pi / 2)
    plan = Plan(
        "hold-heading", MotionMode.ROLL, MissionFrameKind.START,
        (heading, PlanWaypoint(10.0, 10.0, 1.0)), LINE.max_speed_mps,
    )  # fmt: skip
    flight = fly(plan, Pose2D(0.0, 0.0, 0.0))
    assert flight.done
    assert flight.reached[0][1] <= LINE.stop_tolerance_m  # stopped on it, precisely
    assert NavState.FINAL_HEADING in flight.states
    assert min(speeds_near(flight, (10.0, 0.0), 0.05)) == 0.0


@pytest.mark.parametrize("mode", list(MotionMode))
def test_collinear_waypoints_are_flown_through_at_speed(mode: MotionMode) -> None:
    wps = tuple(PlanWaypoint(5.0 * k, 0.0, 0.3) for k in range(1, 5))
    plan = Plan("straight", mode, MissionFrameKind.START, wps, LINE.max_speed_mps)
    flight = fly(plan, start_pose(mode))
    assert flight.done
    assert len(flight.reached) == 4
    cruise = [
        math.hypot(c.vx_mps, c.vy_mps)
        for p, c in zip(flight.poses, flight.commands, strict=True)
        if 2.0 <= p.x_m <= 18.0
    ]
    assert min(cruise) >= 0.99 * LINE.max_speed_mps  # no stop-and-go at 5, 10, 15 m
    assert max(abs(p.y_m) for p in flight.poses) < 1e-6


@pytest.mark.parametrize("mode", list(MotionMode))
def test_gentle_corner_flown_with_the_turn_geometry_speed_limit(mode: MotionMode) -> None:
    # Without arcs (corner_error_m = 0) a corner gentler than the pivot angle (45°) is rounded
    # by the lookahead law, at cruise with the defaults (R = L/tan(θ/2) ≥ 2.4 m,
    # √(0.3·2.4) > 0.6 m/s); a lower lateral-acceleration limit makes the geometry limit
    # bite: 0.1 m/s² through 0.75 rad gives 0.50 m/s. (With arcs: the test above.)
    control = NO_ARCS.model_copy(update={"max_lateral_accel_mps2": 0.1})
    turn = 0.75  # rad, gentler than pivot_angle_rad
    far = (10.0 + 10.0 * math.cos(turn), 10.0 * math.sin(turn))
    plan = Plan(
        "gentle",
        mode,
        MissionFrameKind.START,
        (PlanWaypoint(10.0, 0.0, 0.5), PlanWaypoint(*far, 0.3)),
        LINE.max_speed_mps,
    )
    flight = fly(plan, start_pose(mode), control)
    assert flight.done
    expected = line.corner_speed_mps(
        turn,
        control.max_speed_mps,
        control.lookahead_m,
        control.max_lateral_accel_mps2,
        control.max_yaw_rate_radps,
    )
    assert 0.1 < expected < LINE.max_speed_mps
    at_corner = [
        math.hypot(c.vx_mps, c.vy_mps)
        for p, c in zip(flight.poses, flight.commands, strict=True)
        if math.hypot(p.x_m - 10.0, p.y_m) < 0.3
    ]
    assert at_corner and max(at_corner) <= expected + 0.02
    assert min(at_corner) >= 0.5 * expected  # flown through, not stopped
    assert NavState.ALIGN not in flight.states
    points = [(0.0, 0.0), (10.0, 0.0), far]
    # The leg ends 0.5 m (pass-through radius r) before the vertex; the rounded path stays
    # inside the chord joining the points r before and after it, r·sin(θ/2) = 0.18 m from the
    # vertex (measured: 0.15 m).
    bound_m = 0.5 * math.sin(turn / 2)
    assert max(distance_to_polyline_m(p, points) for p in flight.poses) <= bound_m


@pytest.mark.parametrize("mode", list(MotionMode))
def test_commands_respect_the_acceleration_limits(mode: MotionMode) -> None:
    flight = fly(shipped("square", mode), start_pose(mode))
    # Not the final arrival: there the command steps from v_min (0.1 m/s) to zero, the stop.
    assert flight.states[-2:] == [NavState.REACHED, NavState.DONE]
    assert flight.commands[-2] == BodyVelocity.zero()
    pairs = list(itertools.pairwise(flight.commands[:-2]))
    dv = LINE.max_accel_mps2 * DT_S
    dw = LINE.max_yaw_accel_radps2 * DT_S
    for a, b in pairs:
        # along and across the commanded direction: at most √2 · a · dt in the plane
        assert math.hypot(b.vx_mps - a.vx_mps, b.vy_mps - a.vy_mps) <= math.sqrt(2) * dv + 1e-9
        assert abs(b.wz_radps - a.wz_radps) <= dw + 1e-9


@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("offset_m", [0.0, 0.05, 0.3, -0.3, 0.6])
def test_no_orbit_when_the_final_goal_is_passed_beside(mode: MotionMode, offset_m: float) -> None:
    # The rover is put on a parallel line offset_m beside the leg, at its end: the goal is
    # almost abeam. It must end without circling the goal, near it, quickly.
    goal = PlanWaypoint(5.0, 0.0, 1.0)
    plan = Plan("abeam", mode, MissionFrameKind.START, (PlanWaypoint(0.0, 0.0, 0.5), goal), 0.6)
    nav = Navigator(plan, LINE)
    nav.step(start_pose(mode), 0.0)
    flight = fly(plan, Pose2D(4.8, offset_m, -AXIS_RAD[mode]), nav=nav, limit_s=30.0)
    assert flight.done and flight.time_s < 20.0
    swept = 0.0
    prev = None
    for p in flight.poses:
        bearing = math.atan2(p.y_m - goal.y_m, p.x_m - goal.x_m)
        if prev is not None:
            swept += math.remainder(bearing - prev, 2 * math.pi)
        prev = bearing
    # Passing straight through the goal sweeps exactly π, beside it less; an orbit 2π.
    assert abs(swept) < 1.5 * math.pi
    end = flight.poses[-1]
    assert math.hypot(end.x_m - goal.x_m, end.y_m - goal.y_m) <= goal.tolerance_m


def test_final_heading_waypoint_is_a_precise_stop_then_a_turn() -> None:
    goal = PlanWaypoint(6.0, 0.0, 1.0, final_yaw_rad=math.pi / 2)
    plan = Plan("heading", MotionMode.ROLL, MissionFrameKind.START, (goal,), 0.6)
    flight = fly(plan, Pose2D(0.0, 0.0, 0.0))
    assert flight.done
    assert flight.reached[0][1] <= LINE.stop_tolerance_m
    assert NavState.FINAL_HEADING in flight.states
    end = flight.poses[-1]
    assert abs(math.remainder(end.yaw_rad - math.pi / 2, 2 * math.pi)) <= (
        LINE.final_heading_tolerance_rad
    )


# -- pure helpers -----------------------------------------------------------------------------


def test_leg_errors_numbers() -> None:
    leg = line.leg_errors((0.0, 0.0), (10.0, 0.0), Pose2D(3.0, 2.0, 0.0))
    assert leg.cross_track_m == pytest.approx(2.0)
    assert leg.along_to_go_m == pytest.approx(7.0)
    assert leg.course_rad == pytest.approx(0.0)
    past = line.leg_errors((0.0, 0.0), (0.0, 10.0), Pose2D(1.0, 11.0, 0.0))
    assert past.along_to_go_m == pytest.approx(-1.0)
    assert past.cross_track_m == pytest.approx(-1.0)  # right of a northward leg
    point = line.leg_errors((1.0, 1.0), (1.0, 1.0), Pose2D(1.0, 3.0, 0.0))
    assert point.length_m == 0.0 and point.along_to_go_m == pytest.approx(2.0)
    assert point.course_rad == pytest.approx(-math.pi / 2)


def test_line_course_and_corner_speed_numbers() -> None:
    assert line.line_course_rad(0.0, 1.0, 1.0) == pytest.approx(-math.pi / 4)
    assert line.line_course_rad(0.0, -1e9, 1.0) == pytest.approx(math.pi / 2)  # never past ⊥
    assert line.corner_speed_mps(0.0, 0.6, 1.0, 0.3, 1.0) == 0.6
    # θ = 90°: R = L / tan 45° = 1 m, √(0.3 · 1) = 0.548 m/s
    assert line.corner_speed_mps(math.pi / 2, 0.6, 1.0, 0.3, 1.0) == pytest.approx(math.sqrt(0.3))
    assert line.corner_speed_mps(math.pi, 0.6, 1.0, 0.3, 1.0) == 0.0
    assert line.braking_speed_mps(0.6, 0.0, 0.3) == pytest.approx(0.6)


def test_waypoint_speed_limits_marks_pivots_and_stops() -> None:
    points = [(0.0, 0.0), (5.0, 0.0), (10.0, 0.0), (10.0, 5.0), (11.0, 9.0)]
    speeds, stops = line.waypoint_speed_limits(
        points, [False, False, False, False], 0.6, 0.785, 1.0, 0.3, 1.0
    )
    assert stops == [False, True, False, True]  # collinear, 90° pivot, 14° gentle, last
    assert speeds[0] == 0.6
    assert speeds[2] == pytest.approx(
        line.corner_speed_mps(math.atan2(1.0, 4.0), 0.6, 1.0, 0.3, 1.0)
    )
    assert speeds[1] == speeds[3] == 0.0
    # with arcs: a corner with one is passed at its speed, a collinear one at cruise, one
    # without an arc (too sharp for the budget) is a stop
    arc = line.corner_arc(points[1], points[2], points[3], 0.25, 0.6, 0.3, 1.0, 0.1)
    assert arc is not None
    speeds, stops = line.waypoint_speed_limits(
        points, [False] * 4, 0.6, 0.785, 1.0, 0.3, 1.0, [None, arc, None, None]
    )
    assert stops == [False, False, True, True]
    assert speeds[:2] == [0.6, arc.speed_mps]


def test_corner_arc_numbers_for_a_90_degree_corner() -> None:
    # e = 0.15 m: R·(1/cos 45° − 1) = e → R = 0.15/(√2 − 1) = 0.3621 m, T = R·tan 45° = R,
    # centre R left of the first leg and R before the vertex; v = √(0.3·R) = 0.330 m/s
    # (yaw rate v/R = 0.91 rad/s < 1 rad/s).
    arc = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), 0.15, 0.6, 0.3, 1.0, 0.1)
    assert arc is not None
    r = 0.15 / (math.sqrt(2.0) - 1.0)
    assert arc.radius_m == pytest.approx(r)
    assert arc.tangent_m == pytest.approx(r)
    assert arc.center_xy_m == pytest.approx((10.0 - r, r))
    assert arc.corner_error_m == pytest.approx(0.15)
    assert arc.turn_rad == pytest.approx(math.pi / 2)
    assert arc.speed_mps == pytest.approx(math.sqrt(0.3 * r))
    assert arc.curvature_per_m == pytest.approx(1.0 / r)
    # a right turn mirrors it, and OMNI (no yaw limit) gets the same a_lat speed
    right = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, -10.0), 0.15, 0.6, 0.3, None, 0.1)
    assert right is not None and right.center_xy_m == pytest.approx((10.0 - r, -r))
    assert right.turn_rad == pytest.approx(-math.pi / 2) and right.curvature_per_m < 0.0
    # the yaw-rate limit binds for a slow turn: v = ω·R
    slow = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), 0.15, 0.6, 0.3, 0.5, 0.1)
    assert slow is not None and slow.speed_mps == pytest.approx(0.5 * r)


def test_corner_arc_limits_and_refusals() -> None:
    # a short leg caps the arc at half its length: T = 0.5 m on a 1 m crossover
    short = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, 1.0), 1.0, 0.6, 0.3, 1.0, 0.1)
    assert short is not None and short.tangent_m == pytest.approx(0.5)
    assert short.corner_error_m < 1.0
    # a gentle corner gets no larger radius than cruise needs (v²/a_lat = 1.2 m): closer
    gentle = line.corner_arc((0.0, 0.0), (10.0, 0.0), (20.0, 1.0), 0.15, 0.6, 0.3, 1.0, 0.1)
    assert gentle is not None and gentle.radius_m == pytest.approx(1.2)
    assert gentle.speed_mps == pytest.approx(0.6) and gentle.corner_error_m < 0.15
    # collinear, reversal, degenerate leg, no budget, too sharp for min_speed: no arc
    assert line.corner_arc((0.0, 0.0), (5.0, 0.0), (10.0, 0.0), 0.15, 0.6, 0.3, 1.0, 0.1) is None
    assert line.corner_arc((0.0, 0.0), (5.0, 0.0), (0.0, 0.0), 0.15, 0.6, 0.3, 1.0, 0.1) is None
    assert line.corner_arc((5.0, 0.0), (5.0, 0.0), (5.0, 5.0), 0.15, 0.6, 0.3, 1.0, 0.1) is None
    assert line.corner_arc((0.0, 0.0), (5.0, 0.0), (5.0, 5.0), 0.0, 0.6, 0.3, 1.0, 0.1) is None
    sharp = (5.0 + 5.0 * math.cos(math.radians(150)), 5.0 * math.sin(math.radians(150)))
    assert line.corner_arc((0.0, 0.0), (5.0, 0.0), sharp, 0.15, 0.6, 0.3, 1.0, 0.1) is None
    nan_c = (5.0, math.nan)
    assert line.corner_arc((0.0, 0.0), (5.0, 0.0), nan_c, 0.15, 0.6, 0.3, 1.0, 0.1) is None


def test_arc_errors_and_the_bisector() -> None:
    arc = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), 0.15, 0.6, 0.3, 1.0, 0.1)
    assert arc is not None
    r, (cx, cy) = arc.radius_m, arc.center_xy_m
    # on the arc at its start: heading east, no error; 5 cm inside: 5 cm left
    assert line.arc_errors(arc, Pose2D(cx, cy - r, 0.0)) == pytest.approx((0.0, 0.0))
    assert line.arc_errors(arc, Pose2D(cx, cy - r + 0.05, 0.0))[1] == pytest.approx(0.05)
    # at the middle: heading north-east; outside the arc = right of it
    mid = Pose2D(cx + r / math.sqrt(2.0), cy - r / math.sqrt(2.0), 0.0)
    assert line.arc_errors(arc, mid)[0] == pytest.approx(math.pi / 4)
    out = Pose2D(cx + 1.1 * r / math.sqrt(2.0), cy - 1.1 * r / math.sqrt(2.0), 0.0)
    assert line.arc_errors(arc, out)[1] == pytest.approx(-0.1 * r)
    assert line.past_corner(arc, Pose2D(mid.x_m + 1e-6, mid.y_m + 1e-6, 0.0))
    assert not line.past_corner(arc, Pose2D(mid.x_m - 1e-6, mid.y_m - 1e-6, 0.0))
    with pytest.raises(NonFiniteError):
        line.arc_errors(arc, Pose2D(math.nan, 0.0, 0.0))
    right = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, -10.0), 0.15, 0.6, 0.3, 1.0, 0.1)
    assert right is not None
    inside = Pose2D(right.center_xy_m[0], right.center_xy_m[1] + 0.9 * r, 0.0)
    assert line.arc_errors(right, inside)[1] == pytest.approx(-0.1 * r)  # right of the path


def test_arc_blend_ramps_the_yaw_rate_and_its_heading_lead() -> None:
    arc = line.corner_arc((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), 0.15, 0.6, 0.3, 1.0, 0.1)
    assert arc is not None
    d = line.arc_ramp_m(arc, 2.0)
    assert d == pytest.approx(arc.speed_mps**2 / arc.radius_m / 2.0)
    length = arc.radius_m * math.pi / 2
    k = arc.curvature_per_m
    assert line.arc_blend(arc, -d / 2 - 1e-9, length, d) == (0.0, 0.0)  # before the ramp
    assert line.arc_blend(arc, 0.0, length, d) == pytest.approx((0.5, k * d / 8))  # at its start
    assert line.arc_blend(arc, d / 2, length - d / 2, d) == pytest.approx((1.0, 0.0))
    assert line.arc_blend(arc, length, 0.0, d) == pytest.approx((0.5, -k * d / 8))  # at its end
    assert line.arc_blend(arc, length + d, -d / 2, d) == pytest.approx((0.0, 0.0))
    # the heading offset is the integral of the missing yaw rate: continuous, 0 at both ends
    steps = [-d / 2 + d * j / 100 for j in range(101)]
    offsets = [line.arc_blend(arc, s, length, d)[1] for s in steps]
    assert max(abs(b - a) for a, b in itertools.pairwise(offsets)) < k * d / 50
    assert line.arc_blend(arc, 0.3, 0.2, 0.0) == (1.0, 0.0)  # no limit: a step
    assert line.arc_blend(arc, math.nan, 0.2, d) == (0.0, 0.0)


CORNER_TURN = st.floats(0.01, math.radians(170))


@settings(max_examples=300)
@given(
    CORNER_TURN,
    st.sampled_from([1.0, -1.0]),
    st.floats(0.2, 40.0),
    st.floats(0.2, 40.0),
    st.floats(0.01, 1.0),
    st.floats(0.1, 1.5),
    st.one_of(st.none(), st.floats(0.2, 3.0)),
)
def test_corner_arc_keeps_its_budget_and_is_tangent_to_both_legs(
    turn: float,
    side: float,
    len_in: float,
    len_out: float,
    budget: float,
    a_lat: float,
    yaw: float | None,
) -> None:
    b = (len_in, 0.0)
    c = (b[0] + len_out * math.cos(side * turn), len_out * math.sin(side * turn))
    arc = line.corner_arc((0.0, 0.0), b, c, budget, 0.6, a_lat, yaw, 0.1)
    if arc is None:
        return
    assert arc.corner_error_m <= budget + 1e-9
    assert arc.tangent_m <= 0.5 * min(len_in, len_out) + 1e-9
    assert 0.1 <= arc.speed_mps <= 0.6 + 1e-12
    assert arc.speed_mps**2 / arc.radius_m <= a_lat + 1e-9
    if yaw is not None:
        assert arc.speed_mps / arc.radius_m <= yaw + 1e-9
    # tangent to the leg in (the x axis) at T before the vertex, and to the leg out
    cx, cy = arc.center_xy_m
    assert abs(cy) == pytest.approx(arc.radius_m, rel=1e-6)
    assert cx == pytest.approx(b[0] - arc.tangent_m, abs=1e-6)
    ux, uy = math.cos(side * turn), math.sin(side * turn)
    dist_out = abs((cx - b[0]) * uy - (cy - b[1]) * ux)
    assert dist_out == pytest.approx(arc.radius_m, rel=1e-6)
    assert math.copysign(1.0, arc.turn_rad) == side and math.copysign(1.0, cy) == side


def test_step_toward_2d_sheds_the_old_direction() -> None:
    v = line.step_toward_2d((0.1, 0.0), (0.0, 0.6), 0.0075)
    assert v[0] == pytest.approx(0.0925) and v[1] == pytest.approx(0.0075)
    assert line.step_toward_2d((0.3, 0.4), (0.0, 0.0), 0.1) == pytest.approx((0.24, 0.32))
    assert line.step_toward_2d((0.0, 0.0), (0.6, 0.0), 0.0) == (0.0, 0.0)


ANY = st.floats(allow_nan=True, allow_infinity=True)
BAD = st.sampled_from([math.nan, math.inf, -math.inf])


@settings(max_examples=200)
@given(st.lists(ANY, min_size=6, max_size=6), st.integers(0, 5), BAD)
def test_leg_errors_raise_on_non_finite(values: list[float], k: int, bad: float) -> None:
    values[k] = bad
    with pytest.raises(NonFiniteError):
        line.leg_errors(
            (values[0], values[1]), (values[2], values[3]), Pose2D(values[4], values[5], 0.0)
        )


@settings(max_examples=200)
@given(st.lists(ANY, min_size=5, max_size=5), st.integers(0, 4), BAD)
def test_speed_helpers_non_finite_is_zero(values: list[float], k: int, bad: float) -> None:
    values[k] = bad
    assert line.corner_speed_mps(*values) == 0.0
    three = (values[k], *values[:k], *values[k + 1 :])[:3]  # the bad one among them
    assert line.braking_speed_mps(*three) == 0.0
    assert line.step_toward(*three) == 0.0
    assert line.stoppable_yaw_rate_radps(*three) == 0.0
    assert line.step_toward_2d((values[0], values[1]), (values[2], values[3]), values[4]) == (
        0.0,
        0.0,
    )


FIN = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False)


@settings(max_examples=200)
@given(FIN, FIN, FIN, FIN, FIN, FIN, st.floats(0.01, 100.0))
def test_line_course_and_leg_errors_finite(
    ax: float, ay: float, bx: float, by: float, px: float, py: float, lookahead: float
) -> None:
    leg = line.leg_errors((ax, ay), (bx, by), Pose2D(px, py, 0.0))
    assert all(math.isfinite(v) for v in (leg.course_rad, leg.cross_track_m, leg.along_to_go_m))
    course = line.line_course_rad(leg.course_rad, leg.cross_track_m, lookahead)
    assert -math.pi < course <= math.pi
    # the course never points away from the line (it closes the cross-track error)
    if leg.length_m > 0.0 and abs(leg.cross_track_m) > 1e-6:
        closing = math.sin(course - leg.course_rad) * leg.cross_track_m
        assert closing <= 0.0


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("mode", list(MotionMode))
def test_noisy_pose_no_dithering_near_the_goals(mode: MotionMode, seed: int) -> None:
    # The navigator sees the true pose plus noise (σ = 2 cm, 0.01 rad, like the simulator's
    # 'low' noise): every stop still ends once (no orbit, no re-approach), in about the
    # noise-free time, within stop_tolerance_m + 3σ of the waypoint.
    import random

    rng = random.Random(seed)
    sigma_m, sigma_rad = 0.02, 0.01
    plan = shipped("square", mode)
    nav = Navigator(plan, LINE)
    plant = IdealPlant(start_pose(mode), mode)
    clean = fly(plan, start_pose(mode))
    out = None
    arrivals: list[float] = []
    while plant.t_s < 2 * clean.time_s:
        seen = Pose2D(
            plant.pose.x_m + rng.gauss(0.0, sigma_m),
            plant.pose.y_m + rng.gauss(0.0, sigma_m),
            plant.pose.yaw_rad + rng.gauss(0.0, sigma_rad),
        )
        out = nav.step(seen, plant.t_s)
        if out.reached_index is not None:
            wp = plan.waypoints[out.reached_index]
            arrivals.append(math.hypot(wp.x_m - plant.pose.x_m, wp.y_m - plant.pose.y_m))
        if out.done:
            break
        plant.step(out.command, DT_S)
    assert out is not None and out.done
    assert plant.t_s < 1.2 * clean.time_s
    assert len(arrivals) == len(plan.waypoints)
    # corners end on their arc's bisector, e from the vertex; the final stop within tolerance
    assert max(arrivals[:-1]) <= LINE.corner_error_m + 3 * sigma_m
    assert arrivals[-1] <= LINE.stop_tolerance_m + 3 * sigma_m


def test_one_leg_computation_per_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """The arrival test and the guidance of a step read the same leg: computed once."""
    calls: list[Pose2D] = []
    real = line.leg_errors

    def counted(start: tuple[float, float], end: tuple[float, float], pose: Pose2D) -> Any:
        calls.append(pose)
        return real(start, end, pose)

    monkeypatch.setattr(line, "leg_errors", counted)
    nav = Navigator(shipped("square", MotionMode.OMNI), LINE)
    for k in range(20):  # tracking the first leg: no waypoint switch
        calls.clear()
        out = nav.step(Pose2D(0.05 * k, 0.3, 0.0), k * DT_S)
        assert out.state is NavState.TRACK and out.reached_index is None
        assert len(calls) == 1
