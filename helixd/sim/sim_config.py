"""Configuration of the built-in ArduPilot-Rover-compatible simulator (``helixd sim``).

Every tunable has a unit in its name, bounds and a default. The terrain traction table follows
published screw-vehicle data where it exists and the thesis's field tests (ch. 5.3) elsewhere:
:data:`DEFAULT_TRACTION`, sources in docs/physics.md. A ground file (``--sim-ground``,
:func:`read_ground_file`) replaces any part of it.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import Any

from pydantic import Field, InstanceOf, field_validator, model_validator

from helixd.base.media import MediaMap, Medium
from helixd.config.link import LinkConfig
from helixd.config.vehicle import VehicleConfig
from helixd.files.bathymetry import Bathymetry
from helixd.files.models import InputModel, load_yaml_model
from helixd.mav.guard_script import HXG_VERSION, PARAM_DEFAULTS
from helixd.plant.collisions import SimObstacles
from helixd.plant.sonar import SonarModel
from helixd.sim.firmware.param_store import DEFAULT_PARAMS

# helixd's own MAVLink system id (link.source_system's default)
HELIXD_SYSID = int(LinkConfig.model_fields["source_system"].default)

# The speed-up the command lines accept, the same for `helixd sim --speedup` and `helixd run
# --sim-speedup` (a 50 Hz control loop keeps up to here); benchmarks may run the simulator
# faster in-process (SimConfig.speedup).
SPEEDUP_MIN = 0.1
SPEEDUP_MAX = 20.0


class Terrain(StrEnum):
    HARD = "hard"
    GRASS = "grass"
    SAND = "sand"
    MUD = "mud"
    WATER = "water"  # the Helix floats: see TerrainTable.water


class Plant(StrEnum):
    HELIX = "helix"  # Helix-25 scrolls, eq. 1, motor lag, terrain slip (physics.py)
    SITL_SKID = "sitl_skid"  # ArduPilot SITL's rover-skid model (skid.py)


class SimClock(StrEnum):
    """What the built-in simulator and a daemon beside it (``run --sim``) time themselves by."""

    WALL = "wall"  # the wall clock, sped up by ``speedup``: what a crew watches
    SIMULATED = "simulated"  # one simulated clock shared in one loop: as fast as the CPU goes


class NoiseLevel(StrEnum):
    NONE = "none"  # exact pose: for tests that compare numbers
    LOW = "low"  # RTK-like
    THESIS = "thesis"  # dual GPS without RTK: ~1 m position, yaw within ±10° (thesis ch. 5.2)


class TerrainTraction(InputModel):
    """How much of the no-slip (eq. 1) body velocity a terrain lets through, per axis, and what
    turning the scrolls costs there (docs/physics.md gives each default its source).

    ``dig_rate_per_m``: pit depth (0..1) gained per metre of slip; a pit scales every axis
    by (1 − depth). ``pit_escape_per_m``: depth lost per metre actually travelled.
    ``power_w``: one scroll's electrical power at its maximum rpm; the power drawn is
    proportional to |rpm| (the thesis: wheel power ∝ wheel rpm), so a scroll that slips spends
    more energy on each metre it delivers.
    """

    roll_efficiency: float = Field(ge=0.0, le=1.0, description="fraction of v_x achieved")
    scroll_efficiency: float = Field(ge=0.0, le=1.0, description="fraction of v_y achieved")
    yaw_efficiency: float = Field(ge=0.0, le=1.0, description="fraction of ω_z achieved")
    dig_rate_per_m: float = Field(ge=0.0, le=10.0, description="pit depth per metre of slip")
    pit_escape_per_m: float = Field(
        ge=0.0, le=10.0, description="pit depth removed per metre travelled (1/m)"
    )
    power_w: float = Field(
        100.0,
        ge=0.0,
        le=10_000.0,
        description="one scroll's power at its max rpm in this medium, ∝ |rpm| (W)",
    )


# The default ground, per medium (docs/physics.md, "The ground table": each number's source,
# and how a speed ratio became a fraction). SCROLL's fractions follow the screw vehicles'
# speeds relative to their best medium (mud and marsh), anchored at mud's 0.85: firm soil
# 0.12 (Marsh Screw Amphibian 1.6 mph against 12.5 mph, Riverine Utility Craft 3.6 kn against
# 25 kn), water 0.62 (RUC 15.7 kn, Amphirol 10 km/h against 12 km/h on mud); dry sand no
# better than firm soil (the Marsh Screw "failed ... especially sand"). ROLL, yaw, digging,
# grass's scroll and the power have no published number: helixd's estimates, shaped by the
# thesis's field tests (ROLL on grass and hard ground as simulated; turning in dry sand dug a
# pit) and by Freeberg 2010 (screws not omnidirectional in water or on pavement).
DEFAULT_TRACTION: dict[str, dict[str, float]] = {
    "hard": {
        "roll_efficiency": 0.95,
        "scroll_efficiency": 0.12,
        "yaw_efficiency": 0.85,
        "dig_rate_per_m": 0.0,
        "pit_escape_per_m": 1.0,
        "power_w": 100.0,
    },
    "grass": {
        "roll_efficiency": 0.9,
        "scroll_efficiency": 0.25,
        "yaw_efficiency": 0.75,
        "dig_rate_per_m": 0.0,
        "pit_escape_per_m": 1.0,
        "power_w": 100.0,
    },
    "sand": {
        "roll_efficiency": 0.6,
        "scroll_efficiency": 0.12,
        "yaw_efficiency": 0.12,
        "dig_rate_per_m": 0.12,
        "pit_escape_per_m": 0.2,
        "power_w": 100.0,
    },
    "mud": {
        "roll_efficiency": 0.3,
        "scroll_efficiency": 0.85,
        "yaw_efficiency": 0.55,
        "dig_rate_per_m": 0.02,
        "pit_escape_per_m": 0.5,
        "power_w": 100.0,
    },
    # afloat: no ground to roll on (a floating screw's roll barely moves it), the screws'
    # threads propel along the scroll axis like a screw propeller, differential scroll speed
    # turns it; nothing to dig
    "water": {
        "roll_efficiency": 0.05,
        "scroll_efficiency": 0.62,
        "yaw_efficiency": 0.4,
        "dig_rate_per_m": 0.0,
        "pit_escape_per_m": 1.0,
        "power_w": 100.0,
    },
}


def _traction(terrain: str) -> Any:
    """A terrain's default :class:`TerrainTraction` (:data:`DEFAULT_TRACTION`)."""
    return Field(default_factory=lambda: TerrainTraction(**DEFAULT_TRACTION[terrain]))


class TerrainTable(InputModel):
    """Each terrain's traction (sourced where a source exists: see docs/physics.md). A row
    given in part keeps the defaults of its other fields (a ground file names only what
    differs: ``mud: {scroll_efficiency: 0.7}``)."""

    hard: TerrainTraction = _traction("hard")
    grass: TerrainTraction = _traction("grass")
    sand: TerrainTraction = _traction("sand")
    mud: TerrainTraction = _traction("mud")
    water: TerrainTraction = _traction("water")

    @model_validator(mode="before")
    @classmethod
    def _rows_over_defaults(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        out = dict(data)
        for key, row in data.items():
            if isinstance(row, dict) and key in DEFAULT_TRACTION:
                out[key] = {**DEFAULT_TRACTION[key], **row}
        return out

    def get(self, terrain: Terrain | Medium) -> TerrainTraction:
        traction: TerrainTraction = getattr(self, Terrain(terrain.value).value)
        return traction


def read_ground_file(path: Path | str) -> TerrainTable:
    """A ground file (``--sim-ground``): YAML keyed by medium (``hard``, ``grass``, ``sand``,
    ``mud``, ``water``), each a mapping of :class:`TerrainTraction` fields; a medium or a field
    left out keeps its default (:data:`DEFAULT_TRACTION`). Hostile input: unknown media or
    fields, non-numbers, NaN/±inf and values out of range are refused, each problem one line
    naming the file, the field and the allowed range (:class:`ConfigFileError`)."""
    return load_yaml_model(path, TerrainTable)


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


class NoiseProfile(InputModel):
    """GPS/EKF error model: Gauss–Markov drift plus white jitter, smoothed by the 'EKF'."""

    pos_sigma_m: float = Field(ge=0.0, le=20.0, description="1σ of the slow position error (m)")
    pos_tau_s: float = Field(gt=0.0, le=3600.0, description="correlation time of it (s)")
    pos_white_m: float = Field(ge=0.0, le=5.0, description="1σ white jitter per fix (m)")
    yaw_sigma_rad: float = Field(ge=0.0, le=1.0, description="1σ of the slow yaw error (rad)")
    yaw_tau_s: float = Field(gt=0.0, le=3600.0, description="correlation time of it (s)")
    vel_white_mps: float = Field(ge=0.0, le=2.0, description="1σ velocity jitter (m/s)")
    ekf_tau_s: float = Field(gt=0.0, le=10.0, description="EKF smoothing time constant (s)")
    variance_base: float = Field(
        ge=0.0, le=0.5, description="EKF_STATUS_REPORT test ratio when healthy (0..1)"
    )


class NoiseProfiles(InputModel):
    none: NoiseProfile = Field(
        default_factory=lambda: NoiseProfile(
            pos_sigma_m=0.0,
            pos_tau_s=30.0,
            pos_white_m=0.0,
            yaw_sigma_rad=0.0,
            yaw_tau_s=30.0,
            vel_white_mps=0.0,
            ekf_tau_s=0.2,
            variance_base=0.02,
        )
    )
    low: NoiseProfile = Field(
        default_factory=lambda: NoiseProfile(
            pos_sigma_m=0.05,
            pos_tau_s=30.0,
            pos_white_m=0.01,
            yaw_sigma_rad=math.radians(0.5),
            yaw_tau_s=30.0,
            vel_white_mps=0.01,
            ekf_tau_s=0.2,
            variance_base=0.05,
        )
    )
    thesis: NoiseProfile = Field(
        default_factory=lambda: NoiseProfile(
            pos_sigma_m=0.7,
            pos_tau_s=20.0,
            pos_white_m=0.2,
            yaw_sigma_rad=math.radians(4.0),
            yaw_tau_s=10.0,
            vel_white_mps=0.05,
            ekf_tau_s=0.3,
            variance_base=0.2,
        )
    )

    def get(self, level: NoiseLevel) -> NoiseProfile:
        profile: NoiseProfile = getattr(self, level.value)
        return profile


def _helix_params() -> dict[str, float]:
    """The Helix-25 setup on top of ArduPilot Rover's defaults (see params.py).

    It includes the README's recommended setup for helixd, so that ``helixd run --sim``,
    ``make demo`` and ``helixd sim`` start configured as a real vehicle should be (a
    preflight warning there then means something): helixd's system id is the GCS id
    (MAV_GCS_SYSID; ArduPilot's default 255 is the ground stations'), and the GCS failsafe
    is on with HOLD as its action; the radio failsafe reads a channel helixd does not override.
    Tests of raw ArduPilot defaults pass ``params`` explicitly.
    """
    return {
        "MAV_GCS_SYSID": float(HELIXD_SYSID),
        "FS_GCS_ENABLE": 1.0,
        "FS_ACTION": 2.0,  # HOLD
        "MODE6": 4.0,  # pilot's mode switch high = HOLD (ArduPilot default: all MANUAL)
        # ArduPilot's throttle channel on one helixd does not override (5, not 3), so that its
        # radio failsafe still sees the receiver's low-throttle failsafe (960: above the 950
        # µs the receiver sends then) while helixd drives
        "RCMAP_THROTTLE": 5.0,
        "FS_THR_VALUE": 960.0,
        "SERVO1_MIN": 1000.0,
        "SERVO1_MAX": 2000.0,
        "SERVO2_MIN": 1000.0,
        "SERVO2_MAX": 2000.0,
        "SERVO3_MIN": 1000.0,
        "SERVO3_MAX": 2000.0,
        "SERVO4_MIN": 1000.0,
        "SERVO4_MAX": 2000.0,
    }


class SimConfig(InputModel):
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
    noise: NoiseLevel = Field(NoiseLevel.THESIS, description="pose noise preset")
    noise_profiles: NoiseProfiles = Field(default_factory=NoiseProfiles)
    seed: int | None = Field(None, ge=0, description="noise RNG seed; None = random")
    speedup: float = Field(
        1.0, gt=0.0, le=100.0, description="sim time runs this many times wall time (SITL's -s)"
    )
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
    boot_duration_s: float = Field(
        2.0, ge=0.0, le=120.0, description="HEARTBEAT custom_mode 16 (INITIALISING) this long (s)"
    )
    reboot_silent_s: float = Field(
        1.5, ge=0.0, le=60.0, description="no MAVLink at all after a reboot, before booting (s)"
    )
    gps_loss_report_s: float = Field(
        0.4,
        ge=0.0,
        le=10.0,
        description="after a gps_loss, GPS_RAW_INT reports no fix (ArduPilot SITL, "
        "SIM_GPS1_ENABLE 0: 0.4 s) (s)",
    )
    gps_receiver_timeout_s: float = Field(
        4.0,
        ge=0.0,
        le=60.0,
        description="after a gps_receiver_silent, GPS_RAW_INT repeats the last fix this long "
        "before it says no GPS (ArduPilot's GPS driver timeout: 4 s) (s)",
    )
    gps_dead_reckon_s: float = Field(
        7.3,
        ge=0.0,
        le=60.0,
        description="after a gps_loss, the EKF keeps its horizontal position this long on dead "
        "reckoning before it drops it (ArduPilot SITL, Rover: 7.3 s) (s)",
    )
    ekf_origin_delay_s: float = Field(
        3.0, ge=0.0, le=600.0, description="after boot: EKF origin set, pose streams start (s)"
    )
    home_delay_s: float | None = Field(
        0.0,
        ge=0.0,
        le=600.0,
        description="after the EKF origin: home set, announced ('Set HOME to …', "
        "HOME_POSITION) (s); ArduPilot Rover sets it from the EKF's first position, in the "
        "same loop (0). Before it arming is refused: 'PreArm: AHRS: waiting for home'. "
        "None = never (only force-arm works)",
    )
    prearm_delay_s: float | None = Field(
        0.0,
        ge=0.0,
        le=3600.0,
        description="after boot: the PreArm checks other than home pass (s); before, arming is "
        "refused with 'PreArm: AHRS: EKF3 still initialising'. None = never (only force-arm "
        "works, as observed in a per-scroll passthrough setup)",
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
    default_stream_rate_hz: float = Field(
        1.0, ge=0.0, le=50.0, description="SRn_* rate of every stream until a GCS asks (Hz)"
    )
    pilot_rc_us: tuple[int, ...] = Field(
        (1500,) * 16, min_length=16, max_length=16, description="pilot radio channels 1..16 (µs)"
    )
    params: dict[str, float] = Field(
        default_factory=_helix_params,
        description="parameter values over the Helix setup and ArduPilot Rover's defaults "
        "(names must exist; given values are merged over the Helix setup, not instead of it)",
    )
    history_max_entries: int = Field(
        200_000, ge=100, le=10_000_000, description="oldest history entries dropped beyond this"
    )
    obstacles: SimObstacles = Field(
        default_factory=SimObstacles, description="solid shapes the rover stops against"
    )
    workdir: Path | None = Field(
        None,
        description="the autopilot's working directory (SITL's): MAVLink FTP serves it, its "
        "scripts/ holds the Lua scripts loaded at boot and helixd-sim-params.json the "
        "parameters set (SITL's eeprom.bin), both kept across restarts; None = a temporary "
        "directory made for the run and removed when the simulator stops",
    )
    guard_installed: bool = Field(
        False,
        description="helixd-guard.lua written into scripts/ and SCR_ENABLE 1 at start, as after "
        "`helixd autopilot install-guard` and a reboot",
    )
    guard_params: dict[str, float] = Field(
        default_factory=dict,
        description="HXG_* values in the autopilot's storage (the script's defaults otherwise; "
        "ArduPilot takes them from storage only, never from --defaults files)",
    )

    @field_validator("params", mode="after")
    @classmethod
    def _over_helix_setup(cls, value: dict[str, float]) -> dict[str, float]:
        return {**_helix_params(), **value}

    @model_validator(mode="after")
    def _check(self) -> SimConfig:
        if not self.motor_pwm_min_us < self.motor_pwm_trim_us < self.motor_pwm_max_us:
            raise ValueError("need motor_pwm_min_us < motor_pwm_trim_us < motor_pwm_max_us")
        for ch in self.scroll_output_channels:
            if not 1 <= ch <= 16:
                raise ValueError(f"scroll_output_channels must be 1..16, got {ch}")
        for pwm in self.pilot_rc_us:
            if not 800 <= pwm <= 2200:
                raise ValueError(f"pilot_rc_us values must be 800..2200, got {pwm}")
        if self.media is not None and self.media_file is not None:
            raise ValueError("give media_file or media, not both")
        unknown = sorted(set(self.params) - set(DEFAULT_PARAMS))
        if unknown:
            raise ValueError(f"unknown parameter names in params: {', '.join(unknown)}")
        settable = set(PARAM_DEFAULTS) - {HXG_VERSION}
        unknown = sorted(set(self.guard_params) - settable)
        if unknown:
            raise ValueError(
                f"guard_params takes {', '.join(sorted(settable))}; not {', '.join(unknown)}"
            )
        return self

    def traction(self) -> TerrainTraction:
        return self.terrains.get(self.terrain)

    def noise_profile(self) -> NoiseProfile:
        return self.noise_profiles.get(self.noise)
