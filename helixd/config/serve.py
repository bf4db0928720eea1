"""helixd serve, the all-day service (``serve``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import Field, model_validator

from helixd.config.fields import ConfigSection


class ServeConfig(ConfigSection):
    gcs_system_ids: list[Annotated[int, Field(ge=1, le=255)]] = Field(
        default_factory=lambda: [255], min_length=1, max_length=16
    )
    """system ids whose MISSION_START / DO_PAUSE_CONTINUE helixd obeys; any other sender is DENIED.
    255: QGroundControl and Mission Planner"""
    reconnect_initial_s: float = Field(1.0, gt=0.0, le=60.0)
    """first wait before re-opening a link that failed (s)"""
    reconnect_max_s: float = Field(30.0, gt=0.0, le=600.0)
    """the wait doubles after each failed attempt up to this (s)"""
    mission_poll_s: float = Field(10.0, gt=0.0, le=3600.0)
    """while idle, the autopilot's mission is also re-read this often (s): ArduPilot tells only the
    uploading link 'Flight plan received' and MISSION_CURRENT carries no mission id, so a same-size
    upload from the ground station is noticed by this read (or a change of MISSION_CURRENT's item
    count); every start re-reads it anyway and flies the plan it finds if it passes the checks"""
    state_rate_hz: float = Field(1.0, gt=0.0, le=10.0)
    """NAMED_VALUE_INT hx_state is sent on every change and this often (Hz)"""
    idle_pose_rate_hz: float = Field(5.0, ge=0.0, le=100.0)
    """between flights, while disarmed or holding (armed in HOLD), the pose streams
    (LOCAL_POSITION_NED, ATTITUDE) are asked at this rate, and at link.pose_rate_hz's again
    before each flight starts (Hz; never faster than negotiated); 0: the flight's rate all day"""
    tick_s: float = Field(0.1, gt=0.0, le=1.0)
    """the service's idle tick: start switch read, heartbeat fed, timers (s)"""
    switch_stale_s: float = Field(1.5, gt=0.0, le=10.0)
    """the start switch is read only from a live radio: RC_CHANNELS older than this, or ArduPilot's
    radio failsafe, is no reading and vetoes a start (s)"""
    state_file: Path | None = Field(None)
    """where the service records which mission was interrupted where (a JSON file); None:
    serve-state.json under recorder.run_root"""
    target_stale_s: float = Field(1.5, gt=0.0, le=10.0)
    """the autopilot's place to go (POSITION_TARGET_GLOBAL_INT, asked at link.telemetry_rate_hz)
    not renewed for this long is no place: in GUIDED, RTL and SMART_RTL helixd then holds (s)"""
    disarm_when_complete: bool = Field(True)
    """a flight that completes its mission ends disarmed (ArduPilot's AUTO stays armed in HOLD);
    false: it stays armed in HOLD, so Go to location or the next Start Mission needs no new arm.
    Disarmed is the default: between flights nobody drives the rover, and an armed one is a mode
    switch away from moving"""
    same_place_m: float = Field(0.5, ge=0.0, le=10.0)
    """a place the autopilot publishes that moved less than this is the same place; farther, it is
    a new one, driven to on a new leg (m)"""
    mission_file: Path | None = Field(None)
    """for crews without a ground station: fly this mission file (as `helixd run --mission` reads
    it; re-read while idle) instead of the autopilot's mission; None: the autopilot's"""

    @model_validator(mode="after")
    def _backoff_order(self) -> ServeConfig:
        if self.reconnect_max_s < self.reconnect_initial_s:
            raise ValueError(
                f"serve.reconnect_max_s = {self.reconnect_max_s} is below "
                f"serve.reconnect_initial_s = {self.reconnect_initial_s}"
            )
        return self
