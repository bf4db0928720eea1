"""The navigator's three additions for missions with commands, on the ideal plant: a flagged
stop is stopped at, ``set_speed`` changes the cruise speed, ``set_reverse`` drives the axis
backwards — and without a program nothing changes."""

from __future__ import annotations

import itertools
import math
from typing import Any

import pytest

from helixd.base.geometry import Pose2D
from helixd.base.plan import MissionFrameKind, MotionMode, NavStep, Plan, PlanWaypoint, Program
from helixd.config.root import HelixdConfig
from helixd.control.navigator import Navigator
from tests.support.ideal_plant import IdealPlant

CFG = HelixdConfig().control
DT = 0.02


def plan(wps: list[PlanWaypoint], mode: MotionMode = MotionMode.ROLL, peak: float = 0.6) -> Plan:
    steps = (NavStep(1, 16, 0, len(wps) - 1, 0.0, (), peak, "all"),)
    return Plan("p", mode, MissionFrameKind.START, tuple(wps), 0.6, program=Program(steps))


def run(nav: Navigator, plant: IdealPlant, seconds: float) -> list[tuple[float, float, float]]:
    """(t, speed along body x, body x velocity) per step."""
    out = []
    for _ in range(int(seconds / DT)):
        o = nav.step(plant.pose, plant.t_s)
        plant.step(o.command, DT)
        out.append((plant.t_s, math.hypot(o.command.vx_mps, o.command.vy_mps), o.command.vx_mps))
        if o.done:
            break
    return out


def until_first_reached(nav: Navigator) -> tuple[IdealPlant, Any]:
    """ROLL from the origin on an ideal plant until the first waypoint is reached (at most
    5000 steps): the plant and the step's output."""
    plant = IdealPlant(Pose2D(0.0, 0.0, 0.0), MotionMode.ROLL)
    for _ in range(5000):
        o = nav.step(plant.pose, plant.t_s)
        if o.reached_index == 0:
            break
        plant.step(o.command, DT)
    return plant, o


def test_a_flagged_stop_is_stopped_at_like_the_final_waypoint() -> None:
    wps = [PlanWaypoint(10.0, 0.0, 1.0, stop=True), PlanWaypoint(20.0, 0.0, 1.0)]
    nav = Navigator(plan(wps), CFG)
    plant, o = until_first_reached(nav)
    assert abs(plant.pose.x_m - 10.0) < CFG.stop_tolerance_m + 0.02
    assert o.distance_error_m < CFG.stop_tolerance_m + 0.02
    # the flown-through twin is reached a tolerance early, at speed
    through = Navigator(plan([PlanWaypoint(10.0, 0.0, 1.0), wps[1]]), CFG)
    plant, _ = until_first_reached(through)
    assert plant.pose.x_m < 9.2


def test_set_speed_changes_the_cruise_from_the_next_step() -> None:
    nav = Navigator(plan([PlanWaypoint(60.0, 0.0, 1.0)]), CFG)
    plant = IdealPlant(Pose2D(0.0, 0.0, 0.0), MotionMode.ROLL)
    fast = run(nav, plant, 20.0)
    assert max(v for _, v, _ in fast) == pytest.approx(0.6, abs=1e-6)
    nav.set_speed(0.25)
    slow = run(nav, plant, 10.0)
    assert slow[-1][1] == pytest.approx(0.25, abs=1e-6)  # braked with the accel limit
    assert all(b[1] <= a[1] + 1e-9 for a, b in itertools.pairwise(slow))
    with pytest.raises(ValueError):
        nav.set_speed(0.7)  # above the program's peak


def test_reverse_drives_backwards_along_the_roll_axis() -> None:
    nav = Navigator(plan([PlanWaypoint(-10.0, 0.0, 1.0)]), CFG)
    nav.set_reverse(True)
    plant = IdealPlant(Pose2D(0.0, 0.0, 0.0), MotionMode.ROLL)  # facing +x, goal behind
    rows = run(nav, plant, 60.0)
    assert plant.pose.x_m == pytest.approx(-10.0, abs=0.15)
    assert abs(plant.pose.yaw_rad) < 0.2  # it never turned round
    assert min(vx for _, _, vx in rows) < -0.5


def test_omni_has_no_axis_to_reverse() -> None:
    nav = Navigator(plan([PlanWaypoint(5.0, 0.0, 1.0)], MotionMode.OMNI), CFG)
    nav.set_reverse(True)
    assert not nav.reverse


def test_without_a_program_the_speed_is_the_plans() -> None:
    p = Plan("p", MotionMode.ROLL, MissionFrameKind.START, (PlanWaypoint(5.0, 0.0, 1.0),), 0.4)
    nav = Navigator(p, CFG)
    assert nav.cruise_speed_mps == 0.4 and p.peak_speed_mps == 0.4 and not nav.reverse
