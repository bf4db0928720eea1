"""The rover's ground profile: what each medium delivered in each mode, over its runs.

A YAML file (``ground.profile_file``; default ``ground-profile.yaml`` under
``recorder.run_root``) holding, per medium and mode, the sums of the fit of
:mod:`helixd.control.ground_fit` (so runs merge exactly: weighted by the time each taught, the
older faded by ``ground.fade`` per run) and the crew's pins (a fraction set by hand, which wins
over the fit). Read as every file is (strict keys, finite numbers in range, one line per
problem naming the file and the field); written whole and atomically (tmp + rename).

:func:`identify_run` reads a run directory — ``flight.csv`` and ``summary.json``'s EKF origin —
with a media map, so it works on runs recorded on the real rover.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import yaml
from pydantic import Field

from helixd.base.media import MediaMap, Medium
from helixd.base.plan import MotionMode
from helixd.control.ground_fit import (
    AXES,
    AxisSums,
    Cell,
    CellSums,
    GroundFitParams,
    Record,
    identify,
)
from helixd.control.params import VehicleParams
from helixd.files.jsonio import JsonTextError, load_json_text
from helixd.files.models import ConfigFileError, InputModel, load_yaml_model
from helixd.recorder.rows import read_flight_columns

PROFILE_NAME = "ground-profile.yaml"
PROFILE_VERSION = 1
HEADER = (
    "# helixd ground profile: per medium and mode the sums of the fit of what the ground\n"
    '# delivered (docs/physics.md, "Learning the ground"). `helixd ground` shows it;\n'
    "# pin a fraction with `helixd ground --pin MEDIUM/MODE/AXIS=F`, forget it with --reset.\n"
)
BIG = 1e12


class AxisModel(InputModel):
    s_uu: float = Field(0.0, ge=0.0, le=BIG, description="Σ ū² Δt (m²/s)")
    s_uy: float = Field(0.0, ge=-BIG, le=BIG, description="Σ ū·y Δt (m²/s)")
    s_yy: float = Field(0.0, ge=0.0, le=BIG, description="Σ y² Δt (m²/s)")
    seconds: float = Field(0.0, ge=0.0, le=BIG, description="time that taught (s)")
    samples: int = Field(0, ge=0, le=10**12, description="rows that taught")


class CellModel(InputModel):
    medium: Medium
    mode: MotionMode
    roll: AxisModel = Field(default_factory=AxisModel)
    scroll: AxisModel = Field(default_factory=AxisModel)
    yaw: AxisModel = Field(default_factory=AxisModel)
    metres: float = Field(0.0, ge=0.0, le=BIG, description="travelled in it (m)")
    energy_j: float = Field(0.0, ge=0.0, le=BIG, description="spent in it (J)")
    runs: tuple[str, ...] = Field((), max_length=10_000, description="runs it came from")


class PinModel(InputModel):
    medium: Medium
    mode: MotionMode
    axis: str = Field(pattern="^(roll|scroll|yaw)$", description="roll, scroll or yaw")
    fraction: float = Field(gt=0.0, le=1.2, description="the fraction the crew measured (1)")


class ProfileModel(InputModel):
    version: int = Field(PROFILE_VERSION, ge=1, le=PROFILE_VERSION)
    cells: tuple[CellModel, ...] = Field((), max_length=1000)
    pins: tuple[PinModel, ...] = Field((), max_length=1000)


class GroundProfile:
    """The profile in memory: sums per (medium, mode) and the crew's pins."""

    def __init__(
        self,
        cells: Mapping[Cell, CellSums] | None = None,
        pins: Mapping[tuple[Medium, MotionMode, str], float] | None = None,
    ) -> None:
        self.cells: dict[Cell, CellSums] = dict(cells or {})
        self.pins: dict[tuple[Medium, MotionMode, str], float] = dict(pins or {})

    def pins_of(self, cell: Cell) -> dict[str, float]:
        return {axis: v for (m, k, axis), v in self.pins.items() if (m, k) == cell}


def _axis(model: AxisModel) -> AxisSums:
    return AxisSums(model.s_uu, model.s_uy, model.s_yy, model.seconds, model.samples)


def read_profile(path: Path) -> GroundProfile:
    """The profile at ``path`` (an empty one if there is no file); ConfigFileError names the
    problems."""
    if not path.exists():
        return GroundProfile()
    got = load_yaml_model(path, ProfileModel)
    cells: dict[Cell, CellSums] = {}
    for c in got.cells:
        if (c.medium, c.mode) in cells:
            raise ConfigFileError(path, [f"{path}: cells: {c.medium}/{c.mode} given twice"])
        cells[(c.medium, c.mode)] = CellSums(
            _axis(c.roll), _axis(c.scroll), _axis(c.yaw), c.metres, c.energy_j, c.runs
        )
    pins = {(p.medium, p.mode, p.axis): p.fraction for p in got.pins}
    return GroundProfile(cells, pins)


def _axis_data(a: AxisSums) -> dict[str, float | int]:
    return {
        "s_uu": a.s_uu,
        "s_uy": a.s_uy,
        "s_yy": a.s_yy,
        "seconds": a.seconds,
        "samples": a.samples,
    }


def write_profile(path: Path, profile: GroundProfile) -> None:
    """Write ``profile`` to ``path`` whole, atomically (tmp + rename)."""
    cells = [
        {
            "medium": m.value,
            "mode": k.value,
            **{axis: _axis_data(c.axis(axis)) for axis in AXES},
            "metres": c.metres,
            "energy_j": c.energy_j,
            "runs": list(c.runs),
        }
        for (m, k), c in sorted(profile.cells.items())
    ]
    pins = [
        {"medium": m.value, "mode": k.value, "axis": axis, "fraction": v}
        for (m, k, axis), v in sorted(profile.pins.items())
    ]
    text = HEADER + yaml.safe_dump(
        {"version": PROFILE_VERSION, "cells": cells, "pins": pins}, sort_keys=False
    )
    ProfileModel.model_validate(yaml.safe_load(text))  # never write what could not be read
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def run_origin(run_dir: Path) -> tuple[float, float] | None:
    """The EKF origin ``summary.json`` recorded (None: none, or no summary)."""
    path = run_dir / "summary.json"
    try:
        data = load_json_text(path.read_text(encoding="utf-8"), path)
    except (OSError, JsonTextError):
        return None
    origin = data.get("origin_latlon_deg") if isinstance(data, dict) else None
    if isinstance(origin, list) and len(origin) == 2:
        lat, lon = origin
        if isinstance(lat, (int, float)) and isinstance(lon, (int, float)):
            return (float(lat), float(lon))
    return None


def identify_run(
    run_dir: Path,
    media: MediaMap,
    vehicle: VehicleParams,
    params: GroundFitParams = GroundFitParams(),  # noqa: B008 (frozen)
) -> dict[Cell, CellSums]:
    """Per medium and mode, the fit's sums from one run directory's ``flight.csv`` over
    ``media`` (a lat/lon map placed with the run's recorded EKF origin). ValueError: no
    flight.csv, or a lat/lon map and no origin recorded."""
    csv = run_dir / "flight.csv"
    if not csv.is_file():
        raise ValueError(f"{run_dir}: no flight.csv")
    origin = run_origin(run_dir)
    if media.needs_origin and origin is None:
        raise ValueError(f"{run_dir}: a lat/lon media map needs the EKF origin; none recorded")
    placed = media.to_ne(origin)
    c = read_flight_columns(csv)
    if "motion_mode" not in c or len(c.get("t_boot_s", ())) < 2:
        return {}
    armed = c["armed"].astype(bool) if "armed" in c else None
    keep = armed if armed is not None else slice(None)
    rec = Record(
        t_s=c["t_boot_s"][keep].tolist(),
        north_m=c["north_m"][keep].tolist(),
        east_m=c["east_m"][keep].tolist(),
        yaw_ned_rad=c["yaw_ned_rad"][keep].tolist(),
        scrolls=[
            list(row) for row in zip(*(c[f"scroll{i}"][keep] for i in range(1, 5)), strict=True)
        ],
        modes=[str(m) for m in c["motion_mode"][keep]],
    )
    return identify(rec, placed, vehicle, params, run=run_dir.name)


__all__ = [
    "PROFILE_NAME",
    "GroundProfile",
    "identify_run",
    "read_profile",
    "run_origin",
    "write_profile",
]
