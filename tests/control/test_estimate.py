"""helixd.control.estimate: the time estimate against the navigator itself, flown in-process
on the ideal plant through the real scroll pipeline (tests/support/ideal_plant.py).

The flights in the built-in simulator are compared in
tests/integration/test_daemon_missions.py (square with the default corner arcs: 71.0 s
estimated / 71.8–72.1 s flown; 83.4 s / 83–85 s with stop and pivot)."""

from __future__ import annotations

import math
import random
import time
from dataclasses import replace

import pytest

from helixd.base.geometry import BodyVelocity, Pose2D
from helixd.base.plan import ActionKind, MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.control import ControlConfig
from helixd.config.root import HelixdConfig
from helixd.config.vehicle import VehicleConfig
from helixd.control.estimate import (
    along_fraction,
    delivered_fraction,
    delivered_fractions,
    estimate_time,
)
from helixd.control.navigator import Navigator
from helixd.control.sequencer import Sequencer, SequencerOutput
from helixd.mission.model import Mission, load_mission
from helixd.mission.resolve import resolve_plan
from helixd.planning.mapfile import load_map
from helixd.planning.route import plan_mission
from tests.support.ideal_plant import IdealPlant
from tests.support.paths import REPO_ROOT

CFG = HelixdConfig()
LINE = CFG.control
THESIS = CFG.control.model_copy(update={"guidance": "thesis"})
ARCS = LINE.model_copy(update={"corner_error_m": 0.25})  # corners flown as arcs
NO_ARCS = LINE.model_copy(update={"corner_error_m": 0.0})  # stop and pivot at corners
DT_S = 0.025  # the 40 Hz pose rate the autopilot grants
LINE_REL = 0.03  # the estimate is within this of the navigator's own time (line guidance)
THESIS_REL = 0.05


def fly_s(plan: Plan, start: Pose2D, control: ControlConfig) -> float:
    """Autopilot seconds the navigator needs on the ideal plant (the scroll pipeline)."""
    nav = Navigator(plan, control)
    plant = IdealPlant(start, plan.mode, VehicleConfig())
    for _ in range(400_000):
        out = nav.step(plant.pose, plant.t_s)
        if out.done:
            return plant.t_s
        plant.step(out.command, DT_S)
    raise AssertionError("the navigator never finished")


def fly_program_s(plan: Plan, start: Pose2D, control: ControlConfig) -> float:
    """Autopilot seconds a mission with commands takes on the ideal plant: the navigator and
    the sequencer stepped as the flight loop steps them (DO_CHANGE_SPEED sets the cruise,
    holds keep the rover standing)."""
    assert plan.program is not None
    nav = Navigator(plan, control)
    seq = Sequencer(plan.program)
    plant = IdealPlant(start, plan.mode, VehicleConfig())

    def apply(out: SequencerOutput) -> bool:
        for action in out.actions:
            if action.kind is ActionKind.SPEED:
                nav.set_speed(action.value)
        return out.holding

    holding = apply(seq.start(plant.t_s))
    for _ in range(400_000):
        if seq.done:
            return plant.t_s
        if holding:
            holding = apply(seq.update(plant.t_s, None, 0.0))
            plant.step(BodyVelocity.zero(), DT_S)
            continue
        out = nav.step(plant.pose, plant.t_s)
        holding = apply(seq.update(plant.t_s, out.reached_index, out.distance_error_m))
        plant.step(BodyVelocity.zero() if holding else out.command, DT_S)
    raise AssertionError("the program never finished")


def shipped(name: str, mode: MotionMode) -> Plan:
    msn = load_mission(REPO_ROOT / "config" / "missions" / f"{name}.yaml")
    return replace(resolve_plan(msn, CFG.control, CFG.mission), mode=mode)


@pytest.mark.parametrize(
    ("guidance", "rel"),
    [(ARCS, LINE_REL), (NO_ARCS, LINE_REL), (THESIS, THESIS_REL)],
    ids=["arcs", "pivots", "thesis"],
)
@pytest.mark.parametrize("mode", list(MotionMode))
@pytest.mark.parametrize("name", ["square", "hexagon", "circle"])
def test_shipped_missions_take_the_estimated_time(
    name: str, mode: MotionMode, guidance: ControlConfig, rel: float
) -> None:
    plan = shipped(name, mode)
    start = Pose2D(0.0, 0.0, 0.0)
    estimate = estimate_time(plan, guidance, (0.0, 0.0), 0.0)
    flown = fly_s(plan, start, guidance)
    assert estimate.total_s == pytest.approx(flown, rel=rel)


def test_the_square_counts_acceleration_braking_and_pivots() -> None:
    """The field engineer's square: 71 s at cruise plus turns at the full yaw rate; the
    navigator takes 83 s (the simulator flies it in 83.1 s)."""
    plan = shipped("square", MotionMode.ROLL)
    est = estimate_time(plan, NO_ARCS, (0.0, 0.0), 0.0)
    assert est.path_length_m == pytest.approx(40.0)
    assert est.pivots == 3  # the three corners; the last waypoint is a stop, not a turn
    assert est.driving_s > 40.0 / plan.speed_mps + 10.0  # four accelerations and brakings
    assert est.turning_s > 3 * (math.pi / 2) / LINE.max_yaw_rate_radps  # yaw acceleration
    assert est.total_s == pytest.approx(fly_s(plan, Pose2D(0.0, 0.0, 0.0), NO_ARCS), rel=0.01)
    assert len(est.arrivals_s) == 4 and est.arrivals_s[-1] == pytest.approx(est.total_s)
    assert list(est.arrivals_s) == sorted(est.arrivals_s)


def test_the_square_with_corner_arcs_follows_the_arcs() -> None:
    """With a corner budget the three corners are arcs (R 0.60 m at 0.43 m/s), not stops and
    pivots: the navigator flies the square in 71.1 s, not 83.5 s, and so does the estimate
    (it planned 83.4 s, stop and pivot, before it followed the arcs)."""
    plan = shipped("square", MotionMode.ROLL)
    est = estimate_time(plan, ARCS, (0.0, 0.0), 0.0)
    flown = fly_s(plan, Pose2D(0.0, 0.0, 0.0), ARCS)
    assert est.pivots == 0 and est.turning_s == 0.0
    assert est.path_length_m == pytest.approx(40.0)  # the polyline, as the operator wrote it
    assert est.total_s == pytest.approx(flown, rel=0.01)
    assert est.total_s < estimate_time(plan, NO_ARCS, (0.0, 0.0), 0.0).total_s - 10.0
    # each corner is reached at its arc's middle, a quarter of the way round
    assert len(est.arrivals_s) == 4 and list(est.arrivals_s) == sorted(est.arrivals_s)


def test_the_pond_crossing_route_is_estimated_with_its_detours() -> None:
    """The planned pond crossing (9 via points around the pontoon and the pipe), from the
    simulator's start (north-facing at the origin): 229.5 s estimated, 230.2 s flown."""
    msn = load_mission(REPO_ROOT / "config" / "missions" / "pond-crossing.yaml")
    occupancy = load_map(REPO_ROOT / "config" / "maps" / "pond.yaml", CFG.planning.max_cells)
    planned, _ = plan_mission(msn, CFG, occupancy)
    plan = resolve_plan(planned, CFG.control, CFG.mission)
    assert len(plan.waypoints) > len(msn.waypoints)  # the detours are in it
    north = math.pi / 2  # ENU: counter-clockwise from East
    est = estimate_time(plan, LINE, (0.0, 0.0), north)
    assert est.path_length_m > 110.0  # straight it would be 55 m
    assert est.total_s == pytest.approx(fly_s(plan, Pose2D(0.0, 0.0, north), LINE), rel=0.02)


# DO_CHANGE_SPEED on the way, a hold, a loop flown twice (tests/integration/
# test_mission_commands_flights.py flies the same legs in the simulator)
SPEEDS = {
    "name": "speeds",
    "mode": "roll",
    "frame": "start",
    "waypoints": [
        {"x": 10, "y": 0},
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3},
        {"x": 10, "y": 8, "hold_s": 6},
        {"x": 2, "y": 8},
        {"command": "DO_CHANGE_SPEED", "speed_mps": 0.5},
        {"x": 2, "y": 2},
        {"x": 8, "y": 2},
        {"command": "DO_JUMP", "item": 6, "repeat": 1},
    ],
}


@pytest.mark.parametrize("guidance", [ARCS, NO_ARCS, THESIS], ids=["arcs", "pivots", "thesis"])
def test_each_leg_is_estimated_at_the_speed_its_do_change_speed_sets(
    guidance: ControlConfig,
) -> None:
    """0.6 m/s to the first waypoint, 0.3 m/s to the hold and on, 0.5 m/s round the loop:
    141.5 s flown in the simulator, 140.2 s estimated (110.6 s when every leg was estimated
    at the mission's 0.6 m/s)."""
    plan = resolve_plan(Mission.model_validate(SPEEDS), guidance, CFG.mission)
    assert plan.leg_speeds_mps() == [0.6, 0.3, 0.3, 0.5, 0.5, 0.5, 0.5]
    assert plan.waypoints[1].stop  # the hold: a stop, not an arc
    est = estimate_time(plan, guidance, (0.0, 0.0), 0.0)
    flown = fly_program_s(plan, Pose2D(0.0, 0.0, 0.0), guidance)
    rel = THESIS_REL if guidance.guidance == "thesis" else LINE_REL
    assert est.total_s == pytest.approx(flown, rel=rel)
    all_fast = replace(plan, program=None)  # the same legs, all at the mission's speed
    assert est.total_s > estimate_time(all_fast, guidance, (0.0, 0.0), 0.0).total_s + 20.0


def random_plans(seed: int, count: int) -> list[tuple[Plan, Pose2D]]:
    rng = random.Random(seed)
    out = []
    for _ in range(count):
        n = rng.randint(1, 7)
        wps = tuple(
            PlanWaypoint(
                rng.uniform(-15.0, 15.0),
                rng.uniform(-15.0, 15.0),
                rng.choice([0.3, 0.5, 1.0, 2.0]),
                rng.choice([None, None, None, rng.uniform(-3.0, 3.0)]),
            )
            for _ in range(n)
        )
        mode = rng.choice(list(MotionMode))
        speed = rng.choice([0.3, 0.6, 1.0])
        plan = Plan("r", mode, MissionFrameKind.START, wps, speed)
        out.append((plan, Pose2D(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-3, 3))))
    return out


@pytest.mark.parametrize(
    ("guidance", "rel"),
    [(ARCS, LINE_REL), (NO_ARCS, LINE_REL), (THESIS, THESIS_REL)],
    ids=["arcs", "pivots", "thesis"],
)
def test_random_missions_take_the_estimated_time(guidance: ControlConfig, rel: float) -> None:
    """Random corners, final headings, tolerances, speeds and start poses."""
    for plan, start in random_plans(24, 25):
        est = estimate_time(plan, guidance, (start.x_m, start.y_m), start.yaw_rad).total_s
        flown = fly_s(plan, start, guidance)
        if flown < 2.0:  # a waypoint inside its tolerance at the start: nothing to time
            assert est < 2.0
            continue
        assert est == pytest.approx(flown, rel=rel), (plan, start)


def test_without_a_start_the_estimate_begins_at_waypoint_1_facing_waypoint_2() -> None:
    wps = (PlanWaypoint(0.0, 0.0, 1.0), PlanWaypoint(0.0, 20.0, 1.0))
    plan = Plan("n", MotionMode.ROLL, MissionFrameKind.LOCAL_NED, wps, 0.6)
    est = estimate_time(plan, LINE)
    assert est.pivots == 0 and est.path_length_m == pytest.approx(20.0)
    assert est.arrivals_s[0] == 0.0
    facing_away = estimate_time(plan, LINE, (0.0, 0.0), -math.pi / 2)
    assert facing_away.pivots == 1 and facing_away.total_s > est.total_s + 2.0


@pytest.mark.parametrize(
    ("control", "braking_s"), [(NO_ARCS, 10.0), (ARCS, 3.0)], ids=["pivots", "arcs"]
)
def test_a_slower_cruise_or_braking_takes_longer(control: ControlConfig, braking_s: float) -> None:
    # gentler braking: four stops (12.1 s more), or the arcs' 0.6 → 0.43 m/s and the last stop
    # (4.0 s more); half the cruise: 60.7 / 62.5 s more
    plan = shipped("square", MotionMode.ROLL)
    base = estimate_time(plan, control, (0.0, 0.0), 0.0).total_s
    gentle = control.model_copy(update={"braking_accel_mps2": 0.05})
    assert estimate_time(plan, gentle, (0.0, 0.0), 0.0).total_s > base + braking_s
    slow = replace(plan, speed_mps=0.3)
    assert estimate_time(slow, control, (0.0, 0.0), 0.0).total_s > base + 50.0


def dense_circle(n: int) -> Plan:
    step_m, radius_m = 0.3, 40.0
    wps = tuple(
        PlanWaypoint(
            radius_m * math.cos(i * step_m / radius_m) - radius_m,
            radius_m * math.sin(i * step_m / radius_m),
            1.0,
        )
        for i in range(n)
    )
    return Plan("big", MotionMode.OMNI, MissionFrameKind.START, wps, 0.6)


def test_a_long_dense_mission_is_estimated_in_linear_time() -> None:
    """100 000 waypoints cost at most 20x what 10 000 cost (no quadratic step; ~1.5 s of CPU
    on this VM, whose speed varies by half from run to run: the seconds are printed, not
    judged), and the estimate is the path at cruise."""
    seconds = []
    for n in (10_000, 100_000):
        plan = dense_circle(n)
        cpu0 = time.process_time()
        est = estimate_time(plan, LINE, (0.0, 0.0), 0.0)
        seconds.append(time.process_time() - cpu0)
        assert est.total_s == pytest.approx(est.path_length_m / 0.6, rel=0.01)
    print(f"estimate: 10k waypoints {seconds[0]:.2f} s, 100k {seconds[1]:.2f} s of CPU")
    assert seconds[1] <= 20.0 * max(seconds[0], 0.01)


def test_an_empty_or_unreachable_profile_is_not_a_hang() -> None:
    plan = Plan("e", MotionMode.ROLL, MissionFrameKind.START, (), 0.6)
    assert estimate_time(plan, LINE).total_s == 0.0
    stuck = LINE.model_copy(update={"min_speed_mps": 0.0})
    one = Plan("s", MotionMode.OMNI, MissionFrameKind.START, (PlanWaypoint(5.0, 0.0, 1.0),), 0.6)
    assert math.isfinite(estimate_time(one, stuck, (0.0, 0.0), 0.0).total_s)


def slipping(**fractions: float) -> ControlConfig:
    slip = LINE.slip.model_copy(update={f"ground_{k}_fraction": v for k, v in fractions.items()})
    return LINE.model_copy(update={"slip": slip})


@pytest.mark.parametrize("guidance", [LINE, THESIS], ids=["line", "thesis"])
def test_a_declared_ground_slows_the_estimate_by_what_the_feed_forward_cannot_make_up(
    guidance: ControlConfig,
) -> None:
    """An axis that gets a fraction f of its command is delivered min(1, f · max_gain) of it:
    the square in ROLL on a roll axis of 40 % drives at 80 % (so 1/0.8 as long), turns in place
    on a yaw of 30 % at 60 %; at 60 % or more the feed-forward makes it all up; without the
    feed-forward an axis gets f."""
    plan = shipped("square", MotionMode.ROLL)
    base = estimate_time(plan, guidance, (0.0, 0.0), 0.0)
    ground = slipping(roll=0.4, scroll=0.2, yaw=0.3).model_copy(
        update={"guidance": guidance.guidance}
    )
    slow = estimate_time(plan, ground, (0.0, 0.0), 0.0)
    assert slow.driving_s == pytest.approx(base.driving_s / 0.8)
    assert slow.turning_s == pytest.approx(base.turning_s / 0.6)
    assert slow.total_s == pytest.approx(slow.driving_s + slow.turning_s)
    assert slow.arrivals_s[-1] == pytest.approx(slow.total_s)
    assert slow.pivots == base.pivots and slow.path_length_m == base.path_length_m
    made_up = slipping(roll=0.6, yaw=0.5).model_copy(update={"guidance": guidance.guidance})
    assert estimate_time(plan, made_up, (0.0, 0.0), 0.0).total_s == pytest.approx(base.total_s)
    off = ground.model_copy(update={"slip": ground.slip.model_copy(update={"enabled": False})})
    bare = estimate_time(plan, off, (0.0, 0.0), 0.0)
    assert bare.driving_s == pytest.approx(base.driving_s / 0.4)


def test_omni_drives_each_leg_at_what_its_direction_gets() -> None:
    """OMNI keeps its heading, so each leg runs at its own angle to the body: along the roll
    axis it gets the roll fraction, along the scroll axis the scroll fraction, between them
    the lower of the two (the feed-forward keeps the command's direction: slip.same_direction);
    without the feed-forward the guidance steers the command against the skew."""
    share = LINE.slip.skew_share
    assert along_fraction(0.0, 0.6, 1.0, share) == pytest.approx(0.6)
    assert along_fraction(math.pi / 2, 0.6, 1.0, share) == pytest.approx(1.0)
    assert along_fraction(-math.pi, 0.6, 1.0, share) == pytest.approx(0.6)
    assert along_fraction(math.pi / 4, 0.6, 1.0, share) == pytest.approx(0.6)
    assert along_fraction(math.radians(60.0), 0.6, 1.0, share) == pytest.approx(0.6)
    nearly_y = along_fraction(math.radians(88.0), 0.6, 1.0, share)  # ramped: share 0.03
    assert 0.6 < nearly_y < 1.0
    plan = shipped("hexagon", MotionMode.OMNI)
    base = estimate_time(plan, LINE, (0.0, 0.0), 0.0)
    mud = estimate_time(plan, slipping(roll=0.3, scroll=0.85, yaw=0.55), (0.0, 0.0), 0.0)
    assert mud.driving_s == pytest.approx(base.driving_s / 0.6)  # every side at 60 %
    assert delivered_fractions(MotionMode.OMNI, LINE.slip) == (1.0, 1.0)
    assert delivered_fractions(MotionMode.SCROLL, slipping(scroll=0.45).slip) == pytest.approx(
        (0.9, 1.0)
    )


def test_the_delivered_fraction_is_total() -> None:
    """Numbers a config cannot hold still give a finite, positive fraction, never 1/0."""
    slip = LINE.slip
    for f in (math.nan, math.inf, -1.0, 0.0):
        got = delivered_fraction(f, slip)
        assert math.isfinite(got) and 0.0 < got <= 1.0
    assert delivered_fraction(0.1, slip) == pytest.approx(0.1)  # a stall: not amplified
    assert delivered_fraction(0.45, slip) == pytest.approx(0.9)
    assert delivered_fraction(1.0, slip) == 1.0


def test_a_plan_whose_mode_follows_the_medium_counts_its_turns() -> None:
    # bank, 40 m of water, bank: roll, stop and turn, scroll, stop and turn, roll
    wps = (
        PlanWaypoint(0.0, 9.0, 1.0, via=True, stop=True, mode=MotionMode.ROLL),
        PlanWaypoint(0.0, 51.0, 1.0, via=True, stop=True, mode=MotionMode.SCROLL),
        PlanWaypoint(0.0, 60.0, 1.0, mode=MotionMode.ROLL),
    )
    plan = Plan("crossing", MotionMode.ROLL, MissionFrameKind.LOCAL_NED, wps, 0.6)
    start = Pose2D(0.0, 0.0, math.pi / 2)  # rolling north
    got = estimate_time(plan, LINE, (0.0, 0.0), start.yaw_rad)
    assert got.pivots == 2  # the two changes of mode, each a 90° turn in place
    plain = tuple(replace(w, mode=None, stop=False) for w in wps)
    one_mode = estimate_time(replace(plan, waypoints=plain), LINE, (0.0, 0.0), start.yaw_rad)
    assert one_mode.pivots == 0 and got.total_s > one_mode.total_s
    nav = Navigator(plan, LINE)
    plant = IdealPlant(start, nav.mode, VehicleConfig())
    for _ in range(100_000):
        plant.mode = nav.mode  # the plant drives in the mode the navigator flies
        out = nav.step(plant.pose, plant.t_s)
        if out.done:
            break
        plant.step(out.command, DT_S)
    assert nav.done
    assert plant.t_s == pytest.approx(got.total_s, rel=LINE_REL)
