"""helixd.mission.judge: the mission time limit against the navigator's own estimate."""

from __future__ import annotations

from typing import Any

from helixd.base.frames import NedPose
from helixd.config.root import HelixdConfig
from helixd.mission.judge import flight_problems
from helixd.mission.model import Mission
from helixd.mission.validate import mission_problems
from tests.support.missions import points_mission


def config(control: dict[str, Any] | None = None, **safety: Any) -> HelixdConfig:
    return HelixdConfig.model_validate({"safety": safety, "control": control or {}})


def test_estimate_over_the_limit_is_refused() -> None:
    # 30 × 90 m at 0.6 m/s is 4 500 s of cruise; every leg starts from rest and brakes to a
    # stop (180° reversals): 4 589 s
    msn = points_mission("start", [(90.0, 0.0), (0.0, 0.0)] * 15)
    assert flight_problems(msn, HelixdConfig()) == [
        "estimated time 4589 s (2700.0 m with acceleration, braking and 0 turns in place) "
        "exceeds safety.mission_time_limit_s = 1800 s; the run would be aborted (split the "
        "mission or raise the limit)"
    ]
    assert flight_problems(msn, config(mission_time_limit_s=4600.0)) == []


def test_acceleration_braking_and_pivots_count() -> None:
    """The 10 m ROLL square: 40 m at 0.6 m/s is 67 s; with the acceleration, the braking into
    each corner and three pivots (no corner arcs) the navigator takes 83 s (the simulator
    flies it in 83.1 s); with the default corner arcs 71 s and no pivot (flown: 71.8 s)."""
    msn = points_mission("start", [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)], mode="roll")
    pivots = {"control": {"corner_error_m": 0.0}}
    assert flight_problems(msn, config(mission_time_limit_s=84.0, **pivots)) == []
    problems = flight_problems(msn, config(mission_time_limit_s=80.0, **pivots))
    assert problems and problems[0].startswith("estimated time 83 s (40.0 m with acceleration")
    assert "3 turns in place" in problems[0]
    assert flight_problems(msn, config(mission_time_limit_s=72.0)) == []
    problems = flight_problems(msn, config(mission_time_limit_s=70.0))
    assert problems and problems[0].startswith("estimated time 71 s (40.0 m with acceleration")
    assert "0 turns in place" in problems[0]


def test_local_ned_time_without_pose_is_a_lower_bound() -> None:
    msn = points_mission("local_ned", [(0.0, 0.0), (60.0, 0.0)])
    assert flight_problems(msn, config(mission_time_limit_s=104.0)) == []
    problems = flight_problems(msn, config(mission_time_limit_s=100.0))
    assert problems[0].startswith("estimated time from waypoint 1 103 s")
    start = NedPose(north_m=-60.0, east_m=0.0, yaw_ned_rad=0.0)  # the first leg adds 100 s
    problems = flight_problems(
        msn, config(mission_time_limit_s=150.0, geofence_radius_m=None), start_ned=start
    )
    assert problems[0].startswith("estimated time 203 s")


def test_start_heading_counts_in_roll_mode() -> None:
    """Facing away from the first leg, the rover pivots first (line guidance)."""
    msn = points_mission("local_ned", [(20.0, 0.0)], mode="roll")
    cfg = config(geofence_radius_m=None, mission_time_limit_s=1000.0)
    facing = flight_problems(
        msn, cfg.model_copy(update={"safety": cfg.safety.model_copy(update={
            "mission_time_limit_s": 38.0})}),
        start_ned=NedPose(0.0, 0.0, 0.0),
    )  # fmt: skip
    away = flight_problems(
        msn, cfg.model_copy(update={"safety": cfg.safety.model_copy(update={
            "mission_time_limit_s": 38.0})}),
        start_ned=NedPose(0.0, 0.0, 3.1),
    )  # fmt: skip
    assert facing == []
    assert away and "1 turns in place" in away[0]


def test_the_missions_own_time_limit_replaces_the_configs() -> None:
    msn = points_mission("local_ned", [(0.0, 0.0), (400.0, 0.0)] * 2, time_limit_s=2200.0)
    plain = msn.model_copy(update={"time_limit_s": None})
    cfg = config(geofence_radius_m=None)
    assert any("mission_time_limit_s = 1800 s" in p for p in flight_problems(plain, cfg))
    assert flight_problems(msn, cfg) == []


def test_flight_problems_include_mission_problems() -> None:
    msn = points_mission("start", [(150.0, 0.0)])  # beyond the default 100 m geofence radius
    geometry = mission_problems(msn, HelixdConfig())
    assert geometry and flight_problems(msn, HelixdConfig())[: len(geometry)] == geometry


def patrol(loop_m: float, **extra: Any) -> Mission:
    """Out and back along ``loop_m`` metres, a DO_JUMP to item 1 forever (a patrol)."""
    return Mission.model_validate(
        {
            "name": "patrol",
            "mode": "omni",
            "frame": "start",
            "waypoints": [
                {"x": 0.0, "y": 0.0},
                {"x": loop_m, "y": 0.0},
                {"command": "DO_JUMP", "item": 1, "repeat": -1},
            ],
            **extra,
        }
    )


def test_a_patrol_is_ended_by_its_time_limit_so_only_its_first_lap_must_fit() -> None:
    """A DO_JUMP repeated forever flies until stopped: its laps planned beyond the limit are
    not a refusal; a first lap that cannot end within the limit is."""
    assert flight_problems(patrol(20.0), HelixdConfig()) == []
    assert flight_problems(patrol(20.0, time_limit_s=600), HelixdConfig()) == []
    (late,) = flight_problems(
        patrol(400.0), config(mission_time_limit_s=300.0, geofence_radius_m=None)
    )
    assert late.startswith("a patrol (DO_JUMP repeated forever) whose first lap ends at")
    assert "beyond safety.mission_time_limit_s = 300 s: not one lap would be flown" in late
