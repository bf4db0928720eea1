"""The MAVLink link to the autopilot (``link``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import AfterValidator, Field, model_validator

from helixd.config.fields import ConfigSection
from helixd.mav.url import LinkError, parse_link_url


def _valid_link_url(url: str) -> str:
    try:
        parse_link_url(url, 115200)  # form only; the baud is checked with link.baud at open
    except LinkError as exc:
        raise ValueError(str(exc)) from None
    return url


class LinkConfig(ConfigSection):
    url: Annotated[str, AfterValidator(_valid_link_url)] = Field(
        "udpin:0.0.0.0:14550", min_length=1
    )
    """MAVProxy-style connection: /dev/ttyACM0[:baud], udpin:, udpout:, tcp:"""
    baud: int = Field(115200, ge=1200, le=3_000_000)
    """serial baud when url has none"""
    source_system: int = Field(247, ge=1, le=255)
    """our MAVLink sysid; the autopilot's MAV_GCS_SYSID must equal it. 247, not 255 (QGC/Mission
    Planner/MAVProxy), 245 (MAVSDK ground station) or 1 (vehicles, MAVROS): a ground station
    sharing our id would hide a dead helixd from the GCS failsafe and fight its overrides"""
    observer_system: int = Field(248, ge=1, le=255)
    """the sysid of every command that does not fly (status, mission upload/download, the download
    before `run --mission autopilot`): never the GCS id (source_system), and they send no
    HEARTBEAT, RC override or MANUAL_CONTROL, so the autopilot never takes them for its GCS and its
    GCS failsafe never sees them"""
    source_component: int = Field(191, ge=1, le=255)
    """our compid (191 = onboard)"""
    event_loop: Literal["asyncio", "uvloop"] = Field("asyncio")
    """the daemon's event loop: 'asyncio' (the standard loop) or 'uvloop' (pip install
    'helixd[fast]'; falls back to the standard loop, with a warning, when it is not installed).
    Default asyncio: on the whole daemon uvloop measured within noise of it
    (tools/bench_control_loop.py runs both; helixd/runtime/eventloop.py)"""
    target_system: int = Field(1, ge=1, le=255)
    """autopilot sysid"""
    target_component: int = Field(1, ge=0, le=255)
    """autopilot compid"""
    heartbeat_rate_hz: float = Field(5.0, ge=0.2, le=10.0)
    """our HEARTBEAT rate (Hz); helixd-guard stops the rover after HXG_TIMEOUT (0.5 s) without one,
    so keep it >= 2.5 / HXG_TIMEOUT: one lost HEARTBEAT then does not trip the guard (preflight
    checks it)"""
    pose_rate_hz: float = Field(50.0, ge=1.0, le=100.0)
    """LOCAL_POSITION_NED/ATTITUDE rate to ask for (Hz)"""
    telemetry_rate_hz: float = Field(5.0, ge=0.5, le=50.0)
    """EKF/SYS_STATUS/RC/SERVO/MISSION_CURRENT stream rate (Hz)"""
    payload_rate_hz: float = Field(5.0, ge=0.0, le=50.0)
    """DISTANCE_SENSOR, RANGEFINDER and WATER_DEPTH (the payload's readings, payload.csv) asked for
    at this rate, once each, never counted as slow (an autopilot without the sensor sends none); 0:
    not asked (Hz)"""
    autopilot_heartbeat_rate_hz: float = Field(5.0, ge=1.0, le=10.0)
    """the autopilot's HEARTBEAT rate to ask for on helixd's link (Hz; ArduPilot sends 1 Hz unless
    asked, and one at once on a mode change): the arm and the mode are in it, so an arm or a disarm
    is seen within 1 / this rate, not within a second"""
    command_timeout_s: float = Field(1.0, gt=0.0, le=30.0)
    """wait for COMMAND_ACK/PARAM_VALUE per try (s)"""
    command_retries: int = Field(3, ge=0, le=10)
    """re-sends after the first try"""
    reconnect_interval_s: float = Field(1.0, gt=0.0, le=60.0)
    """pause between reopen attempts of a lost link (s)"""
    signing_key_file: Path | None = Field(None)
    """MAVLink2 signing key (32 bytes raw or 64 hex chars); None = unsigned"""
    heartbeat_liveness_s: float = Field(1.5, gt=0.0, le=30.0)
    """our HEARTBEAT stops when feed() was not called for this long (s)"""
    heartbeat_type: Literal["gcs", "onboard_controller"] = Field("gcs")
    """MAV_TYPE of our HEARTBEAT (ArduPilot's GCS failsafe keys on sysid)"""
    vehicle_component: bool = Field(True)
    """also a component (source_component) of the autopilot's system (target_system): a second
    HEARTBEAT (MAV_TYPE_ONBOARD_CONTROLLER) from those ids makes ArduPilot route the commands a
    ground station addresses to that component of the vehicle (QGroundControl's MAVLink Actions) to
    helixd, answered from those ids"""
    pose_rate_min_hz: float = Field(5.0, ge=0.5, le=100.0)
    """stop stepping the pose rate down below this (Hz)"""
    stream_step_factor: float = Field(1.25, gt=1.0, le=4.0)
    """after the autopilot DENIED a message interval, the interval asked for is multiplied by this
    until it grants one (1)"""
    stream_check_window_s: float = Field(2.0, ge=0.2, le=60.0)
    """observed stream rates are checked once per window (s)"""
    stream_slow_fraction: float = Field(0.5, gt=0.0, lt=1.0)
    """a stream observed below this fraction of its granted rate is re-requested"""
    reboot_backstep_s: float = Field(1.0, gt=0.0, le=60.0)
    """autopilot time_boot_ms going back by more than this is a reboot (s)"""
    statustext_history: int = Field(50, ge=1, le=1000)
    """STATUSTEXT messages kept in the vehicle state"""
    statustext_grace_s: float = Field(0.3, ge=0.0, le=5.0)
    """after an ARM refusal, wait this long for its 'PreArm:' STATUSTEXT (s)"""
    tcp_connect_timeout_s: float = Field(5.0, gt=0.0, le=60.0)
    """give up a tcp: connection attempt after (s)"""
    command_settle_s: float = Field(0.02, ge=0.0, le=1.0)
    """quiet gap before re-using a command id; a duplicated ack in it is dropped (s)"""
    statustext_timeout_s: float = Field(2.0, ge=0.1, le=30.0)
    """a chunked STATUSTEXT whose last chunk has not come after this long is logged as it is,
    marked incomplete (s); ArduPilot prunes its queue after 5 s"""
    own_id_watch_s: float = Field(2.2, ge=0.0, le=30.0)
    """preflight listens this long after our first message for another sender on our system id (s);
    ground stations send HEARTBEAT at 1 Hz"""
    mission_item_timeout_s: float = Field(1.5, gt=0.0, le=30.0)
    """mission upload/download: re-send after this long without progress (s); above ArduPilot's own
    1 s re-request"""
    mission_retries: int = Field(5, ge=0, le=50)
    """mission upload/download: re-sends in a row before failing"""
    tlog_enabled: bool = Field(True)
    """write the link's .tlog in the run directory"""
    tlog_max_bytes: int = Field(512 * 1024 * 1024, ge=1024 * 1024, le=64 * 1024**3)
    """stop writing the .tlog when it reaches this size (bytes)"""

    @model_validator(mode="after")
    def _not_the_autopilot(self) -> LinkConfig:
        if self.source_system == self.target_system:
            raise ValueError(
                f"link.source_system = {self.source_system} is the autopilot's system id "
                "(link.target_system): helixd needs an id of its own (default 247)"
            )
        if self.observer_system in (self.source_system, self.target_system):
            raise ValueError(
                f"link.observer_system = {self.observer_system} is also "
                + (
                    "link.source_system, the GCS id"
                    if self.observer_system == self.source_system
                    else "the autopilot's system id (link.target_system)"
                )
                + ": the commands that do not fly need an id of their own (default 248)"
            )
        return self
