"""What the autopilot last told us: a plain dataclass updated by pure handlers (no I/O).

The link shell calls :meth:`VehicleState.apply` with every MAVLink message from the autopilot
and the monotonic time it was read; ``apply`` returns a :class:`Change` set so the shell knows
whom to wake (pose waiters, stream re-requests after a reboot or a regained link). Nothing here
reads a clock or touches a socket.

Frames: the pose is kept exactly as MAVLink reports it (NED from the EKF origin, yaw clockwise
from North); :mod:`helixd.base.frames` converts it once, at the edge of the control core.

Hostile telemetry: this is the edge where values from the wire are checked, once. A
LOCAL_POSITION_NED or ATTITUDE with a non-finite or absurd value (beyond
:class:`TelemetryBounds`), or whose ``time_boot_ms`` steps back by less than the reboot
threshold (out of order), is *rejected*: counted, never stored, and it opens (or extends) an
"invalid pose" burst (``pose_invalid_since_s``) that only a valid pose closes. A rejected
ATTITUDE also forgets the yaw, so no pose is formed from an older yaw while the attitude
stream is bad. An invalid pose is therefore never a fresh pose.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from helixd.base.frames import NedPose
from helixd.config.safety import SafetyConfig
from helixd.mav.constants import (
    EKF_ATTITUDE,
    EKF_CONST_POS_MODE,
    EKF_GPS_GLITCHING,
    EKF_POS_HORIZ_REL,
    EKF_UNINITIALIZED,
    EKF_VELOCITY_HORIZ,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MISSION_STATE_MAX,
    MISSION_STATE_UNKNOWN,
    ROVER_MODE_NUMBERS,
    ROVER_MODES,
    UINT16_MAX,
)
from helixd.mav.ekf_report import EkfReport

MavMsg = Any  # pymavlink messages are untyped; every field is read through int()/float()


EKF_REQUIRED_FLAGS = {
    EKF_ATTITUDE: "attitude",
    EKF_VELOCITY_HORIZ: "horizontal velocity",
    EKF_POS_HORIZ_REL: "relative horizontal position",
}
EKF_FORBIDDEN_FLAGS = {
    EKF_CONST_POS_MODE: "constant-position mode (no position aiding)",
    EKF_UNINITIALIZED: "uninitialised",
}

RC_CHANNEL_COUNT = 18
SERVO_CHANNEL_COUNT = 16
SENSOR_RC_RECEIVER = 0x10000  # MAV_SYS_STATUS_SENSOR_RC_RECEIVER
# MAV_SYS_STATUS_GEOFENCE: ArduPilot (GCS_MAVLINK::update_sensor_status_flags, from
# AC_Fence::sys_status_*) reports it present/enabled with an enabled fence, unhealthy while
# breached
SENSOR_GEOFENCE = 0x100000
# MAV_SYS_STATUS_SENSOR_BATTERY: unhealthy once a battery failsafe has fired
# (AP_BattMonitor::has_failsafed)
SENSOR_BATTERY = 0x2000000
GPS_FIX_TYPE_MAX = 8  # GPS_FIX_TYPE_PPP
RSSI_UNKNOWN = 255
LAT_MAX_DEG = 90.0
LON_MAX_DEG = 180.0


def mode_name(custom_mode: int) -> str:
    """Rover mode name; unknown numbers read as ``MODE_<n>``."""
    return ROVER_MODES.get(custom_mode, f"MODE_{custom_mode}")


def mode_number(name: str) -> int:
    """Rover mode number for ``name`` (case-insensitive); ValueError lists the names."""
    key = name.strip().upper()
    if key not in ROVER_MODE_NUMBERS:
        raise ValueError(f"unknown Rover mode {name!r}; allowed: {', '.join(ROVER_MODE_NUMBERS)}")
    return ROVER_MODE_NUMBERS[key]


class Change:
    """What an applied message changed: bit flags, several may be set at once.

    Plain ``int`` constants, not an ``IntFlag``: every message goes through a few of these
    operations, and enum arithmetic costs microseconds each where int arithmetic costs
    nanoseconds.
    """

    NONE = 0
    HEARTBEAT = 1
    POSE = 2
    ATTITUDE = 4
    EKF = 8
    MODE = 16
    ARMED = 32
    RC = 64
    SERVO = 128
    GPS_ORIGIN = 256
    STATUSTEXT = 512
    LINK_REGAINED = 1024
    REBOOT = 2048
    SYS_STATUS = 4096
    POSE_REJECTED = 8192  # a LOCAL_POSITION_NED / ATTITUDE was rejected (see pose_invalid_*)
    HOME = 16384  # HOME_POSITION: the autopilot has a home (it arms only then)
    GPS = 32768  # GPS_RAW_INT: fix type and satellites
    MISSION_CURRENT = 65536  # MISSION_CURRENT: the autopilot's current item / mission size
    FENCE = 131072  # FENCE_STATUS: the autopilot's own fence breached or clear
    TARGET = 262144  # POSITION_TARGET_GLOBAL_INT: where the autopilot's mode drives to


@dataclass(frozen=True, slots=True)
class HomePosition:
    """The autopilot's home (HOME_POSITION): where NAV_RETURN_TO_LAUNCH drives to."""

    lat_deg: float
    lon_deg: float
    # north/east of the EKF origin (m), as ArduPilot sends them; None when it could not
    # (no origin yet: GCS_MAVLINK::send_home_position sends NaN)
    north_m: float | None
    east_m: float | None


@dataclass(frozen=True, slots=True)
class PositionTarget:
    """POSITION_TARGET_GLOBAL_INT: the place the autopilot's mode drives to.

    ArduPilot (GCS_MAVLINK::send_position_target_global_int) streams it in EXTENDED_STATUS in
    every mode whose ``get_desired_location`` gives a place (Rover: AUTO, GUIDED's WP submode,
    RTL, SmartRTL, LOITER, CIRCLE), in MAV_FRAME_GLOBAL; nothing in the other modes, so a
    target not renewed is one the mode no longer has."""

    lat_e7: int
    lon_e7: int
    rx_monotonic_s: float

    @property
    def lat_deg(self) -> float:
        return self.lat_e7 * 1e-7

    @property
    def lon_deg(self) -> float:
        return self.lon_e7 * 1e-7


@dataclass(frozen=True, slots=True)
class MissionCurrent:
    """MISSION_CURRENT: the autopilot's mission as it reports it.

    ArduPilot (GCS_MAVLINK::send_mission_current): ``seq`` is the current NAV item
    (AP_Mission::get_current_nav_index, 0 while there is none), ``total`` the stored items
    without home (row 0), ``mission_state`` a MISSION_STATE (NO_MISSION, NOT_STARTED outside
    AUTO, ACTIVE while AUTO runs it, COMPLETE; UNKNOWN from an autopilot that does not fill
    it or sent a value this dialect does not know).
    """

    seq: int
    total: int
    mission_state: int
    rx_monotonic_s: float
    # 1 while the autopilot is in a mode that runs the mission (Rover: AUTO), 0 otherwise;
    # None: not sent (a MAVLink 1 sender). Streamed faster than the 1 Hz HEARTBEAT, it shows
    # a mode change into or out of AUTO sooner.
    mission_mode: int | None = None


@dataclass(frozen=True, slots=True)
class TelemetryBounds:
    """What a sane pose looks like; beyond these a value is absurd and rejected.

    Defaults equal the ``safety.telemetry_*`` config defaults.
    """

    position_max_m: float = 50_000.0  # |north|, |east| from the EKF origin
    speed_max_mps: float = 20.0  # |vn|, |ve|, |vd|
    yaw_max_rad: float = 4.0 * math.pi  # |ATTITUDE yaw| (ArduPilot sends ±π)

    @staticmethod
    def from_safety(cfg: SafetyConfig) -> TelemetryBounds:
        return TelemetryBounds(
            position_max_m=cfg.telemetry_position_max_m,
            speed_max_mps=cfg.telemetry_speed_max_mps,
            yaw_max_rad=cfg.telemetry_yaw_max_rad,
        )


def _as_float(value: object) -> float:
    """A wire field as float; anything unreadable becomes NaN (and is then rejected)."""
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError, OverflowError):
        return math.nan


def position_problem(
    north_m: float,
    east_m: float,
    velocities_mps: tuple[float, float, float],
    bounds: TelemetryBounds,
) -> str | None:
    """Why a LOCAL_POSITION_NED cannot be a pose (None when it can). Pure."""
    p_max, v_max = bounds.position_max_m, bounds.speed_max_mps
    vx, vy, vz = velocities_mps
    # the common case in one expression: NaN and ±inf compare False and take the long way
    if (
        abs(north_m) <= p_max
        and abs(east_m) <= p_max
        and abs(vx) <= v_max
        and abs(vy) <= v_max
        and abs(vz) <= v_max
    ):
        return None
    for name, value in (("x (north)", north_m), ("y (east)", east_m)):
        if not math.isfinite(value):
            return f"position {name} is {value}"
        if abs(value) > bounds.position_max_m:
            return f"position {name} = {value:.6g} m beyond ±{bounds.position_max_m:g} m"
    for name, value in zip(("vx", "vy", "vz"), velocities_mps, strict=True):
        if not math.isfinite(value):
            return f"velocity {name} is {value}"
        if abs(value) > bounds.speed_max_mps:
            return f"velocity {name} = {value:.6g} m/s beyond ±{bounds.speed_max_mps:g} m/s"
    return None


def yaw_problem(yaw_rad: float, bounds: TelemetryBounds) -> str | None:
    """Why an ATTITUDE yaw cannot be used (None when it can). Pure."""
    if abs(yaw_rad) <= bounds.yaw_max_rad:  # NaN compares False
        return None
    if not math.isfinite(yaw_rad):
        return f"yaw is {yaw_rad}"
    if abs(yaw_rad) > bounds.yaw_max_rad:
        return f"yaw = {yaw_rad:.6g} rad beyond ±{bounds.yaw_max_rad:.3g} rad"
    return None


@dataclass(frozen=True, slots=True)
class PoseSample:
    """LOCAL_POSITION_NED combined with the latest ATTITUDE yaw (NED, yaw clockwise from N)."""

    ned: NedPose
    time_boot_ms: int  # autopilot clock of the LOCAL_POSITION_NED sample
    rx_monotonic_s: float  # our monotonic clock when the message was read
    vn_mps: float
    ve_mps: float
    vd_mps: float


@dataclass(frozen=True, slots=True)
class EkfStatus:
    """EKF_STATUS_REPORT with our health judgement (variances against ``variance_max``)."""

    report: EkfReport
    rx_monotonic_s: float
    variance_max: float
    # judged once, when the report arrives (5 Hz), not at every read (every control tick)
    healthy: bool = field(init=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "healthy", not self.problems())

    def problems(self) -> list[str]:
        report = self.report
        out = [f"no {what}" for bit, what in EKF_REQUIRED_FLAGS.items() if not report.flags & bit]
        out += [what for bit, what in EKF_FORBIDDEN_FLAGS.items() if report.flags & bit]
        for name, value in (
            ("velocity", report.velocity_variance),
            ("horizontal position", report.pos_horiz_variance),
            ("compass", report.compass_variance),
        ):
            if not math.isfinite(value) or value > self.variance_max:
                out.append(f"{name} variance {value:.2f} > {self.variance_max:.2f}")
        return out

    @property
    def gps_glitching(self) -> bool:
        return bool(self.report.flags & EKF_GPS_GLITCHING)

    def describe(self) -> str:
        problems = self.problems()
        text = "healthy" if not problems else "; ".join(problems)
        if self.gps_glitching:
            text += " (GPS glitching)"
        return f"EKF {text} (flags 0x{self.report.flags:04x})"


@dataclass(frozen=True, slots=True)
class StatusText:
    severity: int
    text: str
    rx_monotonic_s: float


def _uint16(value: object) -> int | None:
    """A wire field that must be an integer 0..65535 (bool and float are not); else None."""
    if isinstance(value, bool) or not isinstance(value, int):
        return None
    return value if 0 <= value <= UINT16_MAX else None


def _text(value: object) -> str:
    if isinstance(value, bytes | bytearray):
        value = value.decode("utf-8", errors="replace")
    return str(value).rstrip("\x00").strip()


@dataclass
class VehicleState:
    """Latest vehicle state. Mutated only by :meth:`apply` and the link-status helpers."""

    ekf_variance_max: float = 0.8
    pose_stale_s: float = 0.5  # ATTITUDE older than this (autopilot clock) gives no pose
    reboot_backstep_ms: int = 1000
    target_component: int = 1  # HEARTBEATs from other components of the system are ignored
    statustext_history: int = 50
    bounds: TelemetryBounds = field(default_factory=TelemetryBounds)

    pose: PoseSample | None = None
    yaw_ned_rad: float | None = None
    attitude_time_boot_ms: int | None = None
    ekf: EkfStatus | None = None
    armed: bool = False
    # when the autopilot acknowledged our disarm (monotonic): a HEARTBEAT received before
    # it still says armed, and must not be taken for "armed now" (:attr:`armed_now`)
    disarm_acked_s: float | None = None
    custom_mode: int | None = None
    mode: str = "UNKNOWN"
    base_mode: int = 0
    system_status: int = 0
    mav_type: int | None = None
    rc_inputs_us: tuple[int, ...] = ()
    rc_chancount: int = 0
    rc_rssi: int | None = None
    rc_rx_s: float | None = None
    servo_outputs_us: tuple[int, ...] = ()
    servo_rx_s: float | None = None
    gps_origin: tuple[float, float] | None = None  # (lat_deg, lon_deg)
    origin_rejected_count: int = 0  # GPS_GLOBAL_ORIGIN with a latitude/longitude off the Earth
    gps_origin_rx_s: float | None = None
    home: HomePosition | None = None
    home_rx_s: float | None = None
    home_rejected_count: int = 0  # HOME_POSITION off the Earth or with absurd values
    mission_current: MissionCurrent | None = None
    # MISSION_CURRENT.mission_mode was seen 1: the autopilot fills it (older ones send 0)
    mission_mode_reported: bool = False
    # reception of the last MISSION_CURRENT with mission_mode 1: AUTO was entered after a
    # HEARTBEAT older than this, whatever mode that HEARTBEAT named (crew_mode)
    mission_auto_rx_s: float | None = None
    mission_current_rejected_count: int = 0  # MISSION_CURRENT with seq/total beyond uint16
    position_target: PositionTarget | None = None
    # reception of the first HEARTBEAT naming the current mode: a POSITION_TARGET_GLOBAL_INT
    # older than this may be the previous mode's place
    mode_since_s: float | None = None
    position_target_rejected_count: int = 0  # off the Earth, 0/0, or not a global frame
    battery_voltage_v: float | None = None
    battery_remaining_pct: int | None = None  # SYS_STATUS, 0..100; None: not reported
    gps_fix_type: int | None = None  # GPS_RAW_INT.fix_type (GPS_FIX_TYPE, 0..8)
    gps_satellites: int | None = None  # GPS_RAW_INT.satellites_visible; None: unknown (255)
    gps_rx_s: float | None = None  # reception of the latest GPS_RAW_INT (monotonic)
    # GPS_RAW_INT.time_usec (ArduPilot: the autopilot's time of the receiver's latest fix) and
    # our reception of the first message that carried it: a receiver that stops sending
    # leaves ArduPilot repeating its last fix, time_usec frozen, for 4 s (GPS_TIMEOUT_MS)
    gps_time_us: int | None = None
    gps_fix_rx_s: float | None = None
    # SYS_STATUS RC-receiver bit: None when the autopilot reports no receiver at all.
    # While helixd streams overrides ArduPilot's own RC failsafe cannot fire (overrides count
    # as valid RC input), so this bit is how helixd notices the pilot's radio is gone.
    rc_receiver_healthy: bool | None = None
    # The autopilot's own fence and battery monitor (SYS_STATUS bits; FENCE_STATUS, which
    # ArduPilot pushes at once on a breach): None when it reports no such sensor enabled.
    fence_breached: bool | None = None
    fence_breach_rx_s: float | None = None  # reception of the report that said breached
    battery_failsafe: bool | None = None
    last_heartbeat_s: float | None = None
    heartbeat_count: int = 0
    link_lost: bool = False
    link_lost_cause: str = ""  # why, while link_lost: the transport's reason or the silence
    link_lost_count: int = 0
    last_rx_s: float | None = None  # reception of the autopilot's latest message of any kind
    reboot_count: int = 0
    last_time_boot_ms: int | None = None
    statustexts: deque[StatusText] = field(default_factory=deque)
    # Rejected pose telemetry: the current burst (None when the last pose message was valid),
    # its latest reason, and counts (total, and per kind for the summary / diagnostics).
    pose_invalid_since_s: float | None = None
    pose_invalid_reason: str = ""
    pose_rejected_count: int = 0
    pose_rejected_kinds: dict[str, int] = field(default_factory=dict)
    foreign_sysid_counts: dict[int, int] = field(default_factory=dict)

    @property
    def armed_now(self) -> bool:
        """Armed, as a HEARTBEAT received after our last acknowledged disarm says (a start
        right after the last flight's disarm must not read the heartbeat before it)."""
        acked = self.disarm_acked_s
        if acked is None:
            return self.armed
        return self.armed and self.last_heartbeat_s is not None and self.last_heartbeat_s > acked

    # -- link status (called by the shell with its clock) -------------------------------------

    def check_link(self, now_s: float, timeout_s: float) -> bool:
        """Mark the link lost when no HEARTBEAT for ``timeout_s``; True on the transition."""
        if self.link_lost or self.last_heartbeat_s is None:
            return False
        if now_s - self.last_heartbeat_s > timeout_s:
            self.mark_link_lost("heartbeat silence")
            return True
        return False

    def mark_link_lost(self, cause: str = "") -> bool:
        """The transport went away (or the heartbeat stopped). True on the transition."""
        if self.link_lost:
            return False
        self.link_lost = True
        self.link_lost_cause = cause
        self.link_lost_count += 1
        return True

    def count_foreign(self, sysid: int) -> None:
        self.foreign_sysid_counts[sysid] = self.foreign_sysid_counts.get(sysid, 0) + 1

    def latest_statustext(self, prefix: str = "", since_s: float | None = None) -> str | None:
        """Newest STATUSTEXT starting with ``prefix`` (case-insensitive), read after ``since_s``."""
        for st in reversed(self.statustexts):
            if since_s is not None and st.rx_monotonic_s < since_s:
                return None
            if st.text.lower().startswith(prefix.lower()):
                return st.text
        return None

    # -- message handlers ---------------------------------------------------------------------

    def apply(self, msg: MavMsg, rx_s: float) -> int:
        """Update from one message of the autopilot's system; return what changed."""
        mtype = str(msg.get_type())
        self.last_rx_s = rx_s
        handler = _HANDLERS.get(mtype)
        if handler is None:
            return Change.NONE
        if (
            self.target_component
            and mtype != "STATUSTEXT"
            and int(msg.get_srcComponent()) != self.target_component
        ):
            return Change.NONE  # a gimbal/camera/companion of the same system
        return handler(self, msg, rx_s)

    @property
    def pose_invalid(self) -> bool:
        """True while the latest pose telemetry was rejected (no valid pose since)."""
        return self.pose_invalid_since_s is not None

    def _reject(self, kind: str, reason: str, rx_s: float) -> int:
        self.pose_rejected_count += 1
        self.pose_rejected_kinds[kind] = self.pose_rejected_kinds.get(kind, 0) + 1
        self.pose_invalid_reason = reason
        if self.pose_invalid_since_s is None:
            self.pose_invalid_since_s = rx_s
        return Change.POSE_REJECTED

    def _boot_time(self, time_boot_ms: int) -> int:
        """Reboot detection: a backstep larger than ``reboot_backstep_ms`` is a new boot.

        A smaller backstep (a reordered or hostile message) leaves the clock at the newest
        time seen; the pose handlers reject such a message as out of order.
        """
        last = self.last_time_boot_ms
        if last is None or time_boot_ms >= last:
            self.last_time_boot_ms = time_boot_ms
            return Change.NONE
        if time_boot_ms < last - self.reboot_backstep_ms:
            self.last_time_boot_ms = time_boot_ms
            self.reboot_count += 1
            self.link_lost_count += 1
            self.pose = None
            self.yaw_ned_rad = None
            self.attitude_time_boot_ms = None
            self.home = None  # a new boot sets its own
            self.mission_current = None  # a new boot has no current item yet
            self.mission_auto_rx_s = None
            self.position_target = None
            return Change.REBOOT
        return Change.NONE

    def _heartbeat(self, msg: MavMsg, rx_s: float) -> int:
        changed = Change.HEARTBEAT
        self.last_heartbeat_s = rx_s
        self.heartbeat_count += 1
        if self.link_lost:
            self.link_lost = False
            changed |= Change.LINK_REGAINED
        self.base_mode = int(msg.base_mode)
        self.system_status = int(msg.system_status)
        self.mav_type = int(msg.type)
        armed = bool(self.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        if armed != self.armed:
            self.armed = armed
            changed |= Change.ARMED
        custom_mode = int(msg.custom_mode)
        if custom_mode != self.custom_mode:
            self.custom_mode = custom_mode
            self.mode = mode_name(custom_mode)
            self.mode_since_s = rx_s
            changed |= Change.MODE
        return changed

    def _attitude(self, msg: MavMsg, rx_s: float) -> int:
        t_ms = int(msg.time_boot_ms)
        changed = self._boot_time(t_ms)
        t_prev = self.attitude_time_boot_ms
        if not changed & Change.REBOOT and t_prev is not None and t_ms < t_prev:
            # reordered or hostile: older than the yaw we hold, which stays valid
            return changed | self._reject(
                "attitude_out_of_order",
                f"ATTITUDE time_boot_ms {t_ms} is {t_prev - t_ms} ms older than the last",
                rx_s,
            )
        yaw = _as_float(msg.yaw)
        problem = yaw_problem(yaw, self.bounds)
        if problem is not None:
            # forget the yaw: no pose may be formed from an older yaw while attitude is bad
            self.yaw_ned_rad = None
            self.attitude_time_boot_ms = None
            return changed | self._reject("attitude_invalid", f"ATTITUDE {problem}", rx_s)
        self.yaw_ned_rad = yaw
        self.attitude_time_boot_ms = t_ms
        return changed | Change.ATTITUDE

    def _local_position(self, msg: MavMsg, rx_s: float) -> int:
        t_ms = int(msg.time_boot_ms)
        changed = self._boot_time(t_ms)
        last = self.pose
        if not changed & Change.REBOOT and last is not None and t_ms < last.time_boot_ms:
            return changed | self._reject(
                "position_out_of_order",
                f"LOCAL_POSITION_NED time_boot_ms {t_ms} is {last.time_boot_ms - t_ms} ms older "
                "than the last pose",
                rx_s,
            )
        try:  # pymavlink gives floats: one conversion each, no call per field
            north, east = float(msg.x), float(msg.y)
            velocities = (float(msg.vx), float(msg.vy), float(msg.vz))
        except (TypeError, ValueError, OverflowError):
            north, east = _as_float(msg.x), _as_float(msg.y)
            velocities = (_as_float(msg.vx), _as_float(msg.vy), _as_float(msg.vz))
        problem = position_problem(north, east, velocities, self.bounds)
        if problem is not None:
            return changed | self._reject("position_invalid", f"LOCAL_POSITION_NED {problem}", rx_s)
        yaw, t_att = self.yaw_ned_rad, self.attitude_time_boot_ms
        if yaw is None or t_att is None or abs(t_ms - t_att) > self.pose_stale_s * 1000.0:
            return changed
        self.pose = PoseSample(
            ned=NedPose(north_m=north, east_m=east, yaw_ned_rad=yaw),
            time_boot_ms=t_ms,
            rx_monotonic_s=rx_s,
            vn_mps=velocities[0],
            ve_mps=velocities[1],
            vd_mps=velocities[2],
        )
        self.pose_invalid_since_s = None
        return changed | Change.POSE

    def _ekf(self, msg: MavMsg, rx_s: float) -> int:
        self.ekf = EkfStatus(EkfReport.from_message(msg), rx_s, self.ekf_variance_max)
        return Change.EKF

    def _rc(self, msg: MavMsg, rx_s: float) -> int:
        changed = self._boot_time(int(msg.time_boot_ms))
        self.rc_inputs_us = tuple(
            int(getattr(msg, f"chan{i}_raw")) for i in range(1, RC_CHANNEL_COUNT + 1)
        )
        self.rc_chancount = int(msg.chancount)
        rssi = int(msg.rssi)
        self.rc_rssi = None if rssi == RSSI_UNKNOWN else rssi
        self.rc_rx_s = rx_s
        return changed | Change.RC

    def _servo(self, msg: MavMsg, rx_s: float) -> int:
        self.servo_outputs_us = tuple(
            int(getattr(msg, f"servo{i}_raw", 0)) for i in range(1, SERVO_CHANNEL_COUNT + 1)
        )
        self.servo_rx_s = rx_s
        return Change.SERVO

    def _origin(self, msg: MavMsg, rx_s: float) -> int:
        lat_deg, lon_deg = int(msg.latitude) * 1e-7, int(msg.longitude) * 1e-7
        if not (-LAT_MAX_DEG <= lat_deg <= LAT_MAX_DEG and -LON_MAX_DEG <= lon_deg <= LON_MAX_DEG):
            self.origin_rejected_count += 1  # not a place on Earth: never an origin
            return Change.NONE
        self.gps_origin = (lat_deg, lon_deg)
        self.gps_origin_rx_s = rx_s
        return Change.GPS_ORIGIN

    def _home(self, msg: MavMsg, rx_s: float) -> int:
        """HOME_POSITION, checked once here: on the Earth, and a north/east that is finite
        and within the telemetry bounds (else kept as unknown)."""
        lat_deg, lon_deg = int(msg.latitude) * 1e-7, int(msg.longitude) * 1e-7
        if not (-LAT_MAX_DEG <= lat_deg <= LAT_MAX_DEG and -LON_MAX_DEG <= lon_deg <= LON_MAX_DEG):
            self.home_rejected_count += 1
            return Change.NONE
        north, east = float(msg.x), float(msg.y)
        limit = self.bounds.position_max_m
        placed = math.isfinite(north) and math.isfinite(east) and math.hypot(north, east) <= limit
        self.home = HomePosition(
            lat_deg, lon_deg, north if placed else None, east if placed else None
        )
        self.home_rx_s = rx_s
        return Change.HOME

    def _mission_current(self, msg: MavMsg, rx_s: float) -> int:
        """MISSION_CURRENT, checked once here: seq and total must be uint16 integers (else
        the message is counted and dropped); a mission_state outside MISSION_STATE (or
        missing: a MAVLink 1 sender) reads as UNKNOWN."""
        seq, total = _uint16(getattr(msg, "seq", None)), _uint16(getattr(msg, "total", None))
        if seq is None or total is None:
            self.mission_current_rejected_count += 1
            return Change.NONE
        state = _uint16(getattr(msg, "mission_state", None))
        if state is None or state > MISSION_STATE_MAX:
            state = MISSION_STATE_UNKNOWN
        mode = _uint16(getattr(msg, "mission_mode", None))
        if mode == 1:
            self.mission_mode_reported = True  # an autopilot that fills the field
            self.mission_auto_rx_s = rx_s
        self.mission_current = MissionCurrent(seq, total, state, rx_s, mode)
        return Change.MISSION_CURRENT

    def _position_target(self, msg: MavMsg, rx_s: float) -> int:
        """POSITION_TARGET_GLOBAL_INT, checked once here: a place on the Earth, not 0/0, with
        latitude and longitude not ignored (type_mask bits 0 and 1)."""
        lat_e7, lon_e7 = int(msg.lat_int), int(msg.lon_int)
        on_earth = abs(lat_e7) <= LAT_MAX_DEG * 1e7 and abs(lon_e7) <= LON_MAX_DEG * 1e7
        if not on_earth or (lat_e7 == 0 and lon_e7 == 0) or int(msg.type_mask) & 0b11:
            self.position_target_rejected_count += 1
            return Change.NONE
        self.position_target = PositionTarget(lat_e7, lon_e7, rx_s)
        return Change.TARGET

    def _statustext(self, msg: MavMsg, rx_s: float) -> int:
        self.statustexts.append(StatusText(int(msg.severity), _text(msg.text), rx_s))
        while len(self.statustexts) > self.statustext_history:
            self.statustexts.popleft()
        return Change.STATUSTEXT

    def _sys_status(self, msg: MavMsg, rx_s: float) -> int:
        present = int(msg.onboard_control_sensors_present) & SENSOR_RC_RECEIVER
        enabled = int(msg.onboard_control_sensors_enabled) & SENSOR_RC_RECEIVER
        healthy = int(msg.onboard_control_sensors_health) & SENSOR_RC_RECEIVER
        self.rc_receiver_healthy = bool(healthy) if (present and enabled) else None
        self._fence_report(_sensor_fault(msg, SENSOR_GEOFENCE), rx_s)
        self.battery_failsafe = _sensor_fault(msg, SENSOR_BATTERY)
        mv = int(msg.voltage_battery)
        self.battery_voltage_v = None if mv == UINT16_MAX else mv / 1000.0
        pct = int(msg.battery_remaining)
        self.battery_remaining_pct = pct if 0 <= pct <= 100 else None  # -1: not estimated
        return Change.SYS_STATUS

    def _fence_report(self, breached: bool | None, rx_s: float) -> None:
        if breached and not self.fence_breached:
            self.fence_breach_rx_s = rx_s
        self.fence_breached = breached

    def _fence_status(self, msg: MavMsg, rx_s: float) -> int:
        """FENCE_STATUS (AC_Fence::record_breach pushes it on a new breach)."""
        self._fence_report(int(msg.breach_status) != 0, rx_s)
        return Change.FENCE

    def _gps_raw(self, msg: MavMsg, rx_s: float) -> int:
        fix = int(msg.fix_type)
        sats = int(msg.satellites_visible)
        self.gps_fix_type = fix if 0 <= fix <= GPS_FIX_TYPE_MAX else None
        self.gps_satellites = sats if 0 <= sats < 255 else None  # 255: unknown
        self.gps_rx_s = rx_s
        time_us = int(msg.time_usec)
        if time_us != self.gps_time_us:
            self.gps_time_us = time_us
            self.gps_fix_rx_s = rx_s
        return Change.GPS


def _sensor_fault(msg: MavMsg, bit: int) -> bool | None:
    """SYS_STATUS: True when sensor ``bit`` is present and enabled but unhealthy; None when
    it is not both present and enabled."""
    present = int(msg.onboard_control_sensors_present) & bit
    enabled = int(msg.onboard_control_sensors_enabled) & bit
    if not (present and enabled):
        return None
    return not int(msg.onboard_control_sensors_health) & bit


_HANDLERS: dict[str, Callable[[VehicleState, MavMsg, float], int]] = {
    "HEARTBEAT": VehicleState._heartbeat,
    "ATTITUDE": VehicleState._attitude,
    "LOCAL_POSITION_NED": VehicleState._local_position,
    "EKF_STATUS_REPORT": VehicleState._ekf,
    "RC_CHANNELS": VehicleState._rc,
    "SERVO_OUTPUT_RAW": VehicleState._servo,
    "GPS_GLOBAL_ORIGIN": VehicleState._origin,
    "HOME_POSITION": VehicleState._home,
    "STATUSTEXT": VehicleState._statustext,
    "SYS_STATUS": VehicleState._sys_status,
    "GPS_RAW_INT": VehicleState._gps_raw,
    "MISSION_CURRENT": VehicleState._mission_current,
    "FENCE_STATUS": VehicleState._fence_status,
    "POSITION_TARGET_GLOBAL_INT": VehicleState._position_target,
}
