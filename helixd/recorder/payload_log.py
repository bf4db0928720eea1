"""``payload.csv``: the sensors' readings recorded where they were taken.

Every reading the autopilot passes on (:mod:`helixd.link.payload_msgs`: a down-facing
rangefinder's DISTANCE_SENSOR, RANGEFINDER, WATER_DEPTH; a payload's NAMED_VALUE_FLOAT) is one
row: the autopilot time of the reading, the pose at that time linearly interpolated between
the two EKF poses (LOCAL_POSITION_NED, as the link accepted them) either side of it, its
lat/lon through the EKF origin (ArduPilot's flat-earth map), the medium there (the flight's
media map) and the autopilot's mode, the quantity, its value and the sensor's signal quality.

A reading waits for the first pose after it (a few tens of ms at the pose rate); at close the
ones still waiting are placed at the last pose if it is within ``payload.pose_max_gap_s``, the
rest are dropped (counted). RANGEFINDER carries no time: it takes the latest autopilot time
the link saw. The placement is pure (:class:`PayloadPlacer`); :class:`PayloadLog` is the shell
that listens on the link and writes the file.
"""

from __future__ import annotations

import contextlib
import csv
import math
from collections import Counter, deque
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np
import numpy.typing as npt
import structlog

from helixd.base.frames import ne_to_latlon
from helixd.base.media import MediaMap, MediaMapNe
from helixd.base.problems import Problems
from helixd.base.run_files import PAYLOAD_FILE
from helixd.config.recorder import PayloadConfig
from helixd.link.connection import Autopilot
from helixd.link.payload_msgs import Reading, payload_readings

log = structlog.get_logger(__name__)

SCHEMA_VERSION = 1
CSV_COMMENT = (
    f"# helixd payload.csv v{SCHEMA_VERSION}; one row per sensor reading. t_boot_s: autopilot "
    "time of the reading (s); north_m/east_m/yaw_ned_rad: the EKF pose at that time, "
    "interpolated between the poses either side (NED from the EKF origin, yaw clockwise from "
    "North); lat_deg/lon_deg: the same place; medium: the media map's there (empty: no map); "
    "mode: the autopilot's; message: the MAVLink message; quantity and value: the reading "
    "as configured (payload.sources: offset and scale applied; the unit in the quantity's "
    "name); quality_pct: DISTANCE_SENSOR signal quality (0 unknown, 2..100; empty: none); "
    "sensor_id: the sensor's instance; raw: the value as sent (m for distances)."
)
COLUMNS = (
    "t_boot_s",
    "north_m",
    "east_m",
    "yaw_ned_rad",
    "lat_deg",
    "lon_deg",
    "medium",
    "mode",
    "message",
    "quantity",
    "value",
    "quality_pct",
    "sensor_id",
    "raw",
)
POSES_KEPT = 256
PENDING_MAX = 1024


@dataclass(frozen=True, slots=True)
class PlacedReading:
    reading: Reading
    t_boot_s: float
    north_m: float
    east_m: float
    yaw_ned_rad: float


class PayloadPlacer:
    """Readings placed at the pose of their autopilot time (pure: no I/O, no clock)."""

    def __init__(self, max_gap_s: float) -> None:
        self.max_gap_s = max_gap_s
        self._poses: deque[tuple[float, float, float, float]] = deque(maxlen=POSES_KEPT)
        self._pending: deque[tuple[float, Reading]] = deque()
        self.dropped = 0  # readings no pose could place

    def pose(
        self, t_s: float, north_m: float, east_m: float, yaw_rad: float
    ) -> list[PlacedReading]:
        """A new EKF pose; the readings it lets be placed (in time order)."""
        if self._poses and t_s <= self._poses[-1][0]:
            if t_s < self._poses[-1][0] - self.max_gap_s:  # the autopilot rebooted
                self._poses.clear()
            else:
                return []
        self._poses.append((t_s, north_m, east_m, yaw_rad))
        out: list[PlacedReading] = []
        while self._pending and self._pending[0][0] <= t_s:
            t, reading = self._pending.popleft()
            placed = self._place(t, reading)
            if placed is None:
                self.dropped += 1
            else:
                out.append(placed)
        return out

    def reading(self, t_s: float, reading: Reading) -> list[PlacedReading]:
        """A reading taken at autopilot time ``t_s``: placed now if a pose at or after it is
        known, else kept for the next pose."""
        if self._poses and t_s <= self._poses[-1][0]:
            placed = self._place(t_s, reading)
            if placed is None:
                self.dropped += 1
                return []
            return [placed]
        if len(self._pending) >= PENDING_MAX:
            self._pending.popleft()
            self.dropped += 1
        self._pending.append((t_s, reading))
        return []

    def flush(self) -> list[PlacedReading]:
        """The readings still waiting, placed at the last pose when it is close enough."""
        out: list[PlacedReading] = []
        while self._pending:
            t, reading = self._pending.popleft()
            last = self._poses[-1] if self._poses else None
            if last is None or t - last[0] > self.max_gap_s:
                self.dropped += 1
                continue
            out.append(PlacedReading(reading, t, last[1], last[2], last[3]))
        return out

    def _place(self, t_s: float, reading: Reading) -> PlacedReading | None:
        times = [p[0] for p in self._poses]
        i = int(np.searchsorted(times, t_s))  # poses[i-1] < t <= poses[i]
        if i >= len(times):
            return None
        if times[i] == t_s:
            _, n, e, y = self._poses[i]
            return PlacedReading(reading, t_s, n, e, y)
        if i == 0 or times[i] - times[i - 1] > self.max_gap_s:
            return None
        a, b = self._poses[i - 1], self._poses[i]
        span = [a[0], b[0]]
        yaw_b = a[3] + math.remainder(b[3] - a[3], math.tau)  # the short way round
        n = float(np.interp(t_s, span, [a[1], b[1]]))
        e = float(np.interp(t_s, span, [a[2], b[2]]))
        y = math.remainder(float(np.interp(t_s, span, [a[3], yaw_b])), math.tau)
        return PlacedReading(reading, t_s, n, e, y)


def _num(value: float, fmt: str) -> str:
    return fmt % value if math.isfinite(value) else "nan"


class PayloadLog:
    """Listens on the link from :meth:`attach` to :meth:`close` and writes ``payload.csv``."""

    def __init__(
        self, ap: Autopilot, cfg: PayloadConfig, path: Path, media: MediaMap | None = None
    ) -> None:
        self._ap = ap
        self._cfg = cfg
        self.path = path
        self._media = media
        self._media_ne: MediaMapNe | None = None
        self.placer = PayloadPlacer(cfg.pose_max_gap_s)
        self.rows = 0
        self.rejected: Counter[str] = Counter()
        self._last_t_ms: int | None = None
        self._fh: IO[str] | None = None
        self._writer: Any = None

    @classmethod
    def attach(
        cls, ap: Autopilot, cfg: PayloadConfig, run_dir: Path, media: MediaMap | None = None
    ) -> PayloadLog | None:
        """Start recording the readings of ``ap`` into ``run_dir``/payload.csv (None: the
        config turns it off, or the file cannot be opened, which is logged)."""
        if not cfg.enabled:
            return None
        plog = cls(ap, cfg, run_dir / PAYLOAD_FILE, media)
        try:
            fh = plog.path.open("w", newline="")
            fh.write(CSV_COMMENT + "\n")
        except OSError as exc:
            log.warning("payload_log_unavailable", path=str(plog.path), error=str(exc))
            return None
        plog._fh = fh
        plog._writer = csv.writer(fh, lineterminator="\n")
        plog._writer.writerow(COLUMNS)
        ap.add_message_listener(plog.on_message)
        return plog

    def on_message(self, msg: Any, rx_s: float) -> None:
        """The link's listener: poses and readings (every field was checked at the edge)."""
        kind = msg.get_type()
        t_ms = getattr(msg, "time_boot_ms", None)
        if isinstance(t_ms, int) and not isinstance(t_ms, bool) and t_ms >= 0:
            self._last_t_ms = t_ms
        if kind == "LOCAL_POSITION_NED":
            pose = self._ap.state.pose
            if pose is not None and pose.time_boot_ms == t_ms:  # the link accepted it
                ned = pose.ned
                self._write(
                    self.placer.pose(
                        pose.time_boot_ms / 1000.0, ned.north_m, ned.east_m, ned.yaw_ned_rad
                    )
                )
            return
        readings, rejected = payload_readings(msg, self._cfg)
        for r in rejected:
            if not self.rejected[r.message]:
                log.info("payload_reading_dropped", message=r.message, reason=r.reason)
            self.rejected[r.message] += 1
        for reading in readings:
            t = reading.time_boot_ms if reading.time_boot_ms is not None else self._last_t_ms
            if t is None:
                self.placer.dropped += 1
                continue
            self._write(self.placer.reading(t / 1000.0, reading))

    def _medium(self, north_m: float, east_m: float) -> str:
        if self._media is None:
            return ""
        if self._media_ne is None:
            origin = self._ap.state.gps_origin
            if origin is None and self._media.needs_origin:
                return ""
            self._media_ne = self._media.to_ne(origin)
        return self._media_ne.medium_at(north_m, east_m).value

    def _write(self, placed: list[PlacedReading]) -> None:
        if not placed or self._writer is None:
            return
        origin = self._ap.state.gps_origin
        mode = self._ap.state.mode
        for p in placed:
            r = p.reading
            lat = lon = math.nan
            if origin is not None and math.isfinite(p.north_m) and math.isfinite(p.east_m):
                lat, lon = ne_to_latlon(p.north_m, p.east_m, *origin)
            try:
                self._writer.writerow(
                    (
                        _num(p.t_boot_s, "%.3f"),
                        _num(p.north_m, "%.3f"),
                        _num(p.east_m, "%.3f"),
                        _num(p.yaw_ned_rad, "%.4f"),
                        _num(lat, "%.8f"),
                        _num(lon, "%.8f"),
                        self._medium(p.north_m, p.east_m),
                        mode,
                        r.message,
                        r.quantity,
                        _num(r.value, "%.4f"),
                        "" if r.quality_pct is None else r.quality_pct,
                        "" if r.sensor_id is None else r.sensor_id,
                        _num(r.raw, "%.4f"),
                    )
                )
            except OSError as exc:
                log.warning("payload_log_cut", path=str(self.path), error=str(exc))
                self._stop_file()
                return
            self.rows += 1
        try:  # a few rows a second: each batch on disk at once (a kill -9 loses none)
            if self._fh is not None:
                self._fh.flush()
        except OSError as exc:
            log.warning("payload_log_cut", path=str(self.path), error=str(exc))
            self._stop_file()

    def _stop_file(self) -> None:
        fh, self._fh, self._writer = self._fh, None, None
        if fh is not None:
            try:
                fh.close()
            except OSError as exc:
                log.warning("payload_log_cut", path=str(self.path), error=str(exc))

    def close(self) -> None:
        """Stop listening, place what waits, close the file; logs the counts."""
        with contextlib.suppress(ValueError):
            self._ap.remove_message_listener(self.on_message)
        self._write(self.placer.flush())
        self._stop_file()
        log.info(
            "payload_log_closed",
            path=str(self.path),
            rows=self.rows,
            unplaced=self.placer.dropped,
            rejected=dict(self.rejected),
        )


class PayloadCsvError(Problems, ValueError):
    """A payload.csv that cannot be read; ``problems`` has one line each (file and line)."""


MAX_PAYLOAD_BYTES = 512 * 1024 * 1024
LAT_MAX_DEG = 90.0
LON_MAX_DEG = 180.0


@dataclass(frozen=True)
class QuantityReadings:
    """One quantity's readings from payload.csv files: where (lat/lon) and the value."""

    lat_deg: npt.NDArray[np.float64]
    lon_deg: npt.NDArray[np.float64]
    value: npt.NDArray[np.float64]
    skipped: int  # rows of that quantity without a place (no origin, nan) or value


def read_payload_quantity(paths: list[Path], quantity: str) -> QuantityReadings:
    """The readings of ``quantity`` in ``paths`` (payload.csv files, read as hostile input:
    the header checked, each number finite and lat/lon on the Earth; rows that are not are
    skipped and counted, a file that is not a payload.csv is a :class:`PayloadCsvError`)."""
    lats: list[float] = []
    lons: list[float] = []
    values: list[float] = []
    skipped = 0
    problems: list[str] = []
    for path in paths:
        try:
            size = path.stat().st_size
            if size > MAX_PAYLOAD_BYTES:
                problems.append(f"{path}: {size} bytes, more than {MAX_PAYLOAD_BYTES}")
                continue
            with path.open(newline="", encoding="utf-8", errors="replace") as fh:
                rows = csv.reader(line for line in fh if not line.startswith("#"))
                header = next(rows, None)
                if header is None or tuple(header) != COLUMNS:
                    problems.append(f"{path}: not a payload.csv v{SCHEMA_VERSION} (header)")
                    continue
                ilat, ilon = COLUMNS.index("lat_deg"), COLUMNS.index("lon_deg")
                iq, iv = COLUMNS.index("quantity"), COLUMNS.index("value")
                for row in rows:
                    if len(row) != len(COLUMNS) or row[iq] != quantity:
                        continue
                    try:
                        lat, lon, v = float(row[ilat]), float(row[ilon]), float(row[iv])
                    except ValueError:
                        skipped += 1
                        continue
                    if not (
                        math.isfinite(v) and abs(lat) <= LAT_MAX_DEG and abs(lon) <= LON_MAX_DEG
                    ):  # NaN compares False
                        skipped += 1
                        continue
                    lats.append(lat)
                    lons.append(lon)
                    values.append(v)
        except OSError as exc:
            problems.append(f"{path}: cannot read: {exc.strerror or exc}")
    if problems:
        raise PayloadCsvError(problems)
    return QuantityReadings(
        np.array(lats, dtype=float), np.array(lons, dtype=float), np.array(values), skipped
    )
