"""replan_first_leg: the first leg re-planned from the rover's pose at preflight."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.planning.grid import segment_is_free
from helixd.planning.replan import replan_first_leg
from helixd.planning.route import PlanningError, RoutePlan, plan_mission

# a wall across north 8..10, east -3..3; the mission goes to (18, 0) then (18, 5)
CFG = HelixdConfig.model_validate(
    {"planning": {"keep_out_polygons_ne_m": [[[8, -3], [8, 3], [10, 3], [10, -3]]]}}
)
MSN = Mission.model_validate(
    {
        "name": "t",
        "mode": "roll",
        "frame": "local_ned",
        "waypoints": [{"north": 18, "east": 0, "tolerance_m": 0.8}, {"north": 18, "east": 5}],
    }
)


def _polyline_free(route: RoutePlan, pts: list[tuple[float, float]]) -> bool:
    return all(segment_is_free(route.grid, a, b) for a, b in itertools.pairwise(pts))


def test_rover_at_the_planned_start_keeps_the_plan() -> None:
    planned, route = plan_mission(MSN, CFG)
    again, route2 = replan_first_leg(planned, route, MSN, (0.2, -0.1), CFG)
    assert again is planned and route2 is route


def test_rover_elsewhere_gets_a_first_leg_from_its_pose_around_the_wall() -> None:
    planned, route = plan_mission(MSN, CFG)
    # from (5, 1) the straight line to waypoint 0 (18, 0) goes through the wall
    rover = (5.0, 1.0)
    assert not segment_is_free(route.grid, rover, (18.0, 0.0))
    again, route2 = replan_first_leg(planned, route, MSN, rover, CFG)
    leg = route2.legs[0]
    assert leg.points_ne_m[0] == rover and leg.points_ne_m[-1] == (18.0, 0.0)
    assert _polyline_free(route2, list(leg.points_ne_m))
    # the mission: new vias, then waypoint 0 and the rest unchanged
    n_vias = len(leg.points_ne_m) - 2
    assert n_vias >= 1
    assert again.waypoints[n_vias:] == MSN.waypoints
    assert [(w.north, w.east) for w in again.waypoints[:n_vias]] == list(leg.points_ne_m[1:-1])
    assert all(w.tolerance_m == pytest.approx(0.3) for w in again.waypoints[:n_vias])
    assert route2.legs[1:] == route.legs[1:]


def test_rover_with_a_clear_straight_line_gets_no_vias() -> None:
    planned, route = plan_mission(MSN, CFG)
    again, route2 = replan_first_leg(planned, route, MSN, (14.0, 0.0), CFG)
    assert route2.legs[0].straight
    assert again.waypoints == MSN.waypoints


def test_rover_inside_the_wall_or_off_the_grid_is_refused_naming_its_pose() -> None:
    planned, route = plan_mission(MSN, CFG)
    with pytest.raises(PlanningError, match=r"north 9\.00 m, east 0\.00 m\) lies inside an obs"):
        replan_first_leg(planned, route, MSN, (9.0, 0.0), CFG)
    with pytest.raises(PlanningError, match="inside the clearance"):
        replan_first_leg(planned, route, MSN, (7.6, 0.0), CFG)
    with pytest.raises(PlanningError, match="outside the planning grid"):
        replan_first_leg(planned, route, MSN, (500.0, 0.0), CFG)
    with pytest.raises(PlanningError, match="not finite"):
        replan_first_leg(planned, route, MSN, (math.nan, 0.0), CFG)


def test_rover_cut_off_from_waypoint_0_is_refused() -> None:
    # a closed box around the origin: the rover inside it at (1, 1) cannot get out
    box = [
        [[-4, -4], [-4, 4], [-3, 4], [-3, -4]],
        [[3, -4], [3, 4], [4, 4], [4, -4]],
        [[-4, -4], [4, -4], [4, -3], [-4, -3]],
        [[-4, 3], [4, 3], [4, 4], [-4, 4]],
    ]
    cfg = HelixdConfig.model_validate(
        {"planning": {"keep_out_polygons_ne_m": box, "start_ne_m": [10, 10]}}
    )
    msn = Mission.model_validate(
        {
            "name": "t",
            "mode": "roll",
            "frame": "local_ned",
            "waypoints": [{"north": 12, "east": 12}],
        }
    )
    planned, route = plan_mission(msn, cfg)
    with pytest.raises(PlanningError, match="unreachable"):
        replan_first_leg(planned, route, msn, (0.0, 0.0), cfg)


@settings(max_examples=40, deadline=None)
@given(
    n=st.floats(-40.0, 60.0, allow_nan=False),
    e=st.floats(-40.0, 40.0, allow_nan=False),
)
def test_any_pose_gives_a_free_first_leg_or_a_refusal(n: float, e: float) -> None:
    planned, route = plan_mission(MSN, CFG)
    try:
        again, route2 = replan_first_leg(planned, route, MSN, (n, e), CFG)
    except PlanningError as exc:
        assert exc.problems and "rover at preflight" in exc.problems[0]
        return
    assert _polyline_free(route2, list(route2.legs[0].points_ne_m))
    assert again.waypoints[-2:] == MSN.waypoints
