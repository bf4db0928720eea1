"""What a run records and tells the ground station (``recorder``, ``payload``,
``gcs_report``)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, model_validator

from helixd.config.fields import ConfigSection

# ---------------------------------------------------------------------------------------------
# Recorder


class RecorderConfig(ConfigSection):
    run_root: Path = Field(Path("runs"))
    """run directories are created under this"""
    on_write_error: Literal["continue", "refuse"] = Field("continue")
    """disk full / unwritable: keep flying (continue) or refuse to start"""
    flush_interval_s: float = Field(0.5, gt=0.0, le=1.0)
    """flight.csv flushed at least this often (s)"""
    batch_interval_s: float = Field(0.25, gt=0.0, le=1.0)
    """flight.csv rows built in batches this often, off the control path (s)"""
    keep_runs: int = Field(200, ge=1, le=100_000)
    """run directories kept under run_root; the oldest are pruned at the start of a run (count)"""
    keep_bytes: int | None = Field(None, ge=10_000_000, le=10**15)
    """run directories under run_root kept within this total size; the oldest are pruned at the
    start of a run; None: no size limit (bytes)"""


# ---------------------------------------------------------------------------------------------
# Ground-station report (STATUSTEXT / NAMED_VALUE_FLOAT, helixd.report.gcs_report)


class GcsReportConfig(ConfigSection):
    enabled: bool = Field(True)
    """send STATUSTEXT and NAMED_VALUE_FLOAT to the GCS"""
    rate_hz: float = Field(2.0, gt=0.0, le=20.0)
    """STATUSTEXTs per second, long run average (Hz)"""
    burst: int = Field(5, ge=1, le=50)
    """STATUSTEXTs that may go out back to back before rate_hz"""
    queue_max: int = Field(20, ge=1, le=500)
    """texts waiting for the rate limit; faults go first"""
    max_text_chars: int = Field(150, ge=50, le=500)
    """texts go out as lines of up to 50 chars split between words; at most this many chars, a
    longer text ends in '...'"""
    repeat_window_s: float = Field(3.0, ge=0.0, le=600.0)
    """a text the same as one queued this recently is not sent again (s; 0: every text is sent):
    the message pane shows each event once"""
    named_value_rate_hz: float = Field(2.0, gt=0.0, le=50.0)
    """NAMED_VALUE_FLOAT xtrack_m / wp_index rate (Hz)"""
    tick_hz: float = Field(10.0, ge=1.0, le=50.0)
    """how often the daemon's report task sends (Hz)"""
    final_flush_s: float = Field(1.0, ge=0.0, le=5.0)
    """at the end of a run, at most this long (s) to send the last texts"""


# ---------------------------------------------------------------------------------------------
# Payload: the sensors' readings recorded where they were taken (payload.csv)


class PayloadSource(ConfigSection):
    """One message (or one named value) that counts as one quantity in ``payload.csv``."""

    message: Literal["DISTANCE_SENSOR", "RANGEFINDER", "WATER_DEPTH", "NAMED_VALUE_FLOAT"] = Field()
    """the MAVLink message the reading comes in"""
    quantity: str = Field(pattern=r"^[a-z][a-z0-9_]{0,31}$")
    """the quantity's name in payload.csv, its unit in it (e.g. depth_m)"""
    name: str | None = Field(None, pattern=r"^[\x21-\x7e]{1,10}$")
    """NAMED_VALUE_FLOAT only: the value's name (at most 10 printable characters)"""
    sensor_id: int | None = Field(None, ge=0, le=255)
    """DISTANCE_SENSOR / WATER_DEPTH: this instance only"""
    downward_only: bool = Field(True)
    """DISTANCE_SENSOR: only orientation PITCH_270 (facing down), as ArduPilot takes a depth only
    from a down-facing rangefinder"""
    offset_m: float = Field(0.0, ge=-10.0, le=10.0)
    """added to the reading: for a sonar, its transducer's depth below the waterline, so the
    quantity is the depth from the surface (m)"""
    scale: float = Field(1.0, ge=-1e6, le=1e6)
    """the reading × this, then + offset_m"""
    min_value: float = Field(-1e9, ge=-1e9, le=1e9)
    """readings below this are dropped (quantity's unit)"""
    max_value: float = Field(1e9, ge=-1e9, le=1e9)
    """readings above this are dropped (quantity's unit)"""

    @model_validator(mode="after")
    def _named(self) -> PayloadSource:
        if (self.message == "NAMED_VALUE_FLOAT") != (self.name is not None):
            raise ValueError("name is given for NAMED_VALUE_FLOAT sources, and only for them")
        if self.min_value >= self.max_value:
            raise ValueError(f"min_value {self.min_value} must be < max_value {self.max_value}")
        return self


def _default_payload_sources() -> list[PayloadSource]:
    return [PayloadSource(message="DISTANCE_SENSOR", quantity="depth_m")]


class PayloadConfig(ConfigSection):
    """Which of the autopilot's messages are sensor readings, and how they are recorded."""

    enabled: bool = Field(True)
    """write payload.csv (readings where they were taken) in the run"""
    sources: list[PayloadSource] = Field(default_factory=_default_payload_sources, max_length=32)
    """each message (or named value) recorded and the quantity it counts as"""
    record_other_named_values: bool = Field(True)
    """NAMED_VALUE_FLOATs no source names are recorded under their own name (quantity nv_<name>)"""
    min_signal_quality_pct: int = Field(0, ge=0, le=100)
    """DISTANCE_SENSOR readings with a known signal quality below this are dropped (1 = invalid is
    always dropped; 0 = unknown is kept) (%)"""
    pose_max_gap_s: float = Field(1.0, gt=0.0, le=10.0)
    """a reading is placed by interpolating the EKF poses either side of it; poses further apart
    than this (autopilot time) place nothing (s)"""
