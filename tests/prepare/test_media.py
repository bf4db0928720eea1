"""A flight's media map and its plan split by it: which map (the mission's, else the config's),
read and refused one line per problem; the mode policy (the mission's modes over the config's);
the plan ``check`` can split without the rover and the one preflight splits from its start."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from helixd.base.frames import NedPose
from helixd.base.media import Medium
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.mission.model import Mission
from helixd.mission.validate import plan_for_check
from helixd.prepare.media import (
    MediaRefused,
    check_media_plan,
    media_path,
    mode_policy,
    placed_media_plan,
    read_media,
    with_absolute_media,
)

CFG = HelixdConfig()
RING = [[-30, 10], [30, 10], [30, 50], [-30, 50], [-30, 10]]  # [east, north]: 40 m of water


def water_map(tmp_path: Path, medium: str = "water") -> Path:
    media = {
        "type": "FeatureCollection",
        "frame": "local_ned",
        "default_medium": "hard",
        "features": [
            {
                "type": "Feature",
                "properties": {"medium": medium},
                "geometry": {"type": "Polygon", "coordinates": [RING]},
            }
        ],
    }
    path = tmp_path / "water.geojson"
    path.write_text(json.dumps(media), encoding="utf-8")
    return path


def crossing(media_map: Path | None, frame: str = "local_ned", **extra: object) -> Mission:
    """60 m north (across the water), or 60 m along x for a start-frame mission."""
    wps = [{"north": 0.0, "east": 0.0}, {"north": 60.0, "east": 0.0}]
    if frame == "start":
        wps = [{"x": 1.0, "y": 0.0}, {"x": 60.0, "y": 0.0}]
    return Mission.model_validate(
        {"name": "c", "mode": "scroll", "frame": frame, "media_map": media_map, "waypoints": wps}
        | extra
    )


def test_the_missions_map_wins_and_is_read_relative_to_its_file(tmp_path: Path) -> None:
    cfg = CFG.model_copy(
        update={"media": CFG.media.model_copy(update={"media_map": Path("config.geojson")})}
    )
    assert media_path(cfg, crossing(None)) == Path("config.geojson")
    relative = crossing(Path("water.geojson"))
    absolute = with_absolute_media(relative, tmp_path / "crossing.yaml")
    assert absolute.media_map == (tmp_path / "water.geojson").resolve()
    assert media_path(cfg, absolute) == absolute.media_map
    assert with_absolute_media(absolute, Path("/elsewhere/m.yaml")) is absolute
    assert read_media(CFG, crossing(None)) is None  # no map: one mode everywhere


def test_a_missing_or_bad_map_is_refused_naming_the_field(tmp_path: Path) -> None:
    with pytest.raises(MediaRefused) as missing:
        read_media(CFG, crossing(tmp_path / "gone.geojson"))
    assert missing.value.problems == [f"media_map: {tmp_path / 'gone.geojson'}: no such file"]
    lava = water_map(tmp_path, "lava")
    with pytest.raises(MediaRefused) as bad:
        read_media(CFG, crossing(lava))
    assert bad.value.problems and all(p.startswith("media_map: ") for p in bad.value.problems)
    assert "lava" in "\n".join(bad.value.problems)


def test_the_missions_modes_replace_the_configs_per_medium() -> None:
    policy = mode_policy(CFG, crossing(None))
    assert policy.mode_for(Medium.HARD) is MotionMode.ROLL
    assert policy.mode_for(Medium.WATER) is MotionMode.SCROLL
    assert policy.margin_m == CFG.media.transition_margin_m
    ours = crossing(None, media_modes={"water": "omni"})
    assert mode_policy(CFG, ours).mode_for(Medium.WATER) is MotionMode.OMNI
    assert mode_policy(CFG, ours).mode_for(Medium.HARD) is MotionMode.ROLL


def test_check_splits_a_local_crossing_into_roll_scroll_roll(tmp_path: Path) -> None:
    msn = crossing(water_map(tmp_path))
    media = read_media(CFG, msn)
    assert media is not None
    plan, _ = plan_for_check(msn, CFG)
    got = check_media_plan(CFG, msn, plan, media)
    assert got.media is not None and got.why == ""
    modes = [st.mode for st in got.media.stretches]
    assert modes == [MotionMode.ROLL, MotionMode.SCROLL, MotionMode.ROLL]
    assert len(got.media.transitions) == 2
    first, second = (t.xy_m[1] for t in got.media.transitions)  # y: north
    assert 5.0 < first < 10.0 and 50.0 < second < 55.0  # before the water, after it


def test_check_leaves_a_start_mission_to_preflight_which_splits_it_from_the_rover(
    tmp_path: Path,
) -> None:
    msn = crossing(water_map(tmp_path), frame="start")
    media = read_media(CFG, msn)
    assert media is not None
    plan, _ = plan_for_check(msn, CFG)
    got = check_media_plan(CFG, msn, plan, media)
    assert got.media is None and "placed on the map where it starts" in got.why
    # at preflight, the rover at the origin facing north: the mission's x runs north
    placed = placed_media_plan(CFG, msn, plan, None, NedPose(0.0, 0.0, 0.0))
    assert placed is not None
    assert [st.mode for st in placed.stretches] == [
        MotionMode.ROLL,
        MotionMode.SCROLL,
        MotionMode.ROLL,
    ]
    assert (
        placed_media_plan(CFG, crossing(None, frame="start"), plan, None, NedPose(0, 0, 0)) is None
    )
