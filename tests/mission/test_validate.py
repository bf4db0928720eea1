"""One validation for `check` and `run`: mission vs config (helixd.mission.validate) and the
cross-section config rules (helixd.config validators). Pure: numbers in, messages out."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from helixd.base.frames import NedPose
from helixd.base.polygon import leg_leaves_polygon, polygon_problems, segments_intersect
from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.mission.validate import mission_problems, pending_checks
from tests.support.missions import mission_of, points_mission


def config(**safety: Any) -> HelixdConfig:
    return HelixdConfig.model_validate({"safety": safety})


# -- geofence radius --------------------------------------------------------------------------


def test_start_frame_waypoint_outside_radius_is_refused_without_the_pose() -> None:
    msn = points_mission("start", [(50.0, 0.0), (150.0, 0.0), (0.0, 0.0)])
    problems = mission_problems(msn, HelixdConfig())
    assert problems == [
        "waypoint 2 (waypoints[1]): 150.0 m from the start point; allowed at most "
        "safety.geofence_radius_m = 100.0 m"
    ]


def test_start_frame_inside_radius_passes() -> None:
    msn = points_mission("start", [(60.0, 0.0), (60.0, 60.0), (0.0, 0.0)])  # 84.9 m corner
    assert mission_problems(msn, HelixdConfig()) == []


def test_radius_off_disables_the_check() -> None:
    msn = points_mission("start", [(150.0, 0.0)])
    assert mission_problems(msn, config(geofence_radius_m=None)) == []


def test_local_ned_radius_needs_the_pose() -> None:
    msn = points_mission("local_ned", [(0.0, 0.0), (90.0, 0.0)])
    assert mission_problems(msn, HelixdConfig()) == []
    assert "geofence radius around the start point" in pending_checks(msn, HelixdConfig())
    start = NedPose(north_m=-30.0, east_m=0.0, yaw_ned_rad=0.0)
    problems = mission_problems(msn, HelixdConfig(), start_ned=start)
    assert len(problems) == 1
    assert problems[0].startswith(
        "waypoint 2 (waypoints[1]): 120.0 m from the start point (N -30.0 m"
    )


def test_global_mission_is_checked_with_the_origin() -> None:
    origin = (53.5, -113.5)
    north_deg_per_m = 1.0 / 111_320.0
    far = (origin[0] + 150 * north_deg_per_m, origin[1])
    msn = points_mission("global", [(origin[0] + 10 * north_deg_per_m, origin[1]), far])
    assert mission_problems(msn, HelixdConfig()) == []  # no origin: only the time check
    start = NedPose(0.0, 0.0, 0.0)
    problems = mission_problems(msn, HelixdConfig(), start_ned=start, origin_latlon_deg=origin)
    assert len(problems) == 1 and problems[0].startswith("waypoint 2 (waypoints[1]): 15")


def test_many_offenders_are_summarised() -> None:
    msn = points_mission("start", [(200.0 + i, 0.0) for i in range(20)])
    problems = mission_problems(msn, HelixdConfig())
    assert len(problems) == 6
    assert problems[-1] == "… and 15 more waypoints outside safety.geofence_radius_m"


# -- keep-in polygon ----------------------------------------------------------------------------

SQUARE_NE = [[-50.0, -50.0], [-50.0, 50.0], [50.0, 50.0], [50.0, -50.0]]
# U shape: the notch between east 10 and 20 reaches down to north 10
U_NE = [[0.0, 0.0], [0.0, 30.0], [30.0, 30.0], [30.0, 20.0], [10.0, 20.0], [10.0, 10.0],
        [30.0, 10.0], [30.0, 0.0]]  # fmt: skip


def test_local_ned_polygon_is_checked_without_the_pose() -> None:
    cfg = config(geofence_polygon_ne_m=SQUARE_NE, geofence_radius_m=None)
    msn = points_mission("local_ned", [(10.0, 10.0), (60.0, 0.0)])
    assert mission_problems(msn, cfg) == [
        "waypoint 2 (waypoints[1]): N 60.0 m, E 0.0 m is outside safety.geofence_polygon_ne_m"
    ]


def test_leg_across_a_notch_is_refused() -> None:
    cfg = config(geofence_polygon_ne_m=U_NE, geofence_radius_m=None)
    msn = points_mission("local_ned", [(20.0, 5.0), (20.0, 25.0)])  # both arms inside, leg crosses
    problems = mission_problems(msn, cfg)
    assert problems == [
        "leg waypoint 1 (waypoints[0]) → waypoint 2 (waypoints[1]) leaves "
        "safety.geofence_polygon_ne_m (both ends are inside)"
    ]


def test_a_jump_missions_refusals_name_its_items_not_the_plans_indices() -> None:
    """The plan of a mission with commands is its flight (jumps expanded, no point for the
    start): a refusal names the entry a person wrote, once for all its laps — not plan index 0
    as 'waypoint 1' when entry 2 is the one out of the fence."""
    jump = {"command": "DO_JUMP", "item": 1, "repeat": 2}
    msn = mission_of("start", [{"x": 0.0, "y": 0.0}, {"x": 400.0, "y": 0.0}, jump], "omni")
    assert mission_problems(msn, HelixdConfig()) == [
        "waypoint 2 (waypoints[1]): 400.0 m from the start point; allowed at most "
        "safety.geofence_radius_m = 100.0 m"
    ]


def test_start_frame_polygon_needs_the_pose_then_rotates_with_it() -> None:
    cfg = config(geofence_polygon_ne_m=SQUARE_NE, geofence_radius_m=None)
    msn = points_mission("start", [(40.0, 0.0)])  # 40 m ahead of the start pose
    assert mission_problems(msn, cfg) == []
    assert "keep-in polygon" in pending_checks(msn, cfg)
    facing_north = NedPose(north_m=0.0, east_m=0.0, yaw_ned_rad=0.0)
    assert mission_problems(msn, cfg, start_ned=facing_north) == []
    from_the_edge = NedPose(north_m=30.0, east_m=0.0, yaw_ned_rad=0.0)  # 70 m north: outside
    problems = mission_problems(msn, cfg, start_ned=from_the_edge)
    assert problems == [
        "waypoint 1 (waypoints[0]): N 70.0 m, E 0.0 m is outside safety.geofence_polygon_ne_m"
    ]
    facing_east = NedPose(north_m=30.0, east_m=0.0, yaw_ned_rad=math.pi / 2)  # 40 m east: inside
    assert mission_problems(msn, cfg, start_ned=facing_east) == []


def test_start_outside_polygon_is_refused() -> None:
    cfg = config(geofence_polygon_ne_m=SQUARE_NE, geofence_radius_m=None)
    msn = points_mission("local_ned", [(10.0, 10.0)])
    start = NedPose(north_m=80.0, east_m=0.0, yaw_ned_rad=0.0)
    problems = mission_problems(msn, cfg, start_ned=start)
    assert problems[0].startswith("the start point (N 80.0 m, E 0.0 m) is outside")


# -- keep-out areas the mission carries ---------------------------------------------------------

ISLAND_NE = ((10.0, 10.0), (10.0, 20.0), (20.0, 20.0), (20.0, 10.0))


def with_island(points: list[tuple[float, float]]) -> Mission:
    msn = points_mission("local_ned", points)
    return msn.model_copy(update={"keep_out_polygons": (ISLAND_NE,)})


def test_waypoint_inside_a_keep_out_area_is_refused() -> None:
    problems = mission_problems(with_island([(0.0, 0.0), (15.0, 15.0)]), config())
    assert problems == ["waypoint 2 (waypoints[1]): inside keep_out_polygons.0 (a keep-out area)"]


def test_leg_through_a_keep_out_area_is_refused_only_when_nothing_plans_around_it() -> None:
    msn = with_island([(15.0, 0.0), (15.0, 30.0)])  # the leg crosses the island
    assert mission_problems(msn, config()) == []  # planning routes it around
    off = HelixdConfig.model_validate({"planning": {"enabled": False}})
    assert mission_problems(msn, off) == [
        "leg waypoint 1 (waypoints[0]) → waypoint 2 crosses keep_out_polygons.0 "
        "(planning.enabled is false: nothing plans around it)"
    ]


def test_keep_out_areas_need_a_frame_fixed_to_the_ground() -> None:
    with pytest.raises(ValidationError, match="keep-out areas need a local_ned or global"):
        Mission.model_validate(
            {
                "name": "t",
                "mode": "roll",
                "frame": "start",
                "waypoints": [{"x": 1.0, "y": 0.0}],
                "keep_out_polygons": [list(ISLAND_NE)],
            }
        )


# -- polygon geometry ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("poly", "fragment"),
    [
        ([], "at least 3 vertices, got 0"),
        ([(0.0, 0.0), (1.0, 1.0)], "at least 3 vertices, got 2"),
        ([(0.0, 0.0), (math.nan, 1.0), (1.0, 0.0)], "not a finite"),
        ([(0.0, 0.0), (0.0, 0.0), (5.0, 5.0)], "same point"),
        ([(0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, 10.0)], "intersect itself"),
        ([(0.0, 0.0), (5.0, 0.0), (10.0, 0.0)], "area 0"),
        ([(0.0, 0.0), (0.5, 0.0), (0.5, 0.5)], "area 0.125"),
    ],
)
def test_bad_polygons(poly: list[tuple[float, float]], fragment: str) -> None:
    problems = polygon_problems(poly)
    assert problems and fragment in problems[0], problems


def test_good_polygons() -> None:
    assert polygon_problems([(0.0, 0.0), (0.0, 10.0), (10.0, 0.0)]) == []
    assert polygon_problems([tuple(v) for v in U_NE]) == []  # type: ignore[misc]


def test_segments() -> None:
    assert segments_intersect((0, 0), (2, 2), (0, 2), (2, 0))
    assert segments_intersect((0, 0), (2, 0), (1, 0), (3, 0))  # collinear overlap
    assert not segments_intersect((0, 0), (1, 0), (2, 0), (3, 0))
    assert not leg_leaves_polygon((1, 1), (2, 2), [(0, 0), (0, 5), (5, 5), (5, 0)])


# -- config-only rules (pydantic validators: they run whenever the config loads) --------------


def config_errors(data: dict[str, Any]) -> str:
    with pytest.raises(ValidationError) as info:
        HelixdConfig.model_validate(data)
    return str(info.value)


@pytest.mark.parametrize(
    ("data", "fragment"),
    [
        (
            {"safety": {"takeover": {"switch_channel": 2}}},
            "safety.takeover.switch_channel = 2 is the RC channel that drives scroll 2",
        ),
        (
            {"startup": {"start_switch_channel": 4}},
            "startup.start_switch_channel = 4 is the RC channel that drives scroll 4",
        ),
        (
            {"safety": {"takeover": {"stick_channels": [6, 3]}}},
            "safety.takeover.stick_channels.1 = 3 is the RC channel that drives scroll 3",
        ),
        (
            {"startup": {"start_switch_channel": 7}, "safety": {"takeover": {"switch_channel": 7}}},
            "are both 7",
        ),
        (
            {
                "startup": {"start_switch_channel": 7},
                "safety": {"takeover": {"stick_channels": [7]}},
            },
            "is also in safety.takeover.stick_channels",
        ),
        ({"safety": {"takeover": {"stick_channels": [0]}}}, "greater than or equal to 1"),
        ({"safety": {"takeover": {"stick_channels": [19]}}}, "less than or equal to 18"),
        ({"safety": {"takeover": {"stick_channels": [5, 5]}}}, "each channel may be listed once"),
        ({"actuation": {"stop_timeout_s": 0.5}}, "must be < safety.fallback_deadline_s = 0.5"),
        (
            {"actuation": {"neutral_hold_s": 0.2, "release_spacing_s": 0.1, "release_repeats": 3}},
            "must be < actuation.stop_timeout_s = 0.4",
        ),
        ({"safety": {"pose_stale_s": 0.2}}, "1 / link.pose_rate_min_hz = 0.200 s"),
        (
            {"startup": {"arm_timeout_s": 1.0, "arm_retry_interval_s": 2.0}},
            "startup.arm_retry_interval_s = 2.0 s must be <=",
        ),
        ({"link": {"url": "tcp:"}}, "expected HOST:PORT"),
        ({"vehicle": {"max_rpm": True}}, "true/false is not a number"),
        ({"safety": {"geofence_radius_m": False}}, "true/false is not a number"),
    ],
)
def test_config_rules(data: dict[str, Any], fragment: str) -> None:
    assert fragment in config_errors(data)


def test_pilot_channels_on_scroll_numbers_are_fine_with_the_servo_backend() -> None:
    # DO_SET_SERVO drives SERVOn outputs; RC input n is the pilot's, no conflict.
    cfg = HelixdConfig.model_validate(
        {"actuation": {"backend": "servo"}, "safety": {"takeover": {"switch_channel": 1}}}
    )
    assert cfg.safety.takeover.switch_channel == 1


def test_defaults_satisfy_every_rule() -> None:
    assert HelixdConfig() == HelixdConfig.model_validate({})


# -- totality: any valid mission, config and pose gives a list of one-line messages -------------

coord = st.floats(min_value=-400.0, max_value=400.0, allow_nan=False)


@settings(max_examples=150, deadline=None)
@given(
    frame=st.sampled_from(["start", "local_ned"]),
    mode=st.sampled_from(["roll", "scroll", "omni"]),
    points=st.lists(st.tuples(coord, coord), min_size=1, max_size=12),
    pose=st.none() | st.tuples(coord, coord, st.floats(-7.0, 7.0)),
    radius=st.none() | st.floats(1.0, 1000.0),
    limit=st.floats(1.0, 86_400.0),
    polygon=st.sampled_from([[], SQUARE_NE, U_NE]),
)
def test_mission_problems_is_total(
    frame: str,
    mode: str,
    points: list[tuple[float, float]],
    pose: tuple[float, float, float] | None,
    radius: float | None,
    limit: float,
    polygon: list[list[float]],
) -> None:
    try:
        msn = points_mission(frame, points, mode=mode)
    except ValidationError:
        return  # e.g. consecutive duplicates or beyond max_range_m: refused at load already
    cfg = config(
        geofence_radius_m=radius, mission_time_limit_s=limit, geofence_polygon_ne_m=polygon
    )
    start = None if pose is None else NedPose(*pose)
    problems = mission_problems(msn, cfg, start_ned=start)
    assert all(isinstance(p, str) and "\n" not in p and len(p) < 300 for p in problems)
    # radius and polygon lists are capped; time and the first-waypoint distance are one line each
    assert len(problems) <= 2 * 6 + 3
