"""The pond's bottom and the down-facing sonar that senses it (pure; the generator is passed in).

The bottom is a bathymetry file (:mod:`helixd.files.bathymetry`) placed around the EKF origin
with ArduPilot's flat-earth map; between its nodes the depth is bilinear
(:class:`scipy.interpolate.RegularGridInterpolator`), a cell with a dry (``null``) corner is
dry. That depth is the simulator's *truth*: ``tools/bench_survey.py`` measures helixd's depth
map against it.

The sonar sits at the rover's centre, ``offset_m`` below the surface, facing down. Each
reading, like ArduPilot's rangefinder driver (AP_RangeFinder_Backend::update_status):

* a dropout (probability ``dropout``) is no data: ArduPilot sends no DISTANCE_SENSOR for a
  rangefinder without data (``has_data()`` false);
* otherwise the range is the water under the transducer plus Gaussian noise (``noise_m``),
  sent as measured even outside ``min_m``..``max_m`` (the status is then OutOfRange, the
  message still goes out with the sensor's min and max): over dry ground, the range is 0;
* ``signal_quality_pct`` as ArduPilot's backend reports it (SITL's: unknown, sent as 0).

Sent as ArduPilot sends it (GCS_MAVLINK::send_distance_sensor): DISTANCE_SENSOR in cm, capped
at 65535, orientation PITCH_270, in the EXTRA3 stream; RANGEFINDER (metres) when asked for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import Field, model_validator
from scipy.interpolate import RegularGridInterpolator

from helixd.base.frames import latlon_to_ne
from helixd.files.bathymetry import Bathymetry
from helixd.files.models import InputModel

CM_PER_M = 100.0
UINT16_MAX = 65535


class SonarModel(InputModel):
    """The simulated down-facing sonar (active with a bathymetry)."""

    noise_m: float = Field(0.025, ge=0.0, le=5.0, description="1σ range noise (m)")
    min_m: float = Field(0.2, ge=0.0, le=100.0, description="minimum range (m)")
    max_m: float = Field(30.0, gt=0.0, le=655.0, description="maximum range (m)")
    dropout: float = Field(
        0.02, ge=0.0, le=1.0, description="share of readings with no data (none sent)"
    )
    offset_m: float = Field(
        0.0, ge=0.0, le=5.0, description="the transducer's depth below the surface (m)"
    )
    signal_quality_pct: int = Field(
        0, ge=0, le=100, description="DISTANCE_SENSOR signal_quality sent (0 = unknown)"
    )
    named_value: str = Field(
        "WTEMP",
        pattern=r"^[\x21-\x7e]{0,10}$",
        description="a payload's NAMED_VALUE_FLOAT over water: the water temperature (°C, "
        "colder deeper), sent at named_value_rate_hz; empty: none",
    )
    named_value_rate_hz: float = Field(1.0, gt=0.0, le=50.0, description="its rate (Hz)")

    @model_validator(mode="after")
    def _range(self) -> SonarModel:
        if self.min_m >= self.max_m:
            raise ValueError(f"min_m {self.min_m} must be < max_m {self.max_m}")
        return self


@dataclass(frozen=True, slots=True)
class SonarReading:
    distance_m: float
    min_m: float
    max_m: float
    quality_pct: int

    def cm(self) -> tuple[int, int, int]:
        """(current, min, max) in cm as DISTANCE_SENSOR carries them (capped at 65535)."""

        def c(m: float) -> int:
            return min(UINT16_MAX, max(0, round(m * CM_PER_M)))

        return c(self.distance_m), c(self.min_m), c(self.max_m)


class BathymetryNe:
    """A bathymetry placed around the EKF origin: the true depth at (north, east)."""

    def __init__(self, bathy: Bathymetry, origin_lat_deg: float, origin_lon_deg: float) -> None:
        sw = bathy.south_west
        self.north0_m, self.east0_m = latlon_to_ne(
            sw.lat_deg, sw.lon_deg, origin_lat_deg, origin_lon_deg
        )
        rows, cols = bathy.shape
        self.cell_m = bathy.cell_m
        self.north_m = self.north0_m + bathy.cell_m * np.arange(rows)
        self.east_m = self.east0_m + bathy.cell_m * np.arange(cols)
        grid = np.array(
            [[math.nan if d is None else d for d in row] for row in bathy.depth_m], dtype=float
        )
        self.grid_m = grid
        self._interp = RegularGridInterpolator(
            (self.north_m, self.east_m),
            grid,
            method="linear",
            bounds_error=False,
            fill_value=math.nan,
        )

    def depth_at(self, north_m: float, east_m: float) -> float | None:
        """The water's depth here (m), None where it is dry or off the grid."""
        if not (math.isfinite(north_m) and math.isfinite(east_m)):
            return None
        d = float(self._interp((north_m, east_m)))
        return d if math.isfinite(d) else None

    def depths_at(self, north_m: np.ndarray, east_m: np.ndarray) -> np.ndarray:
        """:meth:`depth_at` over arrays (NaN: dry or off the grid)."""
        pts = np.column_stack([np.ravel(north_m), np.ravel(east_m)])
        out: np.ndarray = self._interp(pts).reshape(np.shape(north_m))
        return out


def sense(
    depth_m: float | None, model: SonarModel, rng: np.random.Generator
) -> SonarReading | None:
    """One sonar reading over water ``depth_m`` deep (None: dry); None: a dropout."""
    if model.dropout > 0.0 and rng.random() < model.dropout:
        return None
    water = 0.0 if depth_m is None else max(0.0, depth_m - model.offset_m)
    noise = rng.normal(0.0, model.noise_m) if model.noise_m > 0.0 and water > 0.0 else 0.0
    return SonarReading(max(0.0, water + noise), model.min_m, model.max_m, model.signal_quality_pct)


def water_temperature_c(depth_m: float, rng: np.random.Generator) -> float:
    """The payload's named value over water: 18 °C at the surface, 1.5 °C colder per metre,
    0.05 °C noise."""
    return 18.0 - 1.5 * depth_m + float(rng.normal(0.0, 0.05))
