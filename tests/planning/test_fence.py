"""A .plan's own geofence in planning: exclusion zones become obstacles, the inclusion polygon
the boundary; a global mission is planned around waypoint 0 and its vias written as lat/lon."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, Point, Polygon

from helixd.base.frames import latlon_to_ne, ne_to_latlon
from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.config.root import HelixdConfig
from helixd.files.models import ConfigFileError
from helixd.mission.formats import load_mission_file
from helixd.planning.fence import plan_global_mission
from helixd.planning.obstacles import KeepOutCircle, clearance_m
from helixd.planning.route import PlanningError
from tests.support.cli import main_exit
from tests.support.paths import DATA_DIR

DATA = DATA_DIR
LAT0, LON0 = 53.5233, -113.5263  # waypoint 0
# wall across the leg wp0 (0, 0) → wp1 (20, 0): north 9..11, east -4..4
WALL_NE = [(9.0, -4.0), (9.0, 4.0), (11.0, 4.0), (11.0, -4.0)]
KEEP_IN_NE = [(-10.0, -15.0), (-10.0, 15.0), (30.0, 15.0), (30.0, -15.0)]


def _ll(n: float, e: float) -> list[float]:
    return list(ne_to_latlon(n, e, LAT0, LON0))


def _item(seq: int, n: float, e: float) -> dict[str, Any]:
    lat, lon = _ll(n, e)
    return {
        "AMSLAltAboveTerrain": None, "Altitude": 0, "AltitudeMode": 1, "autoContinue": True,
        "command": 16, "doJumpId": seq, "frame": 3, "params": [0, 0, 0, None, lat, lon, 0],
        "type": "SimpleItem",
    }  # fmt: skip


def write_plan(
    tmp_path: Path,
    waypoints_ne: list[tuple[float, float]],
    circles: tuple[tuple[float, float, float], ...] = (),
) -> Path:
    doc = json.loads((DATA / "sim_square.plan").read_text())
    doc["mission"]["items"] = [_item(i + 1, n, e) for i, (n, e) in enumerate(waypoints_ne)]
    polys = [{"inclusion": True, "polygon": [_ll(*v) for v in KEEP_IN_NE], "version": 1}]
    polys.append({"inclusion": False, "polygon": [_ll(*v) for v in WALL_NE], "version": 1})
    doc["geoFence"]["polygons"] = polys
    doc["geoFence"]["circles"] = [
        {"inclusion": False, "circle": {"center": _ll(n, e), "radius": r}, "version": 1}
        for n, e, r in circles
    ]
    path = tmp_path / "wall.plan"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


def test_plan_reader_routes_instead_of_refusing_a_leg_through_an_exclusion(
    tmp_path: Path,
) -> None:
    path = write_plan(tmp_path, [(0.0, 0.0), (20.0, 0.0)])
    with pytest.raises(Exception, match="crosses the geofence's exclusion polygon 0"):
        load_mission_file(path, mode=MotionMode.ROLL)  # planning not in use: refused
    loaded = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True)
    assert loaded.mission.frame is MissionFrameKind.GLOBAL
    # a waypoint inside the exclusion is still refused, naming the item
    inside = write_plan(tmp_path, [(0.0, 0.0), (10.0, 0.0)])
    with pytest.raises(Exception, match=r"item 2.*inside the geofence's exclusion polygon 0"):
        load_mission_file(inside, mode=MotionMode.ROLL, route_keep_outs=True)


def _fence(path: Path, origin: tuple[float, float]) -> tuple[list[Any], list[KeepOutCircle]]:
    from helixd.mission.formats import plan_fence_ne

    fence = plan_fence_ne(path, origin)
    circles = [KeepOutCircle(*c.centre_ne_m, c.radius_m) for c in fence.exclusion_circles]
    return list(fence.exclusion_polygons), circles


@pytest.mark.parametrize("ekf_origin_ne_m", [(0.0, 0.0), (-300.0, 250.0)])
def test_global_vias_keep_the_clearance_from_any_ekf_origin(
    tmp_path: Path, ekf_origin_ne_m: tuple[float, float]
) -> None:
    path = write_plan(tmp_path, [(0.0, 0.0), (20.0, 0.0), (20.0, 10.0)], circles=((20, 5, 1.5),))
    msn = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True).mission
    cfg = HelixdConfig()
    origin = msn.points()[0]
    polys, circles = _fence(path, origin)
    planned, route = plan_global_mission(msn, cfg, polys, circles, origin)
    assert planned.frame is MissionFrameKind.GLOBAL
    assert route.origin_latlon_deg == origin
    assert len(planned.waypoints) > len(msn.waypoints)
    assert all(w.lat is not None and w.north is None for w in planned.waypoints)
    # fly it from an EKF origin elsewhere: every segment keeps the clearance from the wall and
    # the circle, and stays inside the keep-in polygon
    ekf = ne_to_latlon(*ekf_origin_ne_m, LAT0, LON0)

    def ne(lat: float, lon: float) -> tuple[float, float]:
        return latlon_to_ne(lat, lon, *ekf)

    wall = Polygon([ne(*_ll(*v)) for v in WALL_NE])
    disc = Point(ne(*_ll(20, 5))).buffer(1.5, 256)
    keep_in = Polygon([ne(*_ll(*v)) for v in KEEP_IN_NE])
    pts = [ne(*p) for p in planned.points()]
    need = clearance_m(cfg) - 1e-3
    for a, b in itertools.pairwise(pts):
        seg = LineString([a, b])
        assert seg.distance(wall) >= need and seg.distance(disc) >= need - 0.01
        assert keep_in.contains(seg)
    assert math.dist(pts[0], ne(*_ll(0, 0))) < 1e-6  # waypoint 0 unchanged


def test_waypoint_in_the_inflated_exclusion_is_refused_naming_it(tmp_path: Path) -> None:
    path = write_plan(tmp_path, [(0.0, 0.0), (8.6, 0.0)])  # 0.4 m short of the wall
    msn = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True).mission
    origin = msn.points()[0]
    polys, circles = _fence(path, origin)
    with pytest.raises(PlanningError) as err:
        plan_global_mission(msn, HelixdConfig(), polys, circles, origin)
    assert len(err.value.problems) == 1
    assert err.value.problems[0].startswith("waypoint 2 (north 8.60 m")  # numbered from 1
    assert "clearance of an obstacle" in err.value.problems[0]


def test_global_mission_with_origin_shapes_is_refused_saying_what_to_do(tmp_path: Path) -> None:
    path = write_plan(tmp_path, [(0.0, 0.0), (20.0, 0.0)])
    msn = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True).mission
    cfg = HelixdConfig.model_validate(
        {"planning": {"keep_out_circles": [{"north_m": 5, "east_m": 5, "radius_m": 1}]}}
    )
    with pytest.raises(PlanningError, match=r"planning.keep_out_circles: those are north/east"):
        plan_global_mission(msn, cfg, [], [], msn.points()[0])


def test_check_plans_a_plan_around_its_exclusions_and_refuses_without_planning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_plan(tmp_path, [(0.0, 0.0), (20.0, 0.0)])
    assert main_exit(["check", "--mission", str(path), "--mode", "roll"]) == 0
    out = capsys.readouterr().out
    assert "leg wp 1 → wp 2" in out and "intermediate" in out
    off = tmp_path / "off.yaml"
    off.write_text("planning:\n  enabled: false\n", encoding="utf-8")
    assert main_exit(["check", "-m", str(path), "--mode", "roll", "-c", str(off)]) == 2
    assert "crosses the geofence's exclusion polygon 0" in capsys.readouterr().err


def test_first_leg_of_a_global_plan_is_replanned_from_the_rover(tmp_path: Path) -> None:
    from helixd.prepare.planned import first_leg_replanner

    path = write_plan(tmp_path, [(20.0, 0.0), (20.0, 10.0)])  # waypoint 0 beyond the wall
    msn = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True).mission
    cfg = HelixdConfig()
    origin = msn.points()[0]
    polys, circles = _fence(path, origin)
    planned, route = plan_global_mission(msn, cfg, polys, circles, origin)
    assert planned.waypoints == msn.waypoints  # nothing in the way between the waypoints
    replan = first_leg_replanner(cfg, msn, planned, route)
    ekf = ne_to_latlon(-50.0, 40.0, LAT0, LON0)  # the EKF origin elsewhere
    rover = latlon_to_ne(*_ll(0.0, 0.0), *ekf)  # the rover south of the wall
    again = replan(rover, ekf)
    vias = again.waypoints[: len(again.waypoints) - len(msn.waypoints)]
    assert vias and all(w.lat is not None for w in vias)
    assert again.waypoints[len(vias) :] == msn.waypoints
    wall = Polygon([latlon_to_ne(*_ll(*v), *ekf) for v in WALL_NE])
    pts = [rover, *(latlon_to_ne(w.lat, w.lon, *ekf) for w in vias)]  # type: ignore[arg-type]
    pts.append(latlon_to_ne(*msn.points()[0], *ekf))
    for a, b in itertools.pairwise(pts):
        assert LineString([a, b]).distance(wall) >= clearance_m(cfg) - 1e-3
    with pytest.raises(PlanningError, match="needs the EKF origin"):
        replan(rover, None)


def test_check_plot_of_a_global_plan_is_labelled_around_waypoint_0(tmp_path: Path) -> None:
    from matplotlib.figure import Figure

    from helixd.recorder.plan_plots import draw_route

    path = write_plan(tmp_path, [(0.0, 0.0), (20.0, 0.0)])
    msn = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True).mission
    origin = msn.points()[0]
    polys, circles = _fence(path, origin)
    _, route = plan_global_mission(msn, HelixdConfig(), polys, circles, origin)
    ax = Figure().subplots()
    draw_route(ax, route)
    assert ax.get_xlabel() == "east of waypoint 1 (m)"
    assert ax.get_ylabel() == "north of waypoint 1 (m)"
    png = tmp_path / "p.png"
    assert main_exit(["check", "-m", str(path), "--mode", "roll", "--plot", str(png)]) == 0
    assert png.stat().st_size > 1000


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    wps=st.lists(st.tuples(st.floats(-8.0, 28.0), st.floats(-12.0, 12.0)), min_size=1, max_size=4),
    box=st.tuples(
        st.floats(-5.0, 25.0), st.floats(-10.0, 10.0), st.floats(0.5, 6.0), st.floats(0.5, 8.0)
    ),
)
def test_any_plan_is_refused_or_planned_clear_of_its_exclusion(
    tmp_path: Path,
    wps: list[tuple[float, float]],
    box: tuple[float, float, float, float],
) -> None:
    n0, e0, dn, de = box
    wall = [(n0, e0), (n0, e0 + de), (n0 + dn, e0 + de), (n0 + dn, e0)]
    doc = json.loads((DATA / "sim_square.plan").read_text())
    doc["mission"]["items"] = [_item(i + 1, n, e) for i, (n, e) in enumerate(wps)]
    doc["geoFence"]["polygons"] = [
        {"inclusion": True, "polygon": [_ll(*v) for v in KEEP_IN_NE], "version": 1},
        {"inclusion": False, "polygon": [_ll(*v) for v in wall], "version": 1},
    ]
    doc["geoFence"]["circles"] = []
    path = tmp_path / "fuzz.plan"
    path.write_text(json.dumps(doc), encoding="utf-8")
    try:
        msn = load_mission_file(path, mode=MotionMode.ROLL, route_keep_outs=True).mission
        origin = msn.points()[0]
        polys, circles = _fence(path, origin)
        planned, _ = plan_global_mission(msn, HelixdConfig(), polys, circles, origin)
    except (ConfigFileError, PlanningError) as exc:
        assert str(exc)
        return
    shape = Polygon([latlon_to_ne(*_ll(*v), *origin) for v in wall])
    pts = [latlon_to_ne(a, b, *origin) for a, b in planned.points()]
    need = clearance_m(HelixdConfig()) - 1e-3
    for a, b in itertools.pairwise(pts):
        assert LineString([a, b]).distance(shape) >= need
