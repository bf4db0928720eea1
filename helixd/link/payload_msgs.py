"""The sensors' readings the autopilot passes on, read at the edge (pure: no I/O, no clock).

Which messages count as which quantity is the config's (``payload.sources``,
:class:`helixd.config.recorder.PayloadSource`). What ArduPilot sends (GCS_Common.cpp,
Rover's GCS_MAVLink_Rover.cpp):

* ``DISTANCE_SENSOR`` (``send_distance_sensor``), one per rangefinder instance, in EXTRA3:
  ``current_distance``, ``min_distance`` and ``max_distance`` in cm (capped at 65535),
  ``orientation`` (PITCH_270 = 25 faces down), ``signal_quality`` 0 = unknown, 1 = invalid,
  2..100 %. A reading outside the sensor's own min/max is out of range and dropped, as is a
  quality of 1 or one below ``payload.min_signal_quality_pct``.
* ``RANGEFINDER`` (Rover: the shortest distance of all rangefinders, m; no time of its own).
* ``WATER_DEPTH`` (boats only: FRAME_CLASS 2 with a PITCH_270 rangefinder): ``distance`` (m),
  ``healthy`` (0: dropped).
* ``NAMED_VALUE_FLOAT``: a payload's (a Lua script's) named value; ``name`` is up to 10
  characters, NUL-padded.

Every field is checked once, here: type, finiteness, range. A reading that fails is one
``Rejected`` with the reason, never a row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from helixd.config.recorder import PayloadConfig, PayloadSource

MavMsg = Any


@dataclass(frozen=True, slots=True)
class Reading:
    """One reading as it will be recorded: the quantity's value (offset and scale applied)."""

    message: str
    quantity: str
    value: float
    time_boot_ms: int | None  # the autopilot's time of the reading (None: RANGEFINDER)
    quality_pct: int | None = None  # DISTANCE_SENSOR's signal quality (0 = unknown)
    sensor_id: int | None = None
    raw: float = math.nan  # the value as sent (m for distances)


@dataclass(frozen=True, slots=True)
class Rejected:
    message: str
    reason: str


MSG_DISTANCE_SENSOR = "DISTANCE_SENSOR"
MSG_RANGEFINDER = "RANGEFINDER"
MSG_WATER_DEPTH = "WATER_DEPTH"
MSG_NAMED_VALUE_FLOAT = "NAMED_VALUE_FLOAT"
PAYLOAD_MESSAGES = frozenset(
    {MSG_DISTANCE_SENSOR, MSG_RANGEFINDER, MSG_WATER_DEPTH, MSG_NAMED_VALUE_FLOAT}
)
# the ones a ground station asks for with SET_MESSAGE_INTERVAL (a payload's named values come
# as its script sends them)
PAYLOAD_STREAMS = (MSG_DISTANCE_SENSOR, MSG_RANGEFINDER, MSG_WATER_DEPTH)
MAV_SENSOR_ROTATION_PITCH_270 = 25  # facing down
QUALITY_UNKNOWN = 0
QUALITY_INVALID = 1
CM_PER_M = 100.0
UINT16_MAX = 65535
UINT32_MAX = 4_294_967_295
RANGE_MAX_M = 1000.0  # RANGEFINDER / WATER_DEPTH: beyond this a float is not a distance
NAMED_VALUE_MAX_ABS = 1e12
NAME_CHARS = 10


def _int(value: object, lo: int, hi: int) -> int | None:
    if isinstance(value, bool) or not isinstance(value, int):
        return None
    return value if lo <= value <= hi else None


def _float(value: object) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    out = float(value)
    return out if math.isfinite(out) else None


def _name(value: object) -> str | None:
    if isinstance(value, bytes | bytearray):
        try:
            value = value.decode("ascii")
        except UnicodeDecodeError:
            return None
    if not isinstance(value, str):
        return None
    text = value.split("\x00", 1)[0]
    if not 1 <= len(text) <= NAME_CHARS or not all(0x21 <= ord(c) <= 0x7E for c in text):
        return None
    return text


def _applies(
    src: PayloadSource, message: str, sensor_id: int | None, orientation: int | None
) -> bool:
    if src.message != message:
        return False
    if src.sensor_id is not None and src.sensor_id != sensor_id:
        return False
    return not (
        message == MSG_DISTANCE_SENSOR
        and src.downward_only
        and orientation != MAV_SENSOR_ROTATION_PITCH_270
    )


def _quantities(
    cfg: PayloadConfig, message: str, raw: float, fields: dict[str, Any]
) -> tuple[list[Reading], list[Rejected]]:
    readings: list[Reading] = []
    rejected: list[Rejected] = []
    sensor_id = fields.get("sensor_id")
    for src in cfg.sources:
        if not _applies(src, message, sensor_id, fields.get("orientation")):
            continue
        if src.message == MSG_NAMED_VALUE_FLOAT and src.name != fields.get("name"):
            continue
        value = raw * src.scale + src.offset_m
        if not math.isfinite(value) or not src.min_value <= value <= src.max_value:
            rejected.append(
                Rejected(
                    message,
                    f"{src.quantity} = {value:.6g} outside [{src.min_value:g}, {src.max_value:g}]",
                )
            )
            continue
        readings.append(
            Reading(
                message,
                src.quantity,
                value,
                fields.get("time_boot_ms"),
                fields.get("quality_pct"),
                sensor_id,
                raw,
            )
        )
    return readings, rejected


def _distance_sensor(msg: MavMsg, cfg: PayloadConfig) -> tuple[list[Reading], list[Rejected]]:
    t = _int(getattr(msg, "time_boot_ms", None), 0, UINT32_MAX)
    lo = _int(getattr(msg, "min_distance", None), 0, UINT16_MAX)
    hi = _int(getattr(msg, "max_distance", None), 0, UINT16_MAX)
    cur = _int(getattr(msg, "current_distance", None), 0, UINT16_MAX)
    sid = _int(getattr(msg, "id", None), 0, 255)
    orient = _int(getattr(msg, "orientation", None), 0, 255)
    quality = _int(getattr(msg, "signal_quality", 0), 0, 100)
    if None in (t, lo, hi, cur, sid, orient, quality):
        return [], [
            Rejected(MSG_DISTANCE_SENSOR, "a field is missing, not an integer or out of range")
        ]
    assert cur is not None and lo is not None and hi is not None and quality is not None
    if not lo <= cur <= hi:
        return [], [Rejected(MSG_DISTANCE_SENSOR, f"{cur} cm outside the sensor's [{lo}, {hi}] cm")]
    if quality == QUALITY_INVALID or (
        quality != QUALITY_UNKNOWN and quality < cfg.min_signal_quality_pct
    ):
        return [], [Rejected(MSG_DISTANCE_SENSOR, f"signal quality {quality} %")]
    fields = {"time_boot_ms": t, "quality_pct": quality, "sensor_id": sid, "orientation": orient}
    return _quantities(cfg, MSG_DISTANCE_SENSOR, cur / CM_PER_M, fields)


def _rangefinder(msg: MavMsg, cfg: PayloadConfig) -> tuple[list[Reading], list[Rejected]]:
    dist = _float(getattr(msg, "distance", None))
    if dist is None or not 0.0 <= dist <= RANGE_MAX_M:
        return [], [Rejected(MSG_RANGEFINDER, "distance missing, not finite or out of range")]
    return _quantities(cfg, MSG_RANGEFINDER, dist, {"time_boot_ms": None})


def _water_depth(msg: MavMsg, cfg: PayloadConfig) -> tuple[list[Reading], list[Rejected]]:
    t = _int(getattr(msg, "time_boot_ms", None), 0, UINT32_MAX)
    sid = _int(getattr(msg, "id", None), 0, 255)
    healthy = _int(getattr(msg, "healthy", None), 0, 255)
    dist = _float(getattr(msg, "distance", None))
    if (
        t is None
        or sid is None
        or healthy is None
        or dist is None
        or not 0.0 <= dist <= RANGE_MAX_M
    ):
        return [], [Rejected(MSG_WATER_DEPTH, "a field is missing, not finite or out of range")]
    if not healthy:
        return [], [Rejected(MSG_WATER_DEPTH, "sensor not healthy")]
    return _quantities(cfg, MSG_WATER_DEPTH, dist, {"time_boot_ms": t, "sensor_id": sid})


def _named_value(msg: MavMsg, cfg: PayloadConfig) -> tuple[list[Reading], list[Rejected]]:
    t = _int(getattr(msg, "time_boot_ms", None), 0, UINT32_MAX)
    name = _name(getattr(msg, "name", None))
    value = _float(getattr(msg, "value", None))
    if t is None or name is None or value is None or abs(value) > NAMED_VALUE_MAX_ABS:
        return [], [Rejected(MSG_NAMED_VALUE_FLOAT, "time, name or value missing or not sane")]
    fields: dict[str, Any] = {"time_boot_ms": t, "name": name}
    readings, rejected = _quantities(cfg, MSG_NAMED_VALUE_FLOAT, value, fields)
    named = any(s.message == MSG_NAMED_VALUE_FLOAT and s.name == name for s in cfg.sources)
    if not named and cfg.record_other_named_values:
        quantity = "nv_" + "".join(c if c.isalnum() else "_" for c in name.lower())
        readings.append(Reading(MSG_NAMED_VALUE_FLOAT, quantity, value, t, raw=value))
    return readings, rejected


_PARSERS = {
    MSG_DISTANCE_SENSOR: _distance_sensor,
    MSG_RANGEFINDER: _rangefinder,
    MSG_WATER_DEPTH: _water_depth,
    MSG_NAMED_VALUE_FLOAT: _named_value,
}


def payload_readings(msg: MavMsg, cfg: PayloadConfig) -> tuple[list[Reading], list[Rejected]]:
    """The readings ``msg`` carries under ``cfg`` and the ones it had to drop (and why);
    ``([], [])`` for a message that is not a payload message."""
    try:
        kind = msg.get_type()
    except AttributeError:
        return [], []
    parse = _PARSERS.get(kind)
    if parse is None:
        return [], []
    return parse(msg, cfg)


__all__ = [
    "PAYLOAD_MESSAGES",
    "PAYLOAD_STREAMS",
    "Reading",
    "Rejected",
    "payload_readings",
]
