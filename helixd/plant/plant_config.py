"""The Helix plant's settings: the vehicle, its motors, the ground, the world around it.

What the plant needs and nothing of an autopilot: the rover's geometry, which plant model
(:class:`Plant`), the motor controllers' PWM map and lag, the ground (:mod:`helixd.plant.ground`)
and a media map over it, the pond's bottom and the sonar, obstacles, where on the earth the
world is placed and where the rover starts. The built-in simulator's settings
(:class:`helixd.sim.sim_config.SimConfig`) extend it, so one simulator YAML serves ``helixd
sim`` and ``helixd plant``. Every tunable has a unit in its name, bounds and a default.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path

from pydantic import Field, InstanceOf, model_validator

from helixd.base.media import MediaMap
from helixd.config.vehicle import VehicleConfig
from helixd.files.bathymetry import Bathymetry
from helixd.files.models import InputModel
from helixd.plant.collisions import SimObstacles
from helixd.plant.ground import Terrain, TerrainTable, TerrainTraction
from helixd.plant.physics import MotorMap
from helixd.plant.sonar import SonarModel
from helixd.plant.state import PhysicsState


class Plant(StrEnum):
    HELIX = "helix"  # Helix-25 scrolls, eq. 1, motor lag, terrain slip (physics.py)
    SITL_SKID = "sitl_skid"  # ArduPilot SITL's rover-skid model (skid.py)


class SkidModel(InputModel):
    """ArduPilot SITL's skid-steer rover (libraries/SITL/SIM_Rover.cpp; see helixd.plant.skid).

    Defaults are SIM_Rover's constants for a ``skid`` frame. It reads outputs 1 (left motor)
    and 3 (right motor) only, as SITL does; ``scroll_output_channels``, ``scroll_reversed``,
    the motor PWM map, ``motor_time_constant_s`` and the terrain do not apply to it.
    """

    max_speed_mps: float = Field(
        4.0, gt=0.0, le=50.0, description="speed at full throttle (m/s; SIM_Rover max_speed)"
    )
    max_accel_mss: float = Field(
        14.0, gt=0.0, le=200.0, description="acceleration per unit speed error (m/s²; max_accel)"
    )
    turn_rate_dps: float = Field(
        140.0, gt=0.0, le=1000.0, description="yaw rate per unit motor difference (°/s)"
    )
    max_yaw_rate_dps: float = Field(
        360.0, gt=0.0, le=1000.0, description="yaw rate limit (°/s; SIM_Rover.h MAX_YAW_RATE)"
    )
    physics_rate_hz: float = Field(
        1200.0, ge=50.0, le=10_000.0, description="integration frames per second (SITL rate_hz)"
    )


class PlantConfig(InputModel):
    """The plant's part of the simulator YAML (:class:`helixd.sim.sim_config.SimConfig` adds
    the autopilot's)."""

    vehicle: VehicleConfig = Field(
        default_factory=VehicleConfig, description="geometry and 195 RPM max"
    )
    plant: Plant = Field(
        Plant.HELIX, description="vehicle model: helix (scrolls) or sitl_skid (SITL rover-skid)"
    )
    skid: SkidModel = Field(default_factory=SkidModel, description="the sitl_skid plant")
    terrain: Terrain = Field(
        Terrain.HARD,
        description="ground under the rover (helix plant); with a media map, the medium "
        "outside every area unless the map names its default_medium",
    )
    media_file: Path | None = Field(
        None,
        description="media map (GeoJSON, helixd.files.media): the world's media by place, "
        "each scroll in the medium under it (helix plant); read when the simulator starts",
    )
    media: InstanceOf[MediaMap] | None = Field(
        None,
        exclude=True,
        description="a media map already read (helixd sim --media, run --sim-media); "
        "not with media_file",
    )
    terrains: TerrainTable = Field(default_factory=TerrainTable)
    bathymetry: InstanceOf[Bathymetry] | None = Field(
        None,
        exclude=True,
        description="the pond's bottom (helixd.files.bathymetry, --sim-bathymetry): the "
        "simulated down-facing sonar (sonar) senses it; None: no sonar",
    )
    sonar: SonarModel = Field(default_factory=SonarModel, description="the down-facing sonar")
    motor_time_constant_s: float = Field(
        0.3, gt=0.001, le=5.0, description="first-order lag of scroll speed to command (s)"
    )
    scroll_output_channels: tuple[int, int, int, int] = Field(
        (1, 2, 3, 4), description="servo output (1..16) read as the speed of scrolls 1..4"
    )
    scroll_reversed: tuple[bool, bool, bool, bool] = Field(
        (False, False, False, False), description="motor of that scroll wired backwards"
    )
    motor_pwm_min_us: int = Field(1000, ge=800, le=2200, description="full reverse (µs)")
    motor_pwm_trim_us: int = Field(1500, ge=800, le=2200, description="stopped (µs)")
    motor_pwm_max_us: int = Field(2000, ge=800, le=2200, description="full forward (µs)")
    motor_deadband_us: int = Field(
        0, ge=0, le=200, description="|PWM − trim| below this: motor stopped (µs)"
    )
    origin_lat_deg: float = Field(53.52325, ge=-90.0, le=90.0, description="EKF origin latitude")
    origin_lon_deg: float = Field(
        -113.52632,
        ge=-180.0,
        le=180.0,
        description="EKF origin longitude (default: the thesis's field)",
    )
    origin_alt_m: float = Field(668.0, ge=-500.0, le=9000.0, description="EKF origin altitude")
    initial_north_m: float = Field(0.0, ge=-10_000.0, le=10_000.0, description="start pose (m)")
    initial_east_m: float = Field(0.0, ge=-10_000.0, le=10_000.0, description="start pose (m)")
    initial_yaw_ned_rad: float = Field(
        0.0, ge=-math.pi, le=math.pi, description="start heading, clockwise from North (rad)"
    )
    obstacles: SimObstacles = Field(
        default_factory=SimObstacles, description="solid shapes the rover stops against"
    )

    @model_validator(mode="after")
    def _check_plant(self) -> PlantConfig:
        if not self.motor_pwm_min_us < self.motor_pwm_trim_us < self.motor_pwm_max_us:
            raise ValueError("need motor_pwm_min_us < motor_pwm_trim_us < motor_pwm_max_us")
        for ch in self.scroll_output_channels:
            if not 1 <= ch <= 16:
                raise ValueError(f"scroll_output_channels must be 1..16, got {ch}")
        if self.media is not None and self.media_file is not None:
            raise ValueError("give media_file or media, not both")
        return self

    def traction(self) -> TerrainTraction:
        return self.terrains.get(self.terrain)

    def motor_map(self) -> MotorMap:
        """The motor controllers' PWM map."""
        pwm_us = (self.motor_pwm_min_us, self.motor_pwm_trim_us, self.motor_pwm_max_us)
        return MotorMap(*pwm_us, deadband_us=self.motor_deadband_us)

    def start_state(self) -> PhysicsState:
        """The plant at rest where the rover starts."""
        return PhysicsState(
            north_m=self.initial_north_m,
            east_m=self.initial_east_m,
            yaw_ned_rad=self.initial_yaw_ned_rad,
        )
