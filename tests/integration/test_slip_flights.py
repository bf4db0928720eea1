"""The slip estimate learns the simulator's traction on grass, and its feed-forward makes the
rover deliver the navigator's speed (from the autopilot's own velocity telemetry)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helixd.base.exitcodes import ExitCode
from helixd.plant.ground import TerrainTable
from helixd.recorder.rows import read_flight_columns
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration

GRASS = TerrainTable().grass  # the simulator's traction: roll 0.9, yaw 0.75


def fly_square_on_grass(tmp_path: Path, enabled: bool) -> dict[str, np.ndarray]:
    tmp_path.mkdir()
    cfg = {"control": {"slip": {"enabled": enabled}}}
    flown = simulated_flight(tmp_path, "square", cfg, terrain="grass", noise="low", seed=3)
    assert flown.code == ExitCode.OK, flown.log[-3000:]
    return read_flight_columns(flown.run_dir() / "flight.csv")


def delivered_ratio(c: dict[str, np.ndarray]) -> float:
    """Median measured speed / navigator's commanded speed while tracking at speed."""
    steady = (c["nav_state"] == "track") & (c["vx_cmd_mps"] >= 0.4)
    assert steady.sum() > 100
    return float(np.median(c["speed_meas_mps"][steady] / c["vx_cmd_mps"][steady]))


def test_slip_estimate_converges_and_feed_forward_restores_speed(tmp_path: Path) -> None:
    on = fly_square_on_grass(tmp_path / "on", enabled=True)
    off = fly_square_on_grass(tmp_path / "off", enabled=False)
    for c in (on, off):  # the estimate is learnt (and logged) either way
        last = slice(len(c["t_boot_s"]) * 3 // 4, None)
        v = float(np.nanmedian(c["slip_vx_frac"][last]))
        w = float(np.nanmedian(c["slip_w_frac"][last]))
        print(
            f"slip estimate v {v:.3f} (sim {GRASS.roll_efficiency}), w {w:.3f} (sim "
            f"{GRASS.yaw_efficiency})"
        )
        assert v == pytest.approx(GRASS.roll_efficiency, abs=0.08)
        assert w == pytest.approx(GRASS.yaw_efficiency, abs=0.12)
        assert float(c["slip_vx_frac"][0]) == 1.0  # the no-slip prior at the start
    ratio_on, ratio_off = delivered_ratio(on), delivered_ratio(off)
    print(f"delivered / commanded speed: feed-forward on {ratio_on:.3f}, off {ratio_off:.3f}")
    assert ratio_off == pytest.approx(GRASS.roll_efficiency, abs=0.06)
    assert ratio_on == pytest.approx(1.0, abs=0.06)
    assert ratio_on > ratio_off + 0.05
