"""The ground under the Helix plant: each medium's traction, digging and power.

The terrain traction table follows published screw-vehicle data where it exists and the
thesis's field tests (ch. 5.3) elsewhere: :data:`DEFAULT_TRACTION`, sources in docs/physics.md.
A ground file (``--sim-ground``, :func:`read_ground_file`) replaces any part of it. Every
tunable has a unit in its name, bounds and a default.
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Any

from pydantic import Field, model_validator

from helixd.base.media import Medium
from helixd.files.models import InputModel, load_yaml_model


class Terrain(StrEnum):
    HARD = "hard"
    GRASS = "grass"
    SAND = "sand"
    MUD = "mud"
    WATER = "water"  # the Helix floats: see TerrainTable.water


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
