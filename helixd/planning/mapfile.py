"""ROS map_server maps (``map_saver`` output: a YAML beside a PGM or PNG), read as hostile input.

YAML keys (all checked once here, unknown keys refused): ``image`` (a file inside the YAML's own
folder), ``resolution`` (m/pixel), ``origin`` ([x, y, yaw] of the lower-left pixel; yaw must be
0), ``occupied_thresh``, ``free_thresh``, ``negate`` (0/1), ``mode`` (trinary | scale | raw,
default trinary). Pixel occupancy as map_server computes it: p = (255 − v)/255, or v/255 when
negate; p > occupied_thresh is occupied, p < free_thresh is free, anything between is unknown.
``raw`` mode reads v as a percentage (0 free … 100 occupied). **Unknown counts as blocked**:
the rover must not plan through what the map has not seen.

Frames: ROS maps are ENU (REP 103): x east, y north. The map frame is taken to share the EKF
origin, so east_m = x and north_m = y; image row 0 is the northern edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image, UnidentifiedImageError

from helixd.files.yamlio import YamlFileError, clip, load_yaml_file
from helixd.planning.grid import GridFrame

MAX_MAP_YAML_BYTES = 64 * 1024
MAX_IMAGE_BYTES = 256 * 1024 * 1024
MIN_RESOLUTION_M = 0.005
MAX_RESOLUTION_M = 10.0
MAX_ORIGIN_M = 100_000.0
_KEYS = {"image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode"}
_MODES = {"1", "L", "LA", "P", "RGB", "RGBA"}
_FORMATS = {"PPM": "PGM", "PNG": "PNG"}  # Pillow names PGM files "PPM"


class MapFileError(ValueError):
    """The map cannot be used; the message names the file and the field."""


@dataclass(frozen=True)
class OccupancyMap:
    frame: GridFrame
    blocked: npt.NDArray[Any]  # bool [row (north), col (east)]: occupied or unknown
    source: Path
    # bool [row, col]: occupied only (what is solid: the simulator's walls); None = as blocked
    occupied: npt.NDArray[Any] | None = None

    @property
    def solid(self) -> npt.NDArray[Any]:
        return self.blocked if self.occupied is None else self.occupied


def _number(doc: dict[str, Any], key: str, path: Path, lo: float, hi: float) -> float:
    value = doc.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MapFileError(f"{path}: {key}: {clip(value)} is not a number (allowed: {lo}..{hi})")
    f = float(value)
    if not (math.isfinite(f) and lo <= f <= hi):
        raise MapFileError(f"{path}: {key}: {clip(value)} out of range (allowed: {lo}..{hi})")
    return f


def _image_path(doc: dict[str, Any], path: Path) -> Path:
    name = doc.get("image")
    if not isinstance(name, str) or not name.strip() or "\x00" in name:
        raise MapFileError(f"{path}: image: {clip(name)} is not a file name")
    folder = path.resolve().parent
    target = (folder / name).resolve()
    if not target.is_relative_to(folder):
        raise MapFileError(
            f"{path}: image: {clip(name)} points outside the map's folder {folder} (refused)"
        )
    if not target.is_file():
        raise MapFileError(f"{path}: image: {clip(name)}: no such file {target}")
    return target


def _occupancy(
    pixels: npt.NDArray[Any], mode: str, negate: bool, occupied: float, free: float
) -> npt.NDArray[Any]:
    """Blocked mask (occupied or unknown) in image orientation."""
    if mode == "raw":
        value = pixels.astype(np.float64)
        return ~(value < free * 100.0)
    p = (pixels.astype(np.float64) / 255.0) if negate else (255.0 - pixels) / 255.0
    return ~(p < free)  # occupied (p > occupied_thresh) and unknown are both blocked


def _occupied_only(
    pixels: npt.NDArray[Any], mode: str, negate: bool, occupied: float
) -> npt.NDArray[Any]:
    """Occupied mask (unknown excluded) in image orientation."""
    if mode == "raw":
        return np.asarray(pixels.astype(np.float64) > occupied * 100.0)
    p = (pixels.astype(np.float64) / 255.0) if negate else (255.0 - pixels) / 255.0
    return np.asarray(p > occupied)


def load_map(path: Path | str, max_cells: int) -> OccupancyMap:
    """Read a map_server YAML and its image; raise :class:`MapFileError` naming file and field."""
    p = Path(path)
    try:
        doc = load_yaml_file(p, MAX_MAP_YAML_BYTES)
    except YamlFileError as exc:
        raise MapFileError(exc.message) from None
    if not isinstance(doc, dict):
        raise MapFileError(f"{p}: not a map_server YAML mapping (image, resolution, origin, …)")
    unknown = sorted(str(k) for k in doc if k not in _KEYS)
    if unknown:
        raise MapFileError(f"{p}: unknown key(s) {clip(unknown)} (allowed: {sorted(_KEYS)})")
    for key in ("image", "resolution", "origin"):
        if key not in doc:
            raise MapFileError(f"{p}: {key}: missing (map_server needs it)")
    res = _number(doc, "resolution", p, MIN_RESOLUTION_M, MAX_RESOLUTION_M)
    origin = doc["origin"]
    if not isinstance(origin, list) or len(origin) != 3:
        raise MapFileError(f"{p}: origin: {clip(origin)} is not [x, y, yaw]")
    ox = _number({"origin[0]": origin[0]}, "origin[0]", p, -MAX_ORIGIN_M, MAX_ORIGIN_M)
    oy = _number({"origin[1]": origin[1]}, "origin[1]", p, -MAX_ORIGIN_M, MAX_ORIGIN_M)
    yaw = _number({"origin[2]": origin[2]}, "origin[2]", p, -math.pi, math.pi)
    if abs(yaw) > 1e-9:
        raise MapFileError(f"{p}: origin[2]: yaw {yaw} rad; rotated maps are not supported (0)")
    occupied = _number({**{"occupied_thresh": 0.65}, **doc}, "occupied_thresh", p, 0.0, 1.0)
    free = _number({**{"free_thresh": 0.196}, **doc}, "free_thresh", p, 0.0, 1.0)
    if not free < occupied:
        raise MapFileError(f"{p}: free_thresh {free} must be < occupied_thresh {occupied}")
    negate = doc.get("negate", 0)
    if negate not in (0, 1) or (not isinstance(negate, bool | int)):
        raise MapFileError(f"{p}: negate: {clip(negate)} (allowed: 0 or 1)")
    mode = doc.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise MapFileError(f"{p}: mode: {clip(mode)} (allowed: trinary, scale, raw)")
    image = _image_path(doc, p)
    if image.stat().st_size > MAX_IMAGE_BYTES:
        raise MapFileError(f"{p}: image: {image} is larger than {MAX_IMAGE_BYTES >> 20} MB")
    try:
        with Image.open(image) as img:
            if img.format not in _FORMATS:
                raise MapFileError(f"{p}: image: {image.name} is {img.format}, allowed: PGM or PNG")
            width, height = img.size
            if width < 1 or height < 1 or width * height > max_cells:
                raise MapFileError(
                    f"{p}: image: {width} × {height} pixels; allowed 1..{max_cells} cells "
                    "(planning.max_cells)"
                )
            if img.mode not in _MODES:
                raise MapFileError(
                    f"{p}: image: {image.name} has pixel mode {img.mode}; allowed 8-bit: "
                    f"{', '.join(sorted(_MODES))}"
                )
            img.load()
            pixels = np.asarray(img.convert("L"))  # colour channels averaged, as map_server
    except MapFileError:
        raise
    except (OSError, UnidentifiedImageError, ValueError, Image.DecompressionBombError) as exc:
        raise MapFileError(f"{p}: image: {image.name}: cannot read: {clip(str(exc))}") from None
    if pixels.ndim != 2 or pixels.shape != (height, width):
        raise MapFileError(f"{p}: image: {image.name}: not a single-channel picture")
    blocked = _occupancy(pixels, str(mode), bool(negate), occupied, free)[::-1].copy()
    frame = GridFrame(
        origin_north_m=oy, origin_east_m=ox, resolution_m=res, rows=height, cols=width
    )
    solid = _occupied_only(pixels, str(mode), bool(negate), occupied)[::-1].copy()
    return OccupancyMap(frame=frame, blocked=blocked, source=p, occupied=solid)
