"""The simulator's world by place: water in the terrain table, each scroll in the medium
under it, a blend across a boundary, and the core driving from the bank into the pond."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError

from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium
from helixd.config.vehicle import VehicleConfig
from helixd.files.media import MediaMapError
from helixd.plant.ground import Terrain, TerrainTable
from helixd.plant.physics import scroll_positions_ne, step
from helixd.plant.state import PhysicsState
from helixd.sim.core import SimCore
from helixd.sim.server import with_media
from helixd.sim.sim_config import SimConfig
from tests.support.simcore import make_core, run

VEHICLE = VehicleConfig()
TABLE = TerrainTable()
DT_S = 0.02
TAU_S = 0.3
ROLL = (0.5, 0.5, -0.5, -0.5)  # +x, forward (thesis eq. 1)
SCROLL = (0.5, -0.5, -0.5, 0.5)  # +y, left


def drive(fractions: tuple[float, ...], traction: Any, seconds: float = 5.0) -> PhysicsState:
    state = PhysicsState()
    for _ in range(round(seconds / DT_S)):
        state = step(state, DT_S, fractions, VEHICLE, traction, TAU_S)
    return state


def test_water_has_its_row_and_every_medium_has_a_terrain() -> None:
    assert {m.value for m in Medium} == {t.value for t in Terrain}
    water = TABLE.get(Medium.WATER)
    assert water.roll_efficiency < 0.1 < water.scroll_efficiency
    assert water.dig_rate_per_m == 0.0
    assert TABLE.get(Terrain.WATER) == water


def test_in_water_roll_barely_moves_scroll_propels() -> None:
    water = TABLE.get(Medium.WATER)
    rolled = drive(ROLL, water)
    scrolled = drive(SCROLL, water)
    on_ground = drive(ROLL, TABLE.get(Medium.HARD))
    assert math.hypot(rolled.north_m, rolled.east_m) < 0.1 * on_ground.north_m
    assert math.hypot(scrolled.north_m, scrolled.east_m) > 5 * math.hypot(
        rolled.north_m, rolled.east_m
    )
    assert scrolled.east_m < -1.0  # +y is left: facing North, west
    assert rolled.pit_depth == scrolled.pit_depth == 0.0


def test_in_water_it_turns_by_differential_scroll_speed() -> None:
    turned = drive((0.4, 0.4, 0.4, 0.4), TABLE.get(Medium.WATER), seconds=2.0)
    assert turned.yaw_ned_rad < -0.3  # CCW body yaw: NED yaw decreases
    assert math.hypot(turned.north_m, turned.east_m) < 1e-9


@pytest.mark.parametrize("medium", list(Medium))
def test_four_equal_tractions_move_as_one(medium: Medium) -> None:
    one = drive((0.5, 0.2, -0.3, 0.1), TABLE.get(medium))
    four = drive((0.5, 0.2, -0.3, 0.1), (TABLE.get(medium),) * 4)
    assert four.north_m == pytest.approx(one.north_m, abs=1e-9)
    assert four.east_m == pytest.approx(one.east_m, abs=1e-9)
    assert four.yaw_ned_rad == pytest.approx(one.yaw_ned_rad, abs=1e-9)
    assert four.pit_depth == pytest.approx(one.pit_depth, abs=1e-12)


def test_straddling_a_boundary_blends_and_yaws_towards_the_weaker_side() -> None:
    hard, water = TABLE.get(Medium.HARD), TABLE.get(Medium.WATER)
    # scrolls 1, 2 on the right (bank), 3, 4 on the left (afloat)
    state = PhysicsState()
    for _ in range(round(0.5 / DT_S)):
        state = step(state, DT_S, ROLL, VEHICLE, (hard, hard, water, water), TAU_S)
    only_hard = drive(ROLL, hard, 0.5)
    only_water = drive(ROLL, water, 0.5)
    mean = (hard.roll_efficiency + water.roll_efficiency) / 2.0
    assert state.vx_body_mps == pytest.approx(
        only_hard.vx_body_mps * mean / hard.roll_efficiency, rel=1e-6
    )
    assert only_water.north_m < state.north_m < only_hard.north_m
    assert state.wz_body_radps > 0.0  # CCW: the bank side pushes, the rover turns left


def test_one_or_four_tractions_only() -> None:
    with pytest.raises(ValueError, match="one traction or four"):
        step(PhysicsState(), DT_S, ROLL, VEHICLE, (TABLE.hard,) * 3, TAU_S)


def test_scroll_positions_follow_the_heading() -> None:
    lx, ly = VEHICLE.lx_m, VEHICLE.ly_m
    north = scroll_positions_ne(0.0, 0.0, 0.0, VEHICLE)
    assert north[0] == pytest.approx((lx, ly))  # scroll 1 front right: facing North, east
    assert north[2] == pytest.approx((-lx, -ly))  # scroll 3 rear left
    east = scroll_positions_ne(10.0, 20.0, math.pi / 2, VEHICLE)
    assert east[0] == pytest.approx((10.0 - ly, 20.0 + lx))  # facing East, right is South
    assert east[3] == pytest.approx((10.0 + ly, 20.0 + lx))


WATER_NORTH_OF_5_M = MediaMap(
    MediaFrame.LOCAL_NED,
    (MediaArea(Medium.WATER, ((5.0, -50.0), (5.0, 50.0), (100.0, 50.0), (100.0, -50.0))),),
)


def set_scrolls(core: SimCore, pwm_us: tuple[int, int, int, int]) -> None:
    for channel, pwm in enumerate(pwm_us, start=1):
        core.set_rc(channel, pwm)


def test_the_core_rolls_off_the_bank_into_the_water_crawls_there_and_scroll_propels() -> None:
    core = make_core(1, media=WATER_NORTH_OF_5_M)
    run(core, 2.0)
    set_scrolls(core, (1700, 1700, 1300, 1300))  # ROLL forward, facing North
    run(core, 12.0)
    kinds = [e for e in core.drain_events() if e.kind == "media"]
    assert [e.details["scrolls"] for e in kinds] == [
        ["hard"] * 4,
        ["water", "hard", "hard", "water"],  # the front scrolls first
        ["water"] * 4,
    ]
    assert core.scroll_media == (Medium.WATER,) * 4
    # afloat, rolling gives next to nothing: it crawls (5 % of the roll) just past the edge
    rolled_to = core.phys.north_m
    assert 5.0 + VEHICLE.lx_m < rolled_to < 8.0
    assert core.phys.speed_mps < 0.1
    set_scrolls(core, (1300, 1700, 1700, 1300))  # SCROLL right: towards East
    run(core, 5.0)
    assert core.phys.east_m > 1.5
    assert core.phys.north_m == pytest.approx(rolled_to, abs=0.05)


def test_without_a_map_the_core_moves_exactly_as_before() -> None:
    plain, mapped = make_core(1), make_core(1, media=MediaMap(MediaFrame.LOCAL_NED, ()))
    for core in (plain, mapped):
        run(core, 2.0)
        set_scrolls(core, (1700, 1600, 1300, 1450))
        run(core, 3.0)
    assert plain.media_ne is None and plain.scroll_media is None
    assert mapped.phys.north_m == pytest.approx(plain.phys.north_m, abs=1e-9)
    assert mapped.phys.yaw_ned_rad == pytest.approx(plain.phys.yaw_ned_rad, abs=1e-9)


def test_outside_the_map_the_configured_terrain_applies() -> None:
    core = make_core(1, media=MediaMap(MediaFrame.LOCAL_NED, ()), terrain="sand")
    run(core, 2.0)
    set_scrolls(core, (1700, 1700, 1300, 1300))
    run(core, 0.1)
    assert core.scroll_media == (Medium.SAND,) * 4


def test_media_file_is_read_by_the_shell(tmp_path: Path) -> None:
    repo_map = Path(__file__).resolve().parents[2] / "config/maps/pond-media.geojson"
    cfg = with_media(SimConfig(media_file=repo_map))
    assert cfg.media is not None and cfg.media_file is None
    core = SimCore(cfg, 1, np.random.default_rng(1))
    assert core.media_ne is not None and core.media_ne.medium_at(25.0, 10.0) is Medium.WATER
    with pytest.raises(ValueError, match="read by the shell"):
        SimCore(SimConfig(media_file=repo_map), 1, np.random.default_rng(1))
    bad = tmp_path / "bad.geojson"
    bad.write_text('{"type": "FeatureCollection", "features": [1]}', "utf-8")
    with pytest.raises(MediaMapError, match=r"bad.geojson: features.0"):
        with_media(SimConfig(media_file=bad))
    with pytest.raises(ValidationError, match="not both"):
        SimConfig(media_file=bad, media=WATER_NORTH_OF_5_M)


def test_the_media_at_rest_are_looked_up_once_and_again_wherever_the_rover_is_put() -> None:
    """At rest the map is not searched again for the same pose; a rover put elsewhere (a new
    pose, however it got there) meets the medium there at its next loop."""
    core = make_core(1, media=WATER_NORTH_OF_5_M)
    run(core, 2.0)
    looked_up = core._media_looked_up
    run(core, 1.0)
    assert core._media_looked_up is looked_up  # the same pose: not looked up again
    core.phys = dataclasses.replace(core.phys, north_m=20.0)
    run(core, 0.1)
    assert core.scroll_media == (Medium.WATER,) * 4
    assert [e.details["scrolls"] for e in core.drain_events() if e.kind == "media"][-1] == [
        "water"
    ] * 4
