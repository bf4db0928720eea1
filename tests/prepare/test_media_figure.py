"""What ``check --plot`` draws of a media map: the map placed in the mission frame and the plan
split by it, or why not before preflight. (The drawing itself: tests/cli/test_check_media.py.)"""

from __future__ import annotations

from pathlib import Path

from helixd.base.media import Medium
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.prepare.media import read_media
from helixd.prepare.media_figure import checked_media
from tests.prepare.test_media import crossing, water_map

CFG = HelixdConfig()


def test_a_local_crossing_is_placed_and_split(tmp_path: Path) -> None:
    msn = crossing(water_map(tmp_path))
    media = read_media(CFG, msn)
    assert media is not None
    got = checked_media(CFG, msn, msn, media)
    assert got.placed is not None and got.plan is not None and got.why == ""
    assert got.placed.areas.medium_at(30.0, 0.0) is Medium.WATER  # (north, east)
    assert got.placed.areas.medium_at(5.0, 0.0) is Medium.HARD
    modes = {st.mode for st in got.plan.stretches}
    assert modes == {MotionMode.ROLL, MotionMode.SCROLL}


def test_a_start_mission_is_not_drawn_before_preflight_and_says_why(tmp_path: Path) -> None:
    msn = crossing(water_map(tmp_path), frame="start")
    media = read_media(CFG, msn)
    assert media is not None
    got = checked_media(CFG, msn, msn, media)
    assert got.placed is None and got.plan is None
    assert "placed on the map where it starts" in got.why
