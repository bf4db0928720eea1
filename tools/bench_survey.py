#!/usr/bin/env python3
"""Benchmark: the pond's depth survey, gridded and measured against the simulator's truth.

One flight of ``config/missions/pond-depth.yaml`` (29 transects 2 m apart over the pond's open
water) by the real ``helixd run --sim`` on the simulated clock (seeded), over a bathymetry
(default ``config/maps/pond-bathymetry.yaml``, ``--bathymetry FILE`` for another), the
simulator's down-facing sonar on (DISTANCE_SENSOR, 0.025 m noise, 2 % dropouts, 0.2..30 m),
pose noise ``low`` (RTK-like: a crew surveys depth with RTK). Then ``survey-map``'s own code
grids the run's ``payload.csv`` over ``config/areas/pond-water.geojson`` and the figures are
measured:

* ``samples``: the depth readings gridded; ``coverage``: the share of the area's cells with a
  reading; ``rms_m`` / ``max_abs_m``: the grid at the covered cells' centres against the
  bathymetry's true depth there (:class:`helixd.plant.sonar.BathymetryNe`);
* ``holes_mission_items``: the waypoints of the holes mission, and ``holes_covered``: every
  uncovered cell's centre within half a cell of its path.

Goals: coverage ≥ 0.95, RMS ≤ 0.05 m, every hole covered; with another bathymetry the same
within 10 %. Writes section ``survey`` of ``DIR/latest.json`` (``--results-dir``).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import typer

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # measure the checkout this tool lives in
    sys.path.insert(0, str(ROOT))
if str(ROOT / "tools") not in sys.path:
    sys.path.insert(0, str(ROOT / "tools"))

from bench_results import RESULTS_DIR, write_section  # noqa: E402

from helixd.base.frames import latlon_to_ne  # noqa: E402
from helixd.commands.survey_map import SurveyMap, build_map  # noqa: E402
from helixd.files.bathymetry import read_bathymetry  # noqa: E402
from helixd.mission.formats.areas import read_area  # noqa: E402
from helixd.planning.depth_grid import cells_passed, grid_errors, hole_waypoints  # noqa: E402
from helixd.plant.sonar import BathymetryNe  # noqa: E402
from helixd.sim.sim_config import SimConfig  # noqa: E402

MISSION = ROOT / "config" / "missions" / "pond-depth.yaml"
MEDIA = ROOT / "config" / "maps" / "pond-media.geojson"
BATHYMETRY = ROOT / "config" / "maps" / "pond-bathymetry.yaml"
AREA = ROOT / "config" / "areas" / "pond-water.geojson"
GOAL_COVERAGE = 0.95
GOAL_RMS_M = 0.05
CELL_M = 2.0


def fly(bathymetry: Path, seed: int, run_root: Path, timeout_s: float) -> tuple[Path, float, int]:
    """The survey flown by ``helixd run --sim`` on the simulated clock; (run dir, wall s, exit)."""
    cmd = [
        sys.executable,
        "-m",
        "helixd",
        "run",
        "--sim",
        "--sim-clock",
        "simulated",
        "--sim-seed",
        str(seed),
        "--sim-noise",
        "low",
        "--sim-media",
        str(MEDIA),
        "--sim-bathymetry",
        str(bathymetry),
        "--mission",
        str(MISSION),
        "--run-dir",
        str(run_root),
        "--log-level",
        "warning",
    ]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, cwd=ROOT)
    wall = time.monotonic() - t0
    runs = sorted(p for p in run_root.iterdir() if p.is_dir())
    if not runs:
        raise RuntimeError(f"no run directory; helixd said:\n{proc.stdout[-2000:]}{proc.stderr}")
    return runs[-1], wall, proc.returncode


def truth_at_cells(m: SurveyMap, bathymetry: Path) -> np.ndarray:
    """The bathymetry's depth at every cell centre (NaN: dry), placed as the simulator does
    (around its EKF origin)."""
    sim = SimConfig()
    bathy = BathymetryNe(read_bathymetry(bathymetry), sim.origin_lat_deg, sim.origin_lon_deg)
    cn, ce = m.grid.frame.centres()
    truth = np.full(cn.shape, np.nan)
    for idx in np.ndindex(cn.shape):
        lat, lon = m.to_latlon(float(cn[idx]), float(ce[idx]))
        n, e = latlon_to_ne(lat, lon, sim.origin_lat_deg, sim.origin_lon_deg)
        d = bathy.depth_at(n, e)
        truth[idx] = np.nan if d is None else d
    return truth


def measure(run_dir: Path, bathymetry: Path, cell_m: float) -> dict[str, Any]:
    m = build_map([run_dir], cell_m=cell_m, area=read_area(AREA))
    rms, max_abs, cells = grid_errors(m.grid, truth_at_cells(m, bathymetry))
    path = hole_waypoints(m.legs)
    holes = m.grid.holes
    passed = cells_passed(m.grid, path, cell_m / 2.0 + 1e-6)
    summary = json.loads((run_dir / "summary.json").read_text())
    return {
        "samples": m.grid.samples,
        "coverage": round(m.grid.coverage, 4),
        "area_cells": int(m.grid.in_area.sum()),
        "holes": int(holes.sum()),
        "rms_m": round(rms, 4),
        "max_abs_m": round(max_abs, 4),
        "cells_compared": cells,
        "holes_mission_items": len(path),
        "holes_covered": bool((passed | ~holes).all()),
        "flight_s": summary.get("duration_s"),
        "completed": summary.get("completed"),
    }


def verdicts(fig: dict[str, Any], reference: bool) -> list[str]:
    slack = 0.0 if reference else 0.1  # another bathymetry: the same within 10 %
    cov_goal, rms_goal = GOAL_COVERAGE * (1.0 - slack), GOAL_RMS_M * (1.0 + slack)
    return [
        f"coverage {fig['coverage']:.3f} >= {cov_goal:.3f}: "
        + ("met" if fig["coverage"] >= cov_goal else "MISSED"),
        f"rms {fig['rms_m']:.4f} m <= {rms_goal:.3f} m: "
        + ("met" if fig["rms_m"] <= rms_goal else "MISSED"),
        f"holes mission ({fig['holes_mission_items']} items) passes every one of "
        f"{fig['holes']} holes: " + ("met" if fig["holes_covered"] else "MISSED"),
    ]


def main(
    bathymetry: Path = typer.Option(BATHYMETRY, help="the pond's bottom (bathymetry YAML)"),  # noqa: B008
    seed: int = typer.Option(1, min=0, help="the simulator's seed"),
    cell_m: float = typer.Option(CELL_M, min=0.5, max=10.0, help="grid cell (m)"),
    timeout_s: float = typer.Option(1800.0, min=10.0, help="wall-time limit of the flight (s)"),
    results_dir: Path = typer.Option(RESULTS_DIR, help="where latest.json/md go"),  # noqa: B008
) -> None:
    reference = bathymetry.resolve() == BATHYMETRY.resolve()
    typer.echo(f"survey: {MISSION.name} over {bathymetry}, seed {seed}, simulated clock")
    with tempfile.TemporaryDirectory(prefix="bench-survey-") as tmp:
        run_dir, wall_s, code = fly(bathymetry, seed, Path(tmp), timeout_s)
        fig = measure(run_dir, bathymetry, cell_m)
    fig.update(
        wall_s=round(wall_s, 1),
        exit_code=code,
        seed=seed,
        cell_m=cell_m,
        bathymetry=bathymetry.name,
        sonar_noise_m=SimConfig().sonar.noise_m,
    )
    lines = verdicts(fig, reference)
    for key in ("samples", "coverage", "rms_m", "max_abs_m", "holes", "holes_mission_items"):
        typer.echo(f"  {key:<20} {fig[key]}")
    for line in lines:
        typer.echo(f"  {line}")
    write_section("survey", {**fig, "verdicts": lines}, results_dir)
    typer.echo(f"results: {results_dir / 'latest.json'}")
    if code != 0 or any("MISSED" in line for line in lines):
        raise typer.Exit(1)


if __name__ == "__main__":
    typer.run(main)
