"""The route against the autopilot's own fence (pure), and what preflight makes of it: a
problem refuses, an unreadable or disabled fence only warns."""

from __future__ import annotations

import asyncio
from typing import Any, cast

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.connection import Autopilot
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats.items import FenceNe, ObstacleCircle
from helixd.runtime.autopilot_fence import autopilot_fence_check, route_fence_problems

SQUARE = ((-20.0, -20.0), (-20.0, 20.0), (20.0, 20.0), (20.0, -20.0))
NONE = FenceNe((), (), (), ())
LABELS = ["the start", "waypoint 1", "waypoint 2"]


def fence(**kw: Any) -> FenceNe:
    return FenceNe(
        inclusion_polygons=kw.get("inclusion_polygons", ()),
        exclusion_polygons=kw.get("exclusion_polygons", ()),
        inclusion_circles=kw.get("inclusion_circles", ()),
        exclusion_circles=kw.get("exclusion_circles", ()),
    )


def test_a_route_inside_everything_has_no_problem() -> None:
    f = fence(
        inclusion_polygons=(SQUARE,),
        inclusion_circles=(ObstacleCircle((0.0, 0.0), 30.0),),
        exclusion_circles=(ObstacleCircle((-15.0, -15.0), 2.0),),
    )
    assert route_fence_problems(f, [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], LABELS) == []
    assert route_fence_problems(NONE, [(0.0, 0.0), (1e4, 0.0), (0.0, 1e4)], LABELS) == []


def test_points_outside_an_inclusion_or_inside_an_exclusion() -> None:
    f = fence(
        inclusion_polygons=(SQUARE,),
        exclusion_circles=(ObstacleCircle((10.0, 10.0), 2.0),),
    )
    problems = route_fence_problems(f, [(0.0, 0.0), (30.0, 0.0), (10.0, 10.5)], LABELS)
    assert problems == [
        "waypoint 1 (N 30.0 m, E 0.0 m) is outside the autopilot's inclusion polygon 1",
        "waypoint 2 (N 10.0 m, E 10.5 m) is inside the autopilot's exclusion circle 1",
    ]


def test_legs_through_an_exclusion_zone_or_out_of_an_inclusion() -> None:
    """Every point is fine, the straight legs between them are not."""
    notch = (
        (-20.0, -20.0),
        (-20.0, 20.0),
        (20.0, 20.0),
        (20.0, 5.0),
        (0.0, 0.0),
        (20.0, -5.0),
        (20.0, -20.0),
    )
    f = fence(
        inclusion_polygons=(notch,),
        exclusion_circles=(ObstacleCircle((-10.0, 0.0), 1.0),),
        exclusion_polygons=(((-12.0, 8.0), (-12.0, 12.0), (-8.0, 12.0), (-8.0, 8.0)),),
    )
    two = LABELS[:2]
    assert route_fence_problems(f, [(-15.0, 0.0), (-5.0, 0.0)], two) == [
        "the leg the start → waypoint 1 crosses the autopilot's exclusion circle 1"
    ]
    assert route_fence_problems(f, [(15.0, -10.0), (15.0, 10.0)], two) == [
        "the leg the start → waypoint 1 leaves the autopilot's inclusion polygon 1"
    ]
    across = [(-15.0, 10.0), (-5.0, 10.0), (-5.0, 0.0)]
    assert route_fence_problems(f, across, LABELS) == [
        "the leg the start → waypoint 1 crosses the autopilot's exclusion polygon 1"
    ]


def circle_item(seq: int, radius_m: float) -> MissionItem:
    return MissionItem(
        seq=seq,
        frame=mavlink.MAV_FRAME_GLOBAL,
        command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
        param1=radius_m,
        x=53.52325,
        y=-113.52632,
        mission_type=mavlink.MAV_MISSION_TYPE_FENCE,
    )


class FakeAp:
    def __init__(self, items: tuple[MissionItem, ...] | Exception, enable: float | None) -> None:
        self.mission = self
        self.param = self
        self._items = items
        self._enable = enable

    async def download_fence(self) -> tuple[MissionItem, ...]:
        if isinstance(self._items, Exception):
            raise self._items
        return self._items

    async def get(self, name: str) -> float | None:
        assert name == "FENCE_ENABLE"
        return self._enable


ORIGIN = (53.52325, -113.52632)
POINTS = [(0.0, 0.0), (10.0, 0.0), (10.0, -10.0)]


def judge(ap: FakeAp) -> tuple[list[str], list[str]]:
    return asyncio.run(autopilot_fence_check(cast(Autopilot, ap), ORIGIN, POINTS, LABELS))


def test_an_enabled_fence_refuses_a_disabled_one_warns() -> None:
    problems, warnings = judge(FakeAp((circle_item(0, 5.0),), 1.0))
    assert problems and warnings == []
    outside = "waypoint 1 (N 10.0 m, E 0.0 m) is outside the autopilot's inclusion circle 1"
    assert outside in problems
    problems, warnings = judge(FakeAp((circle_item(0, 5.0),), 0.0))
    assert problems == [] and len(warnings) == 2
    assert warnings[0].startswith("the autopilot's fence is off (FENCE_ENABLE 0)")
    assert judge(FakeAp((circle_item(0, 50.0),), 1.0)) == ([], [])


def test_no_fence_or_an_unreadable_one_does_not_refuse() -> None:
    assert judge(FakeAp((), 1.0)) == ([], [])
    problems, warnings = judge(FakeAp(MissionTransferError("no answer"), 1.0))
    assert problems == [] and "could not be read (no answer)" in warnings[0]
    no_origin = asyncio.run(
        autopilot_fence_check(
            cast(Autopilot, FakeAp((circle_item(0, 5.0),), 1.0)), None, POINTS, LABELS
        )
    )
    assert no_origin == ([], ["no EKF origin: the autopilot's fence is not judged"])
