"""Bathymetry files: the depth of the water over a regular grid (the simulator's pond bottom).

The format (YAML, read as hostile input through :func:`helixd.files.models.load_yaml_model`)::

    format: helixd-bathymetry/1
    south_west: {lat_deg: 53.5232994, lon_deg: -113.5263880}   # node [0][0]
    cell_m: 1.0            # node spacing, north and east (m)
    depth_m:               # rows south → north, each row west → east
      - [null, 0.05, 0.12, null]
      - [0.10, 0.40, 0.55, 0.08]

* node ``[i][j]`` lies ``i × cell_m`` north and ``j × cell_m`` east of ``south_west``, placed
  by ArduPilot's flat-earth map (:func:`helixd.base.frames.latlon_to_ne`), the frame of
  LOCAL_POSITION_NED;
* ``depth_m``: metres from the water's surface to the bottom, 0..``MAX_DEPTH_M``; ``null``:
  no water there (dry land); between nodes the depth is bilinear, and a cell with a ``null``
  corner is dry;
* every row has the same length; 2..``MAX_NODES`` nodes a side; unknown keys are errors.

Every problem is one line naming the file and the field (``pond.yaml: depth_m.3.7: ...``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from helixd.files.models import InputModel, load_yaml_model

MAX_NODES = 1000  # a side
MAX_DEPTH_M = 1000.0
FORMAT = "helixd-bathymetry/1"


class LatLon(InputModel):
    lat_deg: float = Field(ge=-85.0, le=85.0, description="latitude (deg)")
    lon_deg: float = Field(ge=-180.0, le=180.0, description="longitude (deg)")


class Bathymetry(InputModel):
    """A bathymetry file, checked (``depth_m[i][j]``: ``None`` = dry)."""

    format: Literal["helixd-bathymetry/1"] = Field(description="the format and its version")
    south_west: LatLon = Field(description="where node [0][0] is")
    cell_m: float = Field(ge=0.05, le=100.0, description="node spacing north and east (m)")
    depth_m: list[list[float | None]] = Field(
        min_length=2,
        max_length=MAX_NODES,
        description="rows south → north of depths west → east (m below the surface; null: dry)",
    )

    @field_validator("depth_m", mode="after")
    @classmethod
    def _depths(cls, rows: list[list[float | None]]) -> list[list[float | None]]:
        width = len(rows[0])
        if not 2 <= width <= MAX_NODES:
            raise ValueError(f"a row has 2..{MAX_NODES} nodes, row 0 has {width}")
        for i, row in enumerate(rows):
            if len(row) != width:
                raise ValueError(f"row {i} has {len(row)} nodes, row 0 has {width}")
            for j, d in enumerate(row):
                if d is not None and not 0.0 <= d <= MAX_DEPTH_M:
                    raise ValueError(f"[{i}][{j}] = {d!r}: a depth is 0..{MAX_DEPTH_M:g} m or null")
        return rows

    @model_validator(mode="after")
    def _some_water(self) -> Bathymetry:
        if all(d is None for row in self.depth_m for d in row):
            raise ValueError("depth_m: every node is null (no water at all)")
        return self

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.depth_m), len(self.depth_m[0])


def read_bathymetry(path: Path | str) -> Bathymetry:
    """Read and check a bathymetry file; :class:`helixd.files.models.ConfigFileError` names
    each problem."""
    return load_yaml_model(path, Bathymetry)
