"""Builders of the MAVLink messages the simulator sends (pure: values in, message objects out).

Field conventions follow ArduPilot's GCS_MAVLINK senders (GCS_Common.cpp): LOCAL_POSITION_NED
in metres from the EKF origin, ATTITUDE yaw clockwise from North in (−π, π],
GLOBAL_POSITION_INT hdg in centidegrees 0..35999, SERVO_OUTPUT_RAW time_usec truncated to 32
bits, STATUSTEXT split into 50-character chunks with a shared id.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import Any, Protocol, cast

from helixd.mav.constants import (
    MAV_AUTOPILOT_ARDUPILOTMEGA,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_GUIDED_ENABLED,
    MAV_MODE_FLAG_MANUAL_INPUT_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_TYPE_GROUND_ROVER,
)
from helixd.mav.constants import MAV_STATE_ACTIVE as MAV_STATE_ACTIVE
from helixd.mav.constants import MAV_STATE_BOOT as MAV_STATE_BOOT
from helixd.mav.constants import MAV_STATE_CALIBRATING as MAV_STATE_CALIBRATING
from helixd.mav.constants import MAV_STATE_CRITICAL as MAV_STATE_CRITICAL
from helixd.mav.constants import MAV_STATE_STANDBY as MAV_STATE_STANDBY

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.angles import wrap_pi
from helixd.sim.firmware import modes
from helixd.sim.firmware.estimator import PoseEstimate, SimEkfStatus


class Message(Protocol):
    """The part of pymavlink's (untyped) MAVLink_message the simulator uses."""

    def get_type(self) -> str: ...
    def get_srcSystem(self) -> int: ...
    def get_srcComponent(self) -> int: ...


def _m(msg: Any) -> Message:
    return cast(Message, msg)


STATUSTEXT_LEN = 50

SENSOR_GYRO = 0x1
SENSOR_ACCEL = 0x2
SENSOR_MAG = 0x4
SENSOR_BARO = 0x8
SENSOR_GPS = 0x20
SENSOR_RC_RECEIVER = 0x10000
SENSOR_MOTOR_OUTPUTS = 0x8000
SENSOR_AHRS = 0x200000
SENSOR_PREARM_CHECK = 0x10000000
SENSOR_GEOFENCE = 0x100000  # MAV_SYS_STATUS_GEOFENCE
SENSOR_BATTERY = 0x2000000  # MAV_SYS_STATUS_SENSOR_BATTERY
FENCE_BREACH_BOUNDARY = 3  # a circle or polygon fence (GCS_MAVLINK::send_fence_status)
CAPABILITIES = 2 | 4 | 8 | 128 | 256 | 8192  # PARAM_FLOAT MISSION_INT COMMAND_INT ... MAVLINK2
FIRMWARE_VERSION = (4 << 24) | (7 << 16)  # 4.7.0, FIRMWARE_VERSION_TYPE_DEV


def heartbeat(mode: int, armed: bool, system_status: int) -> Message:
    """GCS_MAVLINK_Rover::base_mode: custom mode flag always, armed flag when armed."""
    base = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if mode in modes.MANUAL_INPUT_MODES:
        base |= MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    if mode in modes.AUTOPILOT_MODES:
        base |= MAV_MODE_FLAG_GUIDED_ENABLED
    if armed and mode != modes.INITIALISING:
        base |= MAV_MODE_FLAG_SAFETY_ARMED
    return _m(
        mavlink.MAVLink_heartbeat_message(
            MAV_TYPE_GROUND_ROVER, MAV_AUTOPILOT_ARDUPILOTMEGA, base, mode, system_status, 3
        )
    )


def sys_status(
    rc_ok: bool,
    gps_ok: bool,
    ekf_ok: bool,
    prearm_ok: bool,
    fence: bool | None = None,
    battery_failsafe: bool = False,
) -> Message:
    """GCS_MAVLINK::update_sensor_status_flags. ``fence``: None without an enabled fence
    (the bit absent), else whether it is breached (AC_Fence::sys_status_failed); the battery
    is unhealthy once its failsafe has fired (AP_BattMonitor::has_failsafed)."""
    present = SENSOR_BATTERY | (
        SENSOR_GYRO
        | SENSOR_ACCEL
        | SENSOR_MAG
        | SENSOR_BARO
        | SENSOR_GPS
        | SENSOR_RC_RECEIVER
        | SENSOR_MOTOR_OUTPUTS
        | SENSOR_AHRS
        | SENSOR_PREARM_CHECK
    )
    if fence is not None:
        present |= SENSOR_GEOFENCE
    health = SENSOR_GYRO | SENSOR_ACCEL | SENSOR_MAG | SENSOR_BARO | SENSOR_MOTOR_OUTPUTS
    health |= (SENSOR_RC_RECEIVER if rc_ok else 0) | (SENSOR_GPS if gps_ok else 0)
    health |= (SENSOR_AHRS if ekf_ok else 0) | (SENSOR_PREARM_CHECK if prearm_ok else 0)
    health |= (SENSOR_GEOFENCE if fence is False else 0) | (
        0 if battery_failsafe else SENSOR_BATTERY
    )
    return _m(
        mavlink.MAVLink_sys_status_message(
            present, present, health, 100, 24000, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0, 0
        )
    )


def fence_status(breach_count: int, breach_time_ms: int) -> Message:
    """FENCE_STATUS of a breached boundary fence (AC_Fence::record_breach pushes it)."""
    return _m(
        mavlink.MAVLink_fence_status_message(
            1, breach_count, FENCE_BREACH_BOUNDARY, breach_time_ms & 0xFFFFFFFF
        )
    )


def ekf_status_report(status: SimEkfStatus) -> Message:
    return _m(
        mavlink.MAVLink_ekf_status_report_message(
            status.flags,
            status.velocity_variance,
            status.pos_horiz_variance,
            status.pos_vert_variance,
            status.compass_variance,
            status.terrain_alt_variance,
            0.0,
        )
    )


def local_position_ned(time_boot_ms: int, est: PoseEstimate) -> Message:
    return _m(
        mavlink.MAVLink_local_position_ned_message(
            time_boot_ms, est.north_m, est.east_m, 0.0, est.v_north_mps, est.v_east_mps, 0.0
        )
    )


def attitude(time_boot_ms: int, est: PoseEstimate, raw_yaw_rad: float | None = None) -> Message:
    """``raw_yaw_rad``: send this yaw as it is (fault injection of NaN/inf yaw)."""
    yaw = wrap_pi(est.yaw_ned_rad) if raw_yaw_rad is None else raw_yaw_rad
    return _m(
        mavlink.MAVLink_attitude_message(
            time_boot_ms, 0.0, 0.0, yaw, 0.0, 0.0, est.yaw_rate_ned_radps
        )
    )


def _cdeg_0_360(yaw_rad: float) -> int:
    return round(math.degrees(yaw_rad) * 100.0) % 36000


def global_position_int(
    time_boot_ms: int, lat_deg: float, lon_deg: float, alt_m: float, est: PoseEstimate
) -> Message:
    return _m(
        mavlink.MAVLink_global_position_int_message(
            time_boot_ms,
            round(lat_deg * 1e7),
            round(lon_deg * 1e7),
            round(alt_m * 1000.0),
            0,
            round(est.v_north_mps * 100.0),
            round(est.v_east_mps * 100.0),
            0,
            _cdeg_0_360(est.yaw_ned_rad),
        )
    )


def gps_raw_int(
    time_boot_ms: int,
    lat_deg: float,
    lon_deg: float,
    alt_m: float,
    speed_mps: float,
    course_rad: float,
    accuracy_m: float,
    fix_type: int = 3,  # GPS_FIX_TYPE_3D_FIX; 1: no fix
    satellites: int = 12,
) -> Message:
    eph = max(1, min(32767, round(max(accuracy_m, 0.01) * 100.0)))
    epv = eph * 2
    if fix_type < 2:  # no fix: ArduPilot sends UINT16_MAX (unknown) for both
        eph = epv = 65535
    return _m(
        mavlink.MAVLink_gps_raw_int_message(
            time_boot_ms * 1000,
            fix_type,
            round(lat_deg * 1e7),
            round(lon_deg * 1e7),
            round(alt_m * 1000.0),
            eph,
            epv,
            round(speed_mps * 100.0),
            _cdeg_0_360(course_rad),
            satellites,
            0,
            0,
            0,
            0,
            0,
            0,
        )
    )


def gps_global_origin(lat_deg: float, lon_deg: float, alt_m: float, time_usec: int) -> Message:
    return _m(
        mavlink.MAVLink_gps_global_origin_message(
            round(lat_deg * 1e7), round(lon_deg * 1e7), round(alt_m * 1000.0), time_usec
        )
    )


def home_position(
    lat_deg: float,
    lon_deg: float,
    alt_m: float,
    time_usec: int,
    north_m: float = 0.0,
    east_m: float = 0.0,
) -> Message:
    """GCS_MAVLINK::send_home_position: lat/lon/alt, and x/y/z = home north/east/down of the
    EKF origin (m); q unused (NaN), approach vector 0."""
    nan = math.nan
    return _m(
        mavlink.MAVLink_home_position_message(
            round(lat_deg * 1e7),
            round(lon_deg * 1e7),
            round(alt_m * 1000.0),
            north_m,
            east_m,
            0.0,
            [nan, nan, nan, nan],
            0.0,
            0.0,
            0.0,
            time_usec,
        )
    )


def mission_current(seq: int, total: int, mission_state: int, mission_mode: int) -> Message:
    return _m(mavlink.MAVLink_mission_current_message(seq, total, mission_state, mission_mode))


# GCS_MAVLINK::send_position_target_global_int: x/y/z only (the velocity, acceleration, yaw
# and yaw-rate ignore bits, and the top four bits)
POSITION_TARGET_TYPE_MASK = 0xF000 | 0x0FF8


def position_target_global_int(
    time_boot_ms: int, lat_e7: int, lon_e7: int, alt_amsl_m: float
) -> Message:
    """The place the mode drives to, in MAV_FRAME_GLOBAL (altitude above mean sea level)."""
    zeros = (0.0,) * 8  # velocity, acceleration, yaw, yaw rate: ignored (type_mask)
    frame, mask = mavlink.MAV_FRAME_GLOBAL, POSITION_TARGET_TYPE_MASK
    return _m(
        mavlink.MAVLink_position_target_global_int_message(
            time_boot_ms, frame, mask, lat_e7, lon_e7, alt_amsl_m, *zeros
        )
    )


def mission_item_reached(seq: int) -> Message:
    return _m(mavlink.MAVLink_mission_item_reached_message(seq))


def relay_status(time_boot_ms: int, on_mask: int, present_mask: int) -> Message:
    return _m(mavlink.MAVLink_relay_status_message(time_boot_ms, on_mask, present_mask))


def rc_channels(time_boot_ms: int, radio_in_us: Sequence[int]) -> Message:
    """GCS_MAVLINK::send_rc_channels: every channel's radio_in (an override where one is
    active), the receiver's channel count, RSSI 255 (unknown: no RSSI source). A receiver that
    stops changes none of it: the count stays, the values hold their last frame."""
    chans = [*[int(v) for v in radio_in_us][:16], 0, 0]
    return _m(mavlink.MAVLink_rc_channels_message(time_boot_ms, 16, *chans, 255))


def servo_output_raw(time_boot_ms: int, outputs_us: Sequence[int]) -> Message:
    values = [max(0, min(65535, int(v))) for v in outputs_us][:16]
    return _m(
        mavlink.MAVLink_servo_output_raw_message((time_boot_ms * 1000) & 0xFFFFFFFF, 0, *values)
    )


def vfr_hud(speed_mps: float, yaw_ned_rad: float, alt_m: float) -> Message:
    heading = round(math.degrees(yaw_ned_rad)) % 360
    return _m(mavlink.MAVLink_vfr_hud_message(0.0, speed_mps, heading, 0, alt_m, 0.0))


MAV_DISTANCE_SENSOR_ULTRASOUND = 1  # a sonar
MAV_SENSOR_ROTATION_PITCH_270 = 25  # facing down


def distance_sensor(
    time_boot_ms: int, current_cm: int, min_cm: int, max_cm: int, quality_pct: int
) -> Message:
    """GCS_MAVLINK::send_distance_sensor: instance 0, facing down, covariance 0 (unknown)."""
    return _m(
        mavlink.MAVLink_distance_sensor_message(
            time_boot_ms,
            min_cm,
            max_cm,
            current_cm,
            MAV_DISTANCE_SENSOR_ULTRASOUND,
            0,
            MAV_SENSOR_ROTATION_PITCH_270,
            0,
            0.0,
            0.0,
            [0.0, 0.0, 0.0, 0.0],
            quality_pct,
        )
    )


def rangefinder(distance_m: float) -> Message:
    """GCS_MAVLINK_Rover::send_rangefinder: the shortest distance (m), voltage 0."""
    return _m(mavlink.MAVLink_rangefinder_message(distance_m, 0.0))


def named_value_float(time_boot_ms: int, name: str, value: float) -> Message:
    """A payload's named value (a Lua script's gcs:send_named_float)."""
    return _m(mavlink.MAVLink_named_value_float_message(time_boot_ms, name.encode(), value))


def system_time(time_boot_ms: int) -> Message:
    return _m(mavlink.MAVLink_system_time_message(0, time_boot_ms))


def statustexts(severity: int, text: str, chunk_id: int) -> list[Message]:
    """One message (``id`` 0) or 50-character chunks sharing ``chunk_id`` (GCS::send_statustext).

    A chunk shorter than 50 characters ends a chunked text, so a text whose length is a multiple
    of 50 ends with an empty chunk, as ArduPilot sends it.
    """
    raw = text.encode("ascii", errors="replace")
    if len(raw) <= STATUSTEXT_LEN:
        return [_m(mavlink.MAVLink_statustext_message(severity, raw, 0, 0))]
    chunks = [raw[i : i + STATUSTEXT_LEN] for i in range(0, len(raw), STATUSTEXT_LEN)]
    if len(chunks[-1]) == STATUSTEXT_LEN:
        chunks.append(b"")
    return [
        _m(mavlink.MAVLink_statustext_message(severity, chunk, chunk_id, seq))
        for seq, chunk in enumerate(chunks)
    ]


def command_ack(command: int, result: int, target_system: int, target_component: int) -> Message:
    return _m(
        mavlink.MAVLink_command_ack_message(command, result, 0, 0, target_system, target_component)
    )


def param_value(name: str, value: float, kind: int, count: int, index: int) -> Message:
    return _m(mavlink.MAVLink_param_value_message(name.encode("ascii"), value, kind, count, index))


def file_transfer_protocol(payload: bytes, target_system: int, target_component: int) -> Message:
    """An FTP reply (GCS_FTP::send_reply: target_network 0, to the request's sender)."""
    return _m(
        mavlink.MAVLink_file_transfer_protocol_message(
            0, target_system, target_component, list(payload)
        )
    )


def message_interval(message_id: int, interval_us: int) -> Message:
    return _m(mavlink.MAVLink_message_interval_message(message_id, interval_us))


def autopilot_version(sysid: int) -> Message:
    return _m(
        mavlink.MAVLink_autopilot_version_message(
            CAPABILITIES,
            FIRMWARE_VERSION,
            0,
            0,
            0,
            [0] * 8,
            [0] * 8,
            [0] * 8,
            0,
            0,
            sysid,
            [0] * 18,
        )
    )
