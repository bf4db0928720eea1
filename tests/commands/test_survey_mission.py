"""helixd.commands.survey_mission: what a survey becomes as a mission — the rover's body inside the
area by default, the holes carried as keep-out areas, the time limit on the real estimate."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from shapely.geometry import LineString, Point, Polygon

from helixd.base.frames import NedPose, latlon_to_ne
from helixd.base.plan import MotionMode
from helixd.commands.survey_mission import approach_estimate, default_insets, survey_mission
from helixd.config.root import HelixdConfig
from helixd.control.estimate import estimate_time
from helixd.mission.formats.areas import read_area
from helixd.mission.resolve import resolve_plan
from helixd.mission.validate import apply_mission_limits, mission_problems
from helixd.planning.obstacles import clearance_m, rover_half_width_m
from helixd.prepare.planned import plan_loaded
from tests.support.paths import DATA_DIR

CFG = HelixdConfig()
POND = read_area(DATA_DIR / "pond_with_island.geojson")


def survey(**kw: object) -> object:
    args: dict[str, object] = {
        "name": "pond",
        "mode": MotionMode.SCROLL,
        "spacing_m": 10.0,
        "angle_deg": 30.0,
        "margin_m": 2.0,
        "inset_m": None,
        "time_factor": 1.5,
        **kw,
    }
    return survey_mission(POND, CFG, **args)  # type: ignore[arg-type]


def test_the_default_inset_keeps_the_rovers_body_inside_the_area() -> None:
    got = survey()
    half = rover_half_width_m(CFG)
    assert got.inset_m == pytest.approx(0.429)  # 0.508 / 2 + 0.175 from the vehicle config
    edge = LineString(got.result.area_xy.exterior.coords)
    path = got.result.path_xy_m
    assert min(edge.distance(Point(p)) for p in path) >= half - 1e-6
    # with --inset-m 0 the path runs on the shoreline, as the field engineer found
    bare = survey(inset_m=0.0)
    bare_edge = LineString(bare.result.area_xy.exterior.coords)
    assert min(bare_edge.distance(Point(p)) for p in bare.result.path_xy_m) < 1e-6


def test_the_island_travels_with_the_mission_as_a_keep_out_area() -> None:
    got = survey()
    msn = got.mission
    assert len(msn.keep_out_polygons) == len(POND.holes) == 1
    island = Polygon(
        [latlon_to_ne(a, b, *POND.outer[0])[::-1] for a, b in msn.keep_out_polygons[0]]
    )
    keep = clearance_m(CFG) + 2 * math.sqrt(2) * CFG.planning.resolution_m
    assert got.keep_out_inset_m == pytest.approx(keep + 0.01)
    pts = [latlon_to_ne(a, b, *POND.outer[0])[::-1] for a, b in msn.points()]
    assert min(island.exterior.distance(Point(p)) for p in pts) >= keep
    # `check`/`run` plan every leg around it: no waypoint in its inflated border, and the
    # planned legs keep the clearance
    cfg = apply_mission_limits(CFG, msn)  # as `check` loads it: the survey's own limits
    _, route = plan_loaded(cfg, msn, Path("pond.yaml"), None)
    assert route is not None
    origin = msn.points()[0]
    island_wp1 = Polygon([latlon_to_ne(a, b, *origin)[::-1] for a, b in msn.keep_out_polygons[0]])
    for leg in route.legs:
        line = LineString([(e, n) for n, e in leg.points_ne_m])
        if line.length > 0:
            assert line.distance(island_wp1) >= clearance_m(CFG) - 0.01


def test_the_time_limit_is_built_on_the_navigators_estimate_and_the_approach() -> None:
    got = survey()
    plan = resolve_plan(got.mission, CFG.control, CFG.mission, got.mission.points()[0])
    estimate = estimate_time(plan, CFG.control)
    assert got.estimate.total_s == pytest.approx(estimate.total_s)
    assert (
        got.estimate.total_s
        > plan.path_length_m((plan.waypoints[0].x_m, plan.waypoints[0].y_m)) / 0.6
    )
    approach = approach_estimate(CFG, MotionMode.SCROLL, plan.speed_mps)
    assert approach.total_s > CFG.mission.max_start_distance_m / plan.speed_mps  # + a turn
    assert got.time_limit_s == math.ceil(1.5 * (estimate.total_s + approach.total_s))
    assert got.mission.time_limit_s == got.time_limit_s


def test_a_start_outside_the_survey_fence_is_refused_with_what_to_do() -> None:
    """The field engineer's rover stood 4 m outside the area, the fence 2 m: the refusal says
    to drive the rover inside the fence or grow --margin-m; inside it, no refusal."""
    got = survey()
    msn = got.mission
    lat0, lon0 = msn.points()[0]
    area = Polygon([latlon_to_ne(a, b, lat0, lon0) for a, b in msn.geofence_polygon])
    outside = area.exterior.interpolate(0.0)
    centroid = area.centroid
    # 4 m beyond the fence's first corner, away from the centroid
    dx, dy = outside.x - centroid.x, outside.y - centroid.y
    k = 4.0 / math.hypot(dx, dy)
    start_ne = (outside.x + dx * k, outside.y + dy * k)
    problems = mission_problems(
        msn, CFG, origin_latlon_deg=(lat0, lon0), start_ned=NedPose(*start_ne, 0.0)
    )
    text = [p for p in problems if p.startswith("the start point")]
    assert len(text) == 1
    assert "is outside the mission's geofence_polygon: drive the rover inside it" in text[0]
    assert "--margin-m" in text[0]
    inside = mission_problems(
        msn,
        CFG,
        origin_latlon_deg=(lat0, lon0),
        start_ned=NedPose(centroid.x, centroid.y, 0.0),
    )
    assert not [p for p in inside if p.startswith("the start point")]


def test_without_planning_the_holes_keep_the_same_inset() -> None:
    off = HelixdConfig.model_validate({"planning": {"enabled": False}})
    assert default_insets(off, None) == (rover_half_width_m(off), rover_half_width_m(off))
    assert default_insets(CFG, 2.0) == (2.0, 2.0)  # a wider inset than the clearance holds
