"""The ``flight.csv`` schema: one :class:`FlightRow` per control step.

Units are in the column names. The file starts with one ``#`` comment line documenting units
and frames, then the header row, then one row per step. Floats are written with a fixed number
of decimals (1 mm, 0.1 mrad, 1 ms), booleans as 1/0, NaN as ``nan``.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from operator import attrgetter
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

SCHEMA_VERSION = 2  # 2: slip_vx_frac, slip_vy_frac, slip_w_frac
COMMENT_PREFIX = "#"
CSV_COMMENT = (
    f"# helixd flight.csv v{SCHEMA_VERSION}; one row per control step. "
    "Times: t_boot_s = autopilot time since boot (s), t_mono_s = companion monotonic clock "
    "(wall time, s); they differ under a simulator speed-up. "
    "NED pose: north_m/east_m from the EKF origin, yaw_ned_rad clockwise from North. "
    "Mission frame: x_m/y_m/yaw_rad (start frame: x forward, y left of the start pose; "
    "local_ned/global: x East, y North), yaw counter-clockwise. Errors: distance_error_m, "
    "heading_error_rad (wrapped to (-pi, pi]), cross_track_m (+ left of the leg). PID terms in "
    "output units (m/s for dist_*, rad/s for yaw_*). Commands: body frame, x roll axis, y scroll "
    "axis. scroll1..4: signed fraction of max RPM (scroll ids as thesis Fig. 2). pwm1..4_us: "
    "PWM sent (0 = none); scroll and PWM include the slip feed-forward, vx/vy/wz_cmd do not. "
    "slip_vx_frac/slip_vy_frac/slip_w_frac: estimated fraction of the commanded body velocity "
    "(roll axis, scroll axis, yaw rate) the ground delivers (1 = no slip). mode: the "
    "autopilot's mode; motion_mode: the rover's motion mode flown (roll, scroll, omni); "
    "medium: the media map's medium under the rover's centre (empty: no map). "
    "Booleans 1/0; nan = not available."
)

_MM = "%.3f"  # metres, seconds: 1 mm / 1 ms
_RAD = "%.4f"  # radians: 0.1 mrad
_GAIN = "%.5f"  # PID terms, velocities, fractions


def _f(fmt: str) -> Any:
    return field(metadata={"fmt": fmt})


@dataclass(slots=True)
class FlightRow:
    """One control step as recorded in ``flight.csv`` (field order = column order).

    Not frozen: a frozen dataclass sets each of its 40 fields through object.__setattr__,
    a third of the cost of building, summarising and formatting a row (callgrind)."""

    t_boot_s: float = _f(_MM)
    t_mono_s: float = _f("%.4f")
    north_m: float = _f(_MM)
    east_m: float = _f(_MM)
    yaw_ned_rad: float = _f(_RAD)
    x_m: float = _f(_MM)
    y_m: float = _f(_MM)
    yaw_rad: float = _f(_RAD)
    target_index: int = _f("%d")
    target_x_m: float = _f(_MM)
    target_y_m: float = _f(_MM)
    distance_error_m: float = _f(_MM)
    heading_error_rad: float = _f(_RAD)
    cross_track_m: float = _f(_MM)
    dist_p: float = _f(_GAIN)
    dist_i: float = _f(_GAIN)
    dist_d: float = _f(_GAIN)
    yaw_p: float = _f(_GAIN)
    yaw_i: float = _f(_GAIN)
    yaw_d: float = _f(_GAIN)
    vx_cmd_mps: float = _f(_GAIN)
    vy_cmd_mps: float = _f(_GAIN)
    wz_cmd_radps: float = _f(_GAIN)
    speed_meas_mps: float = _f(_GAIN)
    scroll1: float = _f(_GAIN)
    scroll2: float = _f(_GAIN)
    scroll3: float = _f(_GAIN)
    scroll4: float = _f(_GAIN)
    pwm1_us: int = _f("%d")
    pwm2_us: int = _f("%d")
    pwm3_us: int = _f("%d")
    pwm4_us: int = _f("%d")
    mode: str = _f("%s")
    armed: bool = _f("%d")
    nav_state: str = _f("%s")
    link_ok: bool = _f("%d")
    pose_fresh: bool = _f("%d")
    # schema 2; defaults so writers that predate the slip estimate still build rows
    slip_vx_frac: float = field(default=math.nan, metadata={"fmt": _GAIN})
    slip_vy_frac: float = field(default=math.nan, metadata={"fmt": _GAIN})
    slip_w_frac: float = field(default=math.nan, metadata={"fmt": _GAIN})
    # the motion mode flown (roll, scroll, omni): it follows the medium on a media map
    motion_mode: str = field(default="", metadata={"fmt": "%s"})
    # the media map's medium under the rover's centre ("": no map)
    medium: str = field(default="", metadata={"fmt": "%s"})

    @staticmethod
    def columns() -> tuple[str, ...]:
        return COLUMNS

    @staticmethod
    def csv_header() -> str:
        """The comment line and the header row, newline-terminated, as written to the file."""
        return CSV_COMMENT + "\n" + ",".join(COLUMNS) + "\n"


_FIELDS = dataclasses.fields(FlightRow)
COLUMNS: tuple[str, ...] = tuple(f.name for f in _FIELDS)
COLUMN_TYPES: dict[str, type] = {
    f.name: {"float": float, "int": int, "str": str, "bool": bool}[str(f.type)] for f in _FIELDS
}


class RowFormatter:
    """Formats a FlightRow as one CSV line, fast enough for a 50 Hz loop (one % operation).

    Text fields that need quoting (a comma, quote or newline) take a slower csv-module path.
    """

    def __init__(self) -> None:
        self._fmt = ",".join(str(f.metadata["fmt"]) for f in _FIELDS) + "\n"
        self._values = attrgetter(*COLUMNS)
        self._commas = len(COLUMNS) - 1

    def line(self, row: FlightRow) -> str:
        values = self._values(row)
        text: str = self._fmt % values
        if text.count(",") != self._commas or '"' in text or text.count("\n") != 1:
            text = self._quoted(values)
        return text

    def _quoted(self, values: tuple[Any, ...]) -> str:
        cells = [
            v if isinstance(v, str) else str(f.metadata["fmt"]) % v
            for f, v in zip(_FIELDS, values, strict=True)
        ]
        buf = io.StringIO()
        csv.writer(buf, lineterminator="\n").writerow(cells)
        return buf.getvalue()


Value = float | int | str | bool


def _to_bool(text: str) -> bool:
    return text.strip() not in ("0", "", "false", "False")


def _to_int(text: str) -> int:
    return int(float(text))


def _to_str(text: str) -> str:
    return text


def _converter(column: str) -> Callable[[str], Value]:
    """How a cell of ``column`` is read (a number unless COLUMN_TYPES says otherwise)."""
    kind = COLUMN_TYPES.get(column, float)
    if kind is bool:
        return _to_bool
    if kind is int:
        return _to_int
    if kind is str:
        return _to_str
    return float


def _data_lines(path: Path) -> list[str]:
    with path.open(encoding="utf-8", newline="") as fh:
        return [ln for ln in fh if not ln.startswith(COMMENT_PREFIX)]


def read_flight_csv(path: Path) -> list[dict[str, Value]]:
    """Read ``flight.csv`` into typed dicts, one per row.

    A torn last line (crash or power loss mid-write) and unknown columns from a newer schema are
    tolerated: rows that do not parse are skipped.
    """
    reader = csv.reader(_data_lines(path))
    header = next(reader, None)
    if header is None:
        return []
    rows: list[dict[str, Value]] = []
    readers = [_converter(c) for c in header]  # once per file, not once per cell
    for cells in reader:
        if len(cells) != len(header):
            continue
        try:
            rows.append({c: read(v) for c, read, v in zip(header, readers, cells, strict=True)})
        except ValueError:
            continue
    return rows


def read_flight_columns(path: Path) -> dict[str, npt.NDArray[Any]]:
    """Read ``flight.csv`` column-wise: float64 for numbers, bool, and object for text."""
    rows = read_flight_csv(path)
    names = list(rows[0]) if rows else list(COLUMNS)
    out: dict[str, npt.NDArray[Any]] = {}
    for name in names:
        kind = COLUMN_TYPES.get(name, float)
        values = [r[name] for r in rows]
        if kind is str:
            out[name] = np.array(values, dtype=object)
        elif kind is bool:
            out[name] = np.array(values, dtype=bool)
        else:
            out[name] = np.array(values, dtype=np.float64)
    return out


def nan_row(**overrides: Value) -> FlightRow:
    """A row with every number NaN/0 and text empty, fields in ``overrides`` set (tests, sims)."""
    base: dict[str, Value] = {}
    for name, kind in COLUMN_TYPES.items():
        if kind is float:
            base[name] = math.nan
        elif kind is int:
            base[name] = 0
        elif kind is bool:
            base[name] = False
        else:
            base[name] = ""
    base.update(overrides)
    return FlightRow(**base)  # type: ignore[arg-type]


__all__ = [
    "COLUMNS",
    "CSV_COMMENT",
    "FlightRow",
    "RowFormatter",
    "nan_row",
    "read_flight_columns",
    "read_flight_csv",
]
