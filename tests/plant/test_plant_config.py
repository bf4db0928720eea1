"""The plant's settings (helixd.plant.plant_config): their own checks, the plant's part of the
one simulator YAML (the simulator's SimConfig adds the autopilot's keys), nothing of the
autopilot's accepted by the plant alone."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from helixd.base.media import MediaFrame, MediaMap
from helixd.plant.ground import Terrain
from helixd.plant.plant_config import Plant, PlantConfig
from helixd.sim.sim_config import SimConfig


def test_defaults_are_the_helix_on_hard_ground_at_rest() -> None:
    cfg = PlantConfig()
    assert cfg.plant is Plant.HELIX
    assert cfg.terrain is Terrain.HARD
    assert cfg.traction() == cfg.terrains.hard
    assert (cfg.initial_north_m, cfg.initial_east_m, cfg.initial_yaw_ned_rad) == (0.0, 0.0, 0.0)


def test_the_motor_map_and_the_start_come_from_the_settings() -> None:
    cfg = PlantConfig(
        motor_pwm_min_us=1100,
        motor_pwm_max_us=1900,
        motor_deadband_us=20,
        initial_north_m=3.0,
        initial_east_m=-4.0,
        initial_yaw_ned_rad=1.0,
    )
    motor = cfg.motor_map()
    assert motor.fraction(1900) == 1.0 and motor.fraction(1100) == -1.0
    assert motor.fraction(1515) == 0.0  # within the deadband
    start = cfg.start_state()
    assert (start.north_m, start.east_m, start.yaw_ned_rad) == (3.0, -4.0, 1.0)
    assert start.speed_mps == 0.0 and start.scroll_radps == (0.0, 0.0, 0.0, 0.0)


def test_traction_follows_the_configured_terrain() -> None:
    cfg = PlantConfig(terrain=Terrain.MUD)
    assert cfg.traction() == cfg.terrains.mud
    assert cfg.traction() != PlantConfig().traction()


@pytest.mark.parametrize(
    ("fields", "why"),
    [
        ({"motor_pwm_min_us": 1600}, "motor_pwm_min_us < motor_pwm_trim_us"),
        ({"motor_pwm_max_us": 1400}, "motor_pwm_min_us < motor_pwm_trim_us"),
        ({"scroll_output_channels": (1, 2, 3, 17)}, "scroll_output_channels must be 1..16"),
        ({"media_file": "pond.geojson"}, None),  # alone it is fine: the shell reads it
    ],
)
def test_the_plants_own_checks(fields: dict[str, object], why: str | None) -> None:
    if why is None:
        PlantConfig.model_validate(fields)
        return
    with pytest.raises(ValidationError, match=why):
        PlantConfig.model_validate(fields)
    with pytest.raises(ValidationError, match=why):  # and the simulator's, which extends it
        SimConfig.model_validate(fields)


def test_a_map_given_twice_is_refused() -> None:
    empty = MediaMap(MediaFrame.LOCAL_NED, ())
    with pytest.raises(ValidationError, match="not both"):
        PlantConfig(media_file="pond.geojson", media=empty)


def test_one_simulator_yaml_the_plant_reads_its_part_the_simulator_all() -> None:
    plant_keys = {"terrain": "sand", "motor_time_constant_s": 0.5, "origin_lat_deg": 50.0}
    autopilot_keys = {"noise": "none", "boot_duration_s": 0.5, "params": {"WP_RADIUS": 3.0}}
    sim = SimConfig.model_validate({**plant_keys, **autopilot_keys})
    assert isinstance(sim, PlantConfig)
    assert sim.terrain is Terrain.SAND and sim.boot_duration_s == 0.5
    assert set(PlantConfig.model_fields) < set(SimConfig.model_fields)
    plant = PlantConfig.model_validate(plant_keys)
    assert plant.motor_time_constant_s == 0.5 and plant.origin_lat_deg == 50.0
    with pytest.raises(ValidationError, match="boot_duration_s"):
        PlantConfig.model_validate({**plant_keys, "boot_duration_s": 0.5})
