"""A plan's ``leg_start_xy_m`` on the ideal plant: a resumed survey re-enters its line.

The survey leg runs (0, 0) → (20, 0). The rover, interrupted and moved, restarts at (5, 3):
with the leg start the line guidance converges onto y = 0 and reaches (20, 0) along it; without
(today's behaviour, a fresh mission) the first leg starts at the rover and it cuts across,
staying ~3 m off the surveyed line for most of the way.
"""

from __future__ import annotations

import math

import pytest

from helixd.base.geometry import NonFiniteError, Pose2D
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.root import HelixdConfig
from helixd.control.navigator import Navigator
from tests.support.ideal_plant import IdealPlant

DT_S = 1.0 / 40.0
LINE = HelixdConfig().control.model_copy(update={"guidance": "line"})


def _plan(leg_start: tuple[float, float] | None, mode: MotionMode) -> Plan:
    return Plan(
        name="transect",
        mode=mode,
        frame=MissionFrameKind.LOCAL_NED,
        waypoints=(PlanWaypoint(20.0, 0.0, 0.5),),
        speed_mps=0.6,
        leg_start_xy_m=leg_start,
    )


def _fly(plan: Plan, start: Pose2D) -> tuple[bool, list[Pose2D]]:
    nav = Navigator(plan, LINE)
    plant = IdealPlant(pose=start, mode=plan.mode)
    poses = [start]
    for _ in range(int(200.0 / DT_S)):
        out = nav.step(plant.pose, plant.t_s)
        if out.done:
            return True, poses
        poses.append(plant.step(out.command, DT_S))
    return False, poses


@pytest.mark.parametrize("mode", [MotionMode.ROLL, MotionMode.SCROLL, MotionMode.OMNI])
def test_leg_start_converges_onto_the_interrupted_line(mode: MotionMode) -> None:
    yaw = 0.0 if mode is not MotionMode.SCROLL else -math.pi / 2
    start = Pose2D(5.0, 3.0, yaw)
    done, poses = _fly(_plan((0.0, 0.0), mode), start)
    assert done
    assert math.hypot(poses[-1].x_m - 20.0, poses[-1].y_m) < 0.5
    # back on the surveyed line (y = 0) well before the waypoint: from x = 13 m on, |y| < 0.2 m
    late = [abs(p.y_m) for p in poses if p.x_m > 13.0]
    assert late and max(late) < 0.2


@pytest.mark.parametrize("mode", [MotionMode.ROLL, MotionMode.OMNI])
def test_without_leg_start_the_rover_cuts_across(mode: MotionMode) -> None:
    done, poses = _fly(_plan(None, mode), Pose2D(5.0, 3.0, 0.0))
    assert done
    # the straight line (5, 3) → (20, 0) is still 1.2 m off y = 0 at x = 14
    mid = [abs(p.y_m) for p in poses if 13.5 < p.x_m < 14.5]
    assert mid and min(mid) > 1.0


def test_non_finite_leg_start_is_refused() -> None:
    with pytest.raises(NonFiniteError):
        Navigator(_plan((math.nan, 0.0), MotionMode.ROLL), LINE)
