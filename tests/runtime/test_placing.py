"""The mission placed where the rover is: the plan resolved from the rover and the autopilot's
home, the frame a start mission is flown in, the media followed (or refused) at preflight."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.frames import NedPose
from helixd.base.plan import MissionFrameKind
from helixd.config.root import HelixdConfig
from helixd.link.vehicle import HomePosition
from helixd.mission.expand import DEFAULT_OPTIONS
from helixd.mission.model import Mission
from helixd.runtime.placing import follow_medium, mission_frame, resolve_flight
from helixd.runtime.setup import PreflightFailed

CFG = HelixdConfig()
RETURNS = Mission.model_validate(
    {
        "name": "out and home",
        "mode": "roll",
        "frame": "local_ned",
        "waypoints": [{"north": 5, "east": 0}, {"command": "NAV_RETURN_TO_LAUNCH"}],
    }
)
HERE = NedPose(1.0, 2.0, 0.0)


def test_a_return_home_without_the_autopilots_home_is_refused() -> None:
    with pytest.raises(PreflightFailed, match="NAV_RETURN_TO_LAUNCH"):
        resolve_flight(RETURNS, CFG, None, HERE, None, DEFAULT_OPTIONS)


def test_a_return_home_ends_at_the_autopilots_home() -> None:
    home = HomePosition(53.5, -113.5, -3.0, 4.0)
    plan, where = resolve_flight(RETURNS, CFG, None, HERE, home, DEFAULT_OPTIONS)
    assert where.home_xy_m == (4.0, -3.0)  # x east, y north
    assert where.start_xy_m == (2.0, 1.0)
    last = plan.waypoints[-1]
    assert (last.x_m, last.y_m) == (4.0, -3.0)


def test_a_start_mission_is_framed_at_the_rover() -> None:
    start = Mission.model_validate(
        {"name": "s", "mode": "roll", "frame": "start", "waypoints": [{"x": 1, "y": 0}]}
    )
    assert start.frame is MissionFrameKind.START
    frame = mission_frame(start, HERE)
    assert frame.to_ned(0.0, 0.0)[:2] == pytest.approx((1.0, 2.0))
    assert mission_frame(RETURNS, HERE).to_ned(0.0, 0.0)[:2] == pytest.approx((0.0, 0.0))


def test_without_a_media_map_the_plan_is_flown_as_resolved() -> None:
    plan, _ = resolve_flight(
        RETURNS, CFG, None, HERE, HomePosition(53.5, -113.5, 0.0, 0.0), DEFAULT_OPTIONS
    )
    assert follow_medium(plan, RETURNS, CFG, None, HERE) is plan


def test_a_media_map_gone_by_preflight_refuses_the_flight(tmp_path: Path) -> None:
    gone = tmp_path / "pond-media.geojson"
    mission = Mission.model_validate(
        {
            "name": "m",
            "mode": "roll",
            "frame": "local_ned",
            "media_map": str(gone),
            "waypoints": [{"north": 5, "east": 0}],
        }
    )
    bare = mission.model_copy(update={"media_map": None})
    plan, _ = resolve_flight(bare, CFG, None, HERE, None, DEFAULT_OPTIONS)
    with pytest.raises(PreflightFailed) as refused:
        follow_medium(plan, mission, CFG, None, HERE)
    assert refused.value.problems == [f"media_map: {gone}: no such file"]
    with pytest.raises(PreflightFailed):  # resolving the flight follows the media too
        resolve_flight(mission, CFG, None, HERE, None, DEFAULT_OPTIONS)
