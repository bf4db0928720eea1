"""The autopilot's mission as helixd reads it: downloaded items → a validated mission (or the
refusal, named by where it came from), the fingerprint of what the autopilot stores, the motion
mode a ground-station mission is flown in."""

from __future__ import annotations

from dataclasses import replace

import pytest

from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats import read_gcs
from helixd.mission.formats.wire import gcs_to_wire
from helixd.prepare.autopilot_mission import (
    MISSION_NAME,
    MissionRefused,
    convert_download,
    ground_station_mode,
    items_sha256,
)
from tests.support.paths import DATA_DIR

CFG = HelixdConfig()
PLAN = DATA_DIR / "gcs" / "qgc-MissionPlanner.waypoints"


def downloaded() -> tuple[MissionItem, ...]:
    return gcs_to_wire(read_gcs(PLAN)).mission


def test_the_crews_mode_wins_then_the_configs_then_none() -> None:
    scroll = CFG.model_copy(
        update={"mission": CFG.mission.model_copy(update={"ground_station_mode": "scroll"})}
    )
    assert ground_station_mode(scroll, MotionMode.OMNI) is MotionMode.OMNI
    assert ground_station_mode(scroll, None) is MotionMode.SCROLL
    assert CFG.mission.ground_station_mode is None
    assert ground_station_mode(CFG, None) is None


def test_a_download_becomes_a_mission_of_its_items() -> None:
    items = downloaded()
    got = convert_download(items, (), source="autopilot at test", cfg=CFG, mode=MotionMode.ROLL)
    assert got.mission.name == MISSION_NAME and got.source == "autopilot at test"
    assert got.items == len(items) - 1  # home (row 0) is not a mission item
    assert got.fence_shapes == 0
    assert got.mission.mode is MotionMode.ROLL


def test_only_home_is_nothing_to_fly_and_says_where_it_came_from() -> None:
    home = downloaded()[:1]
    with pytest.raises(MissionRefused) as refused:
        convert_download(home, (), source="autopilot at udp:1", cfg=CFG, mode=MotionMode.ROLL)
    assert refused.value.problems == [
        "autopilot at udp:1: the autopilot holds no mission (only home): nothing to fly"
    ]


def test_the_fingerprint_leaves_home_out_and_tells_mission_from_fence() -> None:
    items = downloaded()
    base = items_sha256(items, ())
    assert len(base) == 64 and base == items_sha256(items, ())
    moved_home = (replace(items[0], x=items[0].x + 0.001), *items[1:])
    assert items_sha256(moved_home, ()) == base  # ArduPilot rewrites home: no news
    nudged = (*items[:-1], replace(items[-1], x=items[-1].x + 1e-6))
    assert items_sha256(nudged, ()) != base
    # the same item stored as the fence is another thing the autopilot holds
    assert items_sha256(items[:-1], items[-1:]) != items_sha256(items, ())
