"""Configuration of the built-in ArduPilot-Rover-compatible simulator (``helixd sim``).

:class:`SimConfig` is the plant's settings (:class:`helixd.plant.plant_config.PlantConfig`:
vehicle, motors, ground, world) and the fake autopilot's: boot and GPS timings, the pose noise
of its estimator, parameters, the guard script, its working directory, the clock and speed-up.
Every tunable has a unit in its name, bounds and a default.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import Any

from pydantic import Field, field_validator, model_validator

from helixd.config.link import LinkConfig
from helixd.files.models import InputModel
from helixd.mav.guard_script import HXG_VERSION, PARAM_DEFAULTS
from helixd.plant.plant_config import PlantConfig
from helixd.sim.firmware.param_store import DEFAULT_PARAMS

# helixd's own MAVLink system id (link.source_system's default)
HELIXD_SYSID = int(LinkConfig.model_fields["source_system"].default)

# The speed-up the command lines accept, the same for `helixd sim --speedup` and `helixd run
# --sim-speedup` (a 50 Hz control loop keeps up to here); benchmarks may run the simulator
# faster in-process (SimConfig.speedup).
SPEEDUP_MIN = 0.1
SPEEDUP_MAX = 20.0


class SimClock(StrEnum):
    """What the built-in simulator and a daemon beside it (``run --sim``) time themselves by."""

    WALL = "wall"  # the wall clock, sped up by ``speedup``: what a crew watches
    SIMULATED = "simulated"  # one simulated clock shared in one loop: as fast as the CPU goes


class NoiseLevel(StrEnum):
    NONE = "none"  # exact pose: for tests that compare numbers
    LOW = "low"  # RTK-like
    THESIS = "thesis"  # dual GPS without RTK: ~1 m position, yaw within ±10° (thesis ch. 5.2)


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


# Each noise level's profile (:class:`NoiseLevel`): exact, RTK-like, and the thesis's dual GPS
# without RTK (ch. 5.2: ~1 m position, yaw within ±10°)
NOISE_PRESETS: dict[str, dict[str, float]] = {
    "none": {
        "pos_sigma_m": 0.0,
        "pos_tau_s": 30.0,
        "pos_white_m": 0.0,
        "yaw_sigma_rad": 0.0,
        "yaw_tau_s": 30.0,
        "vel_white_mps": 0.0,
        "ekf_tau_s": 0.2,
        "variance_base": 0.02,
    },
    "low": {
        "pos_sigma_m": 0.05,
        "pos_tau_s": 30.0,
        "pos_white_m": 0.01,
        "yaw_sigma_rad": math.radians(0.5),
        "yaw_tau_s": 30.0,
        "vel_white_mps": 0.01,
        "ekf_tau_s": 0.2,
        "variance_base": 0.05,
    },
    "thesis": {
        "pos_sigma_m": 0.7,
        "pos_tau_s": 20.0,
        "pos_white_m": 0.2,
        "yaw_sigma_rad": math.radians(4.0),
        "yaw_tau_s": 10.0,
        "vel_white_mps": 0.05,
        "ekf_tau_s": 0.3,
        "variance_base": 0.2,
    },
}


def _preset(level: str) -> Any:
    """A noise level's default :class:`NoiseProfile` (:data:`NOISE_PRESETS`)."""
    return Field(default_factory=lambda: NoiseProfile(**NOISE_PRESETS[level]))


class NoiseProfiles(InputModel):
    none: NoiseProfile = _preset("none")
    low: NoiseProfile = _preset("low")
    thesis: NoiseProfile = _preset("thesis")

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


class SimConfig(PlantConfig):
    """The built-in simulator's settings: the plant's (:class:`PlantConfig`) and the fake
    autopilot's (boot and GPS timings, pose noise, parameters, the guard script, storage)."""

    noise: NoiseLevel = Field(NoiseLevel.THESIS, description="pose noise preset")
    noise_profiles: NoiseProfiles = Field(default_factory=NoiseProfiles)
    seed: int | None = Field(None, ge=0, description="noise RNG seed; None = random")
    speedup: float = Field(
        1.0, gt=0.0, le=100.0, description="sim time runs this many times wall time (SITL's -s)"
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
        for pwm in self.pilot_rc_us:
            if not 800 <= pwm <= 2200:
                raise ValueError(f"pilot_rc_us values must be 800..2200, got {pwm}")
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

    def noise_profile(self) -> NoiseProfile:
        return self.noise_profiles.get(self.noise)
