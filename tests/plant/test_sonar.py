"""The simulator's pond bottom and down-facing sonar (helixd/plant/sonar.py, sim/core.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helixd.files.bathymetry import Bathymetry
from helixd.plant.plant_config import PlantConfig
from helixd.plant.sonar import BathymetryNe, SonarModel, sense
from tests.support.simcore import command, make_core, of_type, run

ORIGIN = PlantConfig().origin_lat_deg, PlantConfig().origin_lon_deg
SET_MESSAGE_INTERVAL = 511


def flat(depth: float | None = 1.5, dry_corner: bool = False) -> Bathymetry:
    """A 21 × 21 m grid centred on the simulator's EKF origin, ``depth`` everywhere."""
    lat0, lon0 = ORIGIN
    rows = [[depth] * 22 for _ in range(22)]
    if dry_corner:
        rows[0][0] = None
    return Bathymetry.model_validate(
        {
            "format": "helixd-bathymetry/1",
            "south_west": {
                "lat_deg": lat0 - 10.0 / 111_318.8,
                "lon_deg": lon0 - 10.0 / (111_318.8 * math.cos(math.radians(lat0))),
            },
            "cell_m": 1.0,
            "depth_m": rows,
        }
    )


def test_depth_is_bilinear_between_nodes_and_none_where_dry() -> None:
    lat0, lon0 = ORIGIN
    b = Bathymetry.model_validate(
        {
            "format": "helixd-bathymetry/1",
            "south_west": {"lat_deg": lat0, "lon_deg": lon0},
            "cell_m": 2.0,
            "depth_m": [[1.0, 2.0, None], [3.0, 4.0, 5.0]],
        }
    )
    ne = BathymetryNe(b, lat0, lon0)
    assert ne.depth_at(0.0, 0.0) == pytest.approx(1.0, abs=1e-6)
    assert ne.depth_at(1.0, 1.0) == pytest.approx(2.5, abs=1e-6)  # the cell's centre
    assert ne.depth_at(2.0, 1.0) == pytest.approx(3.5, abs=1e-6)
    assert ne.depth_at(0.5, 3.0) is None  # a dry corner: the cell is dry
    assert ne.depth_at(-1.0, 0.0) is None  # off the grid
    assert ne.depth_at(math.nan, 0.0) is None


def test_a_reading_is_the_water_less_the_offset_with_noise_and_dropouts() -> None:
    rng = np.random.default_rng(3)
    model = SonarModel(noise_m=0.025, dropout=0.0, offset_m=0.1)
    got = [sense(2.0, model, rng) for _ in range(2000)]
    dist = np.array([r.distance_m for r in got if r is not None])
    assert dist.mean() == pytest.approx(1.9, abs=0.003)
    assert dist.std() == pytest.approx(0.025, rel=0.1)
    dry = sense(None, model, rng)
    assert dry is not None and dry.distance_m == 0.0  # the ground right under it
    some_drop = SonarModel(dropout=0.3)
    dropped = sum(sense(2.0, some_drop, rng) is None for _ in range(2000))
    assert 500 <= dropped <= 700
    assert sense(800.0, SonarModel(), rng) is not None  # out of range: sent as measured
    assert sense(800.0, SonarModel(), rng).cm()[0] == 65535  # type: ignore[union-attr]


def test_the_simulator_streams_distance_sensor_facing_down_as_ardupilot_does() -> None:
    core = make_core(bathymetry=flat(1.5), sonar={"noise_m": 0.0, "dropout": 0.0})
    run(core, 2.0)
    assert command(core, 0, SET_MESSAGE_INTERVAL, 132, 100_000) == 0  # DISTANCE_SENSOR 10 Hz
    assert command(core, 0, SET_MESSAGE_INTERVAL, 173, 500_000) == 0  # RANGEFINDER 2 Hz
    out = run(core, 2.0)
    ds = of_type(out, "DISTANCE_SENSOR", 0)
    assert 18 <= len(ds) <= 22
    m = ds[-1]
    assert (m.current_distance, m.min_distance, m.max_distance) == (150, 20, 3000)
    assert m.orientation == 25 and m.signal_quality == 0
    assert m.time_boot_ms > 2000
    rf = of_type(out, "RANGEFINDER", 0)
    assert 3 <= len(rf) <= 5 and rf[-1].distance == pytest.approx(1.5)
    nv = of_type(out, "NAMED_VALUE_FLOAT")
    assert nv and nv[-1].name == "WTEMP" and 15.0 < nv[-1].value < 16.5


def test_no_sonar_without_a_bathymetry_and_a_seed_gives_the_same_readings() -> None:
    core = make_core()
    run(core, 2.0)
    assert command(core, 0, SET_MESSAGE_INTERVAL, 132, 100_000) == 0
    assert not of_type(run(core, 1.0), "DISTANCE_SENSOR")

    def readings(seed: int) -> list[int]:
        c = make_core(bathymetry=flat(1.5), seed=seed)
        run(c, 2.0)
        command(c, 0, SET_MESSAGE_INTERVAL, 132, 100_000)
        return [m.current_distance for m in of_type(run(c, 3.0), "DISTANCE_SENSOR", 0)]

    assert readings(4) == readings(4) != readings(5)
