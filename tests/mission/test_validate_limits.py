"""Mission-level fence/time overrides and the first-waypoint distance (helixd.mission.validate)."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from helixd.base.frames import NedPose, latlon_to_ne, ne_to_latlon
from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.mission.validate import (
    apply_mission_limits,
    mission_fence_ne,
    mission_problems,
    pending_checks,
)

ORIGIN = (53.52325, -113.52611)


def mission(frame: str, points: list[tuple[float, float]], **extra: Any) -> Mission:
    keys = {"start": ("x", "y"), "local_ned": ("north", "east"), "global": ("lat", "lon")}[frame]
    return Mission.model_validate(
        {
            "name": "t",
            "mode": "scroll",
            "frame": frame,
            "waypoints": [{keys[0]: a, keys[1]: b} for a, b in points],
            **extra,
        }
    )


def g(n: float, e: float) -> tuple[float, float]:
    return ne_to_latlon(n, e, *ORIGIN)


# -- first waypoint near the rover ---------------------------------------------------------------


def test_far_first_waypoint_is_refused_at_preflight() -> None:
    msn = mission("global", [g(130.0, 0.0), g(140.0, 0.0)])
    cfg = HelixdConfig.model_validate({"safety": {"geofence_radius_m": None}})
    start = NedPose(0.0, 0.0, 0.0)
    problems = mission_problems(msn, cfg, start_ned=start, origin_latlon_deg=ORIGIN)
    assert len(problems) == 1
    assert problems[0].startswith(
        "waypoint 1 (waypoints[0]): 130.0 m from the rover (N 0.0 m, E 0.0 m)"
    )
    assert "mission.max_start_distance_m = 100.0 m" in problems[0]
    near = NedPose(100.0, 0.0, 0.0)
    assert mission_problems(msn, cfg, start_ned=near, origin_latlon_deg=ORIGIN) == []
    tight = HelixdConfig.model_validate(
        {"safety": {"geofence_radius_m": None}, "mission": {"max_start_distance_m": 20.0}}
    )
    assert mission_problems(msn, tight, start_ned=near, origin_latlon_deg=ORIGIN)


def test_first_waypoint_distance_is_pending_without_the_pose() -> None:
    msn = mission("local_ned", [(130.0, 0.0)])
    cfg = HelixdConfig.model_validate({"safety": {"geofence_radius_m": None}})
    assert mission_problems(msn, cfg) == []
    assert "distance from the rover to waypoint 1" in pending_checks(msn, cfg)


def test_max_start_distance_is_bounded() -> None:
    for bad in (0.0, -1.0, 10_001.0, math.nan):
        with pytest.raises(ValidationError):
            HelixdConfig.model_validate({"mission": {"max_start_distance_m": bad}})


# -- mission-level fence and time limit -----------------------------------------------------------

SURVEY_NE = [(0.0, 0.0), (0.0, 200.0), (300.0, 200.0), (300.0, 0.0)]


def long_survey(frame: str) -> Mission:
    """A 200 m x 300 m lawnmower: far beyond the default 100 m radius and 30 min."""
    pts = [
        (float(n), float(e))
        for k in range(10)
        for n, e in ((k * 30.0 + 5, 5.0), (k * 30.0 + 5, 195.0))
    ]
    pts = [p if (i // 2) % 2 == 0 else (p[0], 200.0 - p[1]) for i, p in enumerate(pts)]
    fence = [(n - 2.0 if n == 0 else n + 2.0, e - 2.0 if e == 0 else e + 2.0) for n, e in SURVEY_NE]
    if frame == "global":
        pts = [g(n, e) for n, e in pts]
        fence = [g(n, e) for n, e in fence]
    return mission(frame, pts, geofence_polygon=fence, time_limit_s=20_000.0)


@pytest.mark.parametrize("frame", ["local_ned", "global"])
def test_survey_refused_by_config_limits_passes_with_its_own(frame: str) -> None:
    msn = long_survey(frame)
    plain = msn.model_copy(update={"geofence_polygon": (), "time_limit_s": None})
    start = NedPose(0.0, 0.0, 0.0)
    refused = mission_problems(plain, HelixdConfig(), start_ned=start, origin_latlon_deg=ORIGIN)
    assert any("geofence_radius_m" in p for p in refused)  # its time: tests/mission/test_judge
    assert mission_problems(msn, HelixdConfig(), start_ned=start, origin_latlon_deg=ORIGIN) == []


@pytest.mark.parametrize("frame", ["local_ned", "global"])
def test_survey_is_still_fenced(frame: str) -> None:
    """The override replaces the radius by the survey's own polygon: leaving it is refused."""
    msn = long_survey(frame)
    far = (400.0, 100.0)
    wp = g(*far) if frame == "global" else far
    out = msn.model_copy(update={"waypoints": (*msn.waypoints, *mission(frame, [wp]).waypoints)})
    problems = mission_problems(
        out, HelixdConfig(), start_ned=NedPose(0.0, 0.0, 0.0), origin_latlon_deg=ORIGIN
    )
    assert any(
        p.startswith("waypoint 21 (waypoints[20]):")
        and p.endswith("is outside the mission's geofence_polygon")
        for p in problems
    )


def test_applied_config_has_the_exact_polygon_once_placeable() -> None:
    msn = long_survey("global")
    cfg = apply_mission_limits(HelixdConfig(), msn, origin_latlon_deg=ORIGIN)
    assert cfg.safety.mission_time_limit_s == 20_000.0
    assert cfg.safety.geofence_radius_m is None
    poly = cfg.safety.geofence_polygon_ne_m
    assert len(poly) == 4
    assert poly[2][0] == pytest.approx(302.0, abs=1e-6)
    assert poly[2][1] == pytest.approx(202.0, abs=1e-6)
    assert apply_mission_limits(cfg, msn, origin_latlon_deg=ORIGIN) == cfg  # idempotent


def test_before_the_origin_a_radius_contains_the_polygon() -> None:
    """Without the EKF origin (check, or run before preflight) the fence is a radius around the
    start that contains the whole polygon wherever the start may be (<= max_start_distance_m
    from waypoint 0)."""
    msn = long_survey("global")
    cfg = apply_mission_limits(HelixdConfig(), msn)
    radius = cfg.safety.geofence_radius_m
    assert radius is not None
    lat0, lon0 = msn.points()[0]
    far = max(math.hypot(*latlon_to_ne(a, b, lat0, lon0)) for a, b in msn.geofence_polygon)
    assert far + 100.0 <= radius <= (far + 100.0) * 1.01
    assert cfg.safety.geofence_polygon_ne_m == ()
    assert mission_fence_ne(msn) is None


def test_start_frame_polygon_needs_the_start_pose() -> None:
    msn = mission(
        "start",
        [(5.0, 0.0)],
        geofence_polygon=[(-10.0, -10.0), (20.0, -10.0), (20.0, 10.0), (-10.0, 10.0)],
    )
    cfg = apply_mission_limits(HelixdConfig(), msn)
    assert cfg.safety.geofence_radius_m == pytest.approx(math.hypot(20.0, 10.0) * 1.005)
    start = NedPose(north_m=100.0, east_m=50.0, yaw_ned_rad=math.pi / 2)  # facing east
    fence = mission_fence_ne(msn, start_ned=start)
    assert fence is not None
    assert fence[1] == pytest.approx((90.0, 70.0))  # 20 m forward (east), 10 m right (south)


def test_radius_only_override_and_no_override() -> None:
    msn = mission("start", [(5.0, 0.0)], geofence_radius_m=250.0)
    assert apply_mission_limits(HelixdConfig(), msn).safety.geofence_radius_m == 250.0
    plain = mission("start", [(5.0, 0.0)])
    assert apply_mission_limits(HelixdConfig(), plain) == HelixdConfig()


@pytest.mark.parametrize(
    ("fence", "words"),
    [
        ([(0.0, 0.0), (1.0, 1.0)], "at least 3 vertices"),
        ([(0.0, 0.0), (10.0, 10.0), (0.0, 10.0), (10.0, 0.0)], "cross or touch"),
    ],
)
def test_bad_mission_fence_is_refused(fence: list[tuple[float, float]], words: str) -> None:
    with pytest.raises(ValidationError, match=words):
        mission("local_ned", [(5.0, 0.0)], geofence_polygon=fence)


def test_global_fence_vertex_off_the_earth_is_refused() -> None:
    with pytest.raises(ValidationError, match="vertex 1"):
        mission(
            "global",
            [ORIGIN],
            geofence_polygon=[ORIGIN, (95.0, 0.0), (ORIGIN[0] + 0.001, ORIGIN[1])],
        )


def test_check_says_the_missions_polygon_waits_for_the_origin() -> None:
    msn = long_survey("global")
    later = pending_checks(msn, apply_mission_limits(HelixdConfig(), msn))
    assert "keep-in polygon" in later
    assert "geofence radius around the start point" not in later


@settings(max_examples=200, deadline=None)
@given(
    frame=st.sampled_from(["start", "local_ned", "global"]),
    fence=st.lists(
        st.tuples(st.floats(-200, 200) | st.just(math.nan), st.floats(-200, 200)),
        max_size=7,
    ),
    radius=st.none() | st.floats(-1.0, 20_000.0),
    limit=st.none() | st.floats(-1.0, 100_000.0),
    pose=st.none() | st.tuples(st.floats(-300, 300), st.floats(-300, 300), st.floats(-7, 7)),
)
def test_mission_limits_are_total(
    frame: str,
    fence: list[tuple[float, float]],
    radius: float | None,
    limit: float | None,
    pose: tuple[float, float, float] | None,
) -> None:
    """Any fence/radius/limit either fails validation with a message or gives a config whose
    safety values are in their bounds, with or without the pose and origin."""
    if frame == "global":
        fence = [g(n, e) for n, e in fence if math.isfinite(n) and math.isfinite(e)]
        points = [g(5.0, 5.0)]
    else:
        points = [(5.0, 5.0)]
    try:
        msn = mission(
            frame, points, geofence_polygon=fence, geofence_radius_m=radius, time_limit_s=limit
        )
    except ValidationError as exc:
        assert str(exc)
        return
    start = None if pose is None else NedPose(*pose)
    for origin in (None, ORIGIN):
        cfg = apply_mission_limits(HelixdConfig(), msn, origin_latlon_deg=origin, start_ned=start)
        r = cfg.safety.geofence_radius_m
        assert r is None or 0 < r <= 10_000.0
        assert 0 < cfg.safety.mission_time_limit_s <= 86_400.0
        problems = mission_problems(msn, HelixdConfig(), start_ned=start, origin_latlon_deg=origin)
        assert all(isinstance(p, str) and "\n" not in p for p in problems)


def test_the_missions_ground_replaces_the_configs() -> None:
    msn = mission("start", [(1.0, 0.0)], ground={"scroll_fraction": 0.45, "yaw_fraction": 0.8})
    slip = apply_mission_limits(HelixdConfig(), msn).control.slip
    assert (slip.ground_roll_fraction, slip.ground_scroll_fraction, slip.ground_yaw_fraction) == (
        1.0,
        0.45,
        0.8,
    )
    assert slip.max_gain == HelixdConfig().control.slip.max_gain  # the rest stays the config's
    plain = mission("start", [(1.0, 0.0)])
    assert apply_mission_limits(HelixdConfig(), plain) == HelixdConfig()


def test_a_missions_ground_that_is_a_stall_is_refused() -> None:
    """Below control.slip.stuck_fraction the feed-forward gives up and the stall watchdog stops
    the run: a mission that declares such ground is refused, naming the field and the range."""
    msn = mission("start", [(1.0, 0.0)], ground={"roll_fraction": 0.1})
    problems = mission_problems(msn, HelixdConfig())
    assert any(
        p.startswith("ground.roll_fraction = 0.1 is below control.slip.stuck_fraction = 0.15")
        and p.endswith("(allowed range 0.15 .. 1)")
        for p in problems
    ), problems
    assert mission_problems(msn.model_copy(update={"ground": None}), HelixdConfig()) == []
    for bad in (0.0, 1.5, "x"):
        with pytest.raises(ValidationError, match=r"ground\.scroll_fraction"):
            mission("start", [(1.0, 0.0)], ground={"scroll_fraction": bad})
    with pytest.raises(ValidationError, match=r"ground\.sand"):
        mission("start", [(1.0, 0.0)], ground={"sand": 0.5})


def test_a_precision_mission_raises_the_gps_minimum_and_never_lowers_it() -> None:
    cfg = HelixdConfig()
    assert apply_mission_limits(cfg, mission("start", [(5.0, 0.0)])).safety.gps_min_fix_type == 3
    fixed = mission("start", [(5.0, 0.0)], gps_min_fix="rtk_fixed")
    assert apply_mission_limits(cfg, fixed).safety.gps_min_fix_type == 6
    float_ = mission("start", [(5.0, 0.0)], gps_min_fix="rtk_float")
    strict = cfg.model_copy(
        update={"safety": cfg.safety.model_copy(update={"gps_min_fix_type": 6})}
    )
    assert apply_mission_limits(strict, float_).safety.gps_min_fix_type == 6
    with pytest.raises(ValidationError, match="gps_min_fix"):
        mission("start", [(5.0, 0.0)], gps_min_fix="dgps")
