"""The payload's readings read at the edge: helixd/link/payload_msgs.py."""

from __future__ import annotations

import math
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.recorder import PayloadConfig, PayloadSource
from helixd.link.payload_msgs import payload_readings

DOWN = 25  # MAV_SENSOR_ROTATION_PITCH_270
FORWARD = 0


def distance_sensor(
    cm: int = 150,
    lo: int = 20,
    hi: int = 3000,
    orientation: int = DOWN,
    quality: int = 0,
    t_ms: int = 1000,
    sid: int = 0,
) -> Any:
    return mavlink.MAVLink_distance_sensor_message(
        t_ms, lo, hi, cm, 1, sid, orientation, 0, 0.0, 0.0, [0.0] * 4, quality
    )


def test_a_down_facing_distance_is_a_depth_with_the_sonar_offset() -> None:
    cfg = PayloadConfig(
        sources=[PayloadSource(message="DISTANCE_SENSOR", quantity="depth_m", offset_m=0.12)]
    )
    readings, rejected = payload_readings(distance_sensor(cm=150, quality=80), cfg)
    assert rejected == []
    (r,) = readings
    assert (r.quantity, r.time_boot_ms, r.quality_pct, r.sensor_id) == ("depth_m", 1000, 80, 0)
    assert math.isclose(r.value, 1.62) and math.isclose(r.raw, 1.5)


def test_out_of_range_invalid_or_poor_readings_are_dropped_with_their_reason() -> None:
    cfg = PayloadConfig(min_signal_quality_pct=50)
    for msg, why in (
        (distance_sensor(cm=10, lo=20), "outside the sensor's"),  # below min range
        (distance_sensor(cm=3001, hi=3000), "outside the sensor's"),  # above max range
        (distance_sensor(quality=1), "signal quality 1"),  # 1 = invalid
        (distance_sensor(quality=30), "signal quality 30"),  # known and below the minimum
    ):
        readings, rejected = payload_readings(msg, cfg)
        assert readings == [] and why in rejected[0].reason
    # unknown quality (0) is kept
    assert len(payload_readings(distance_sensor(quality=0), cfg)[0]) == 1


def test_a_forward_rangefinder_is_no_depth_unless_the_source_says_so() -> None:
    assert payload_readings(distance_sensor(orientation=FORWARD), PayloadConfig()) == ([], [])
    any_way = PayloadConfig(
        sources=[PayloadSource(message="DISTANCE_SENSOR", quantity="range_m", downward_only=False)]
    )
    assert [
        r.quantity for r in payload_readings(distance_sensor(orientation=FORWARD), any_way)[0]
    ] == ["range_m"]


def test_rangefinder_water_depth_and_named_values() -> None:
    cfg = PayloadConfig(
        sources=[
            PayloadSource(message="RANGEFINDER", quantity="range_m"),
            PayloadSource(message="WATER_DEPTH", quantity="depth_wd_m"),
            PayloadSource(message="NAMED_VALUE_FLOAT", quantity="ph", name="PH"),
        ]
    )
    (r,), _ = payload_readings(mavlink.MAVLink_rangefinder_message(2.5, 0.0), cfg)
    assert (r.quantity, r.value, r.time_boot_ms) == ("range_m", 2.5, None)
    wd = mavlink.MAVLink_water_depth_message(7, 0, 1, 0, 0, 0.0, 0.0, 0.0, 0.0, 1.75, 12.0)
    (r,), _ = payload_readings(wd, cfg)
    assert (r.quantity, r.value, r.time_boot_ms) == ("depth_wd_m", 1.75, 7)
    unhealthy = mavlink.MAVLink_water_depth_message(7, 0, 0, 0, 0, 0.0, 0.0, 0.0, 0.0, 1.75, 12.0)
    assert payload_readings(unhealthy, cfg)[0] == []
    (r,), _ = payload_readings(mavlink.MAVLink_named_value_float_message(9, b"PH", 7.2), cfg)
    assert r.quantity == "ph" and math.isclose(r.value, 7.2, rel_tol=1e-6)
    # a name no source maps is recorded under its own name (or not, if so configured)
    other = mavlink.MAVLink_named_value_float_message(9, b"TURB-1", 3.0)
    assert [x.quantity for x in payload_readings(other, cfg)[0]] == ["nv_turb_1"]
    quiet = cfg.model_copy(update={"record_other_named_values": False})
    assert payload_readings(other, quiet)[0] == []


def test_hostile_values_are_rejected_never_recorded() -> None:
    cfg = PayloadConfig(
        sources=[
            PayloadSource(message="RANGEFINDER", quantity="range_m"),
            PayloadSource(message="NAMED_VALUE_FLOAT", quantity="x", name="X"),
        ]
    )
    for bad in (math.nan, math.inf, -1.0, 1e9):
        assert payload_readings(mavlink.MAVLink_rangefinder_message(bad, 0.0), cfg)[0] == []
    for bad in (math.nan, -math.inf, 1e30):
        msg = mavlink.MAVLink_named_value_float_message(1, b"X", bad)
        assert payload_readings(msg, cfg)[0] == []
    msg = mavlink.MAVLink_named_value_float_message(1, b"\xff\xfe", 1.0)  # not ASCII
    assert payload_readings(msg, cfg) == ([], [payload_readings(msg, cfg)[1][0]])


def test_source_bounds_drop_readings_outside_them() -> None:
    cfg = PayloadConfig(
        sources=[PayloadSource(message="DISTANCE_SENSOR", quantity="depth_m", max_value=1.0)]
    )
    readings, rejected = payload_readings(distance_sensor(cm=150), cfg)
    assert readings == [] and "outside [" in rejected[0].reason


class _Fake:
    """A message whose fields are whatever hypothesis draws (a hostile or broken peer)."""

    def __init__(self, kind: str, **fields: Any) -> None:
        self._kind = kind
        self.__dict__.update(fields)

    def get_type(self) -> str:
        return self._kind


WILD = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**40), max_value=2**40),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.binary(max_size=12),
)
FIELDS = (
    "time_boot_ms",
    "min_distance",
    "max_distance",
    "current_distance",
    "id",
    "orientation",
    "signal_quality",
    "distance",
    "healthy",
    "name",
    "value",
)
ALL_SOURCES = PayloadConfig(
    sources=[
        PayloadSource(message="DISTANCE_SENSOR", quantity="depth_m", downward_only=False),
        PayloadSource(message="RANGEFINDER", quantity="range_m"),
        PayloadSource(message="WATER_DEPTH", quantity="wd_m"),
        PayloadSource(message="NAMED_VALUE_FLOAT", quantity="x", name="X"),
    ]
)


@settings(max_examples=400, deadline=None)
@given(
    kind=st.sampled_from(["DISTANCE_SENSOR", "RANGEFINDER", "WATER_DEPTH", "NAMED_VALUE_FLOAT"]),
    values=st.fixed_dictionaries({}, optional=dict.fromkeys(FIELDS, WILD)),
)
def test_fuzz_any_field_values_give_finite_readings_or_reasons_never_an_exception(
    kind: str, values: dict[str, Any]
) -> None:
    readings, rejected = payload_readings(_Fake(kind, **values), ALL_SOURCES)
    for r in readings:
        assert math.isfinite(r.value) and math.isfinite(r.raw)
        assert r.time_boot_ms is None or 0 <= r.time_boot_ms <= 2**32 - 1
        assert r.quality_pct is None or 0 <= r.quality_pct <= 100
    assert all(isinstance(x.reason, str) and x.reason for x in rejected)


@settings(max_examples=200, deadline=None)
@given(
    cm=st.integers(0, 65535),
    lo=st.integers(0, 65535),
    hi=st.integers(0, 65535),
    quality=st.integers(0, 100),
)
def test_fuzz_real_distance_sensor_frames_keep_only_in_range_valid_readings(
    cm: int, lo: int, hi: int, quality: int
) -> None:
    # through MAVLink's own packing: what a real autopilot's bytes decode to
    mav = mavlink.MAVLink(None)
    msg = distance_sensor(cm=cm, lo=lo, hi=hi, quality=quality)
    decoded = mav.decode(bytearray(msg.pack(mav)))
    readings, _ = payload_readings(decoded, PayloadConfig())
    kept = lo <= cm <= hi and quality != 1
    assert bool(readings) == kept
    if kept:
        assert math.isclose(readings[0].value, cm / 100.0)
