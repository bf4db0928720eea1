"""What the vehicle reports, assembled once per loop (pure), and the message for each id."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

from helixd.base.frames import ne_to_latlon
from helixd.mav.constants import MISSION_STATE_NO_MISSION
from helixd.plant.state import PhysicsState
from helixd.sim import stream_rates as st
from helixd.sim.faults import FaultClock
from helixd.sim.firmware import messages
from helixd.sim.firmware.estimator import PoseEstimate, SimEkfStatus

POSE_MESSAGES = frozenset({st.MSG_LOCAL_POSITION_NED, st.MSG_GLOBAL_POSITION_INT})


@dataclass(frozen=True, slots=True)
class GpsHeld:
    """What GPS_RAW_INT says after the receiver stopped sending: ArduPilot repeats its last
    fix (time and place frozen) until its driver times out, then no GPS (``no_gps``)."""

    time_boot_ms: int  # the last fix's time
    north_m: float
    east_m: float
    no_gps: bool = False


@dataclass(frozen=True, slots=True)
class TelemetryView:
    time_boot_ms: int
    mode: int
    armed: bool
    booting: bool
    failsafe_active: bool
    origin_set: bool
    home_set: bool
    prearm_ok: bool
    rc_ok: bool  # SYS_STATUS RC receiver health: not in Rover's radio failsafe
    estimate: PoseEstimate
    gps_north_m: float
    gps_east_m: float
    gps_accuracy_m: float
    truth: PhysicsState
    ekf: SimEkfStatus
    radio_in_us: Sequence[int]
    outputs_us: Sequence[int]
    origin_lat_deg: float
    origin_lon_deg: float
    origin_alt_m: float
    sysid: int
    # home as (lat_deg, lon_deg, north_m, east_m); None: not set yet (nothing is sent)
    home: tuple[float, float, float, float] | None = None
    relay_masks: tuple[int, int] = (0, 0)  # RELAY_STATUS (on, present)
    # MISSION_CURRENT (seq, total, mission_state, mission_mode): MissionServer's
    mission_current: tuple[int, int, int, int] = (0, 0, MISSION_STATE_NO_MISSION, 0)
    gps_lost: bool = False  # the receiver reports no fix (fault gps_loss)
    gps_held: GpsHeld | None = None  # the receiver stopped (fault gps_receiver_silent)
    fence: bool | None = None  # None: no fence enabled; else whether it is breached
    battery_failsafe: bool = False  # battery 1's failsafe has fired
    # the mode's place to go (lat_e7, lon_e7, alt_amsl_m): get_desired_location; None: none
    position_target: tuple[int, int, float] | None = None

    def system_status(self) -> int:
        """GCS_MAVLINK_Rover::vehicle_system_status."""
        if self.booting:
            return messages.MAV_STATE_CALIBRATING
        if self.failsafe_active:
            return messages.MAV_STATE_CRITICAL
        return messages.MAV_STATE_ACTIVE if self.armed else messages.MAV_STATE_STANDBY


def _time_boot_ms(v: TelemetryView, faults: FaultClock | None) -> int:
    step = None if faults is None else faults.hostile("time_backwards", v.armed)
    if step is None:
        return v.time_boot_ms
    return max(0, v.time_boot_ms - round(float(str(step["step_s"])) * 1000.0))


def _attitude_yaw(v: TelemetryView, faults: FaultClock | None) -> float | None:
    """The hostile yaw to send instead of the estimate's, if a yaw fault is on."""
    if faults is None:
        return None
    if faults.hostile("nan_yaw", v.armed) is not None:
        return math.nan
    inf_yaw = faults.hostile("inf_yaw", v.armed)
    if inf_yaw is not None:
        return math.copysign(math.inf, float(str(inf_yaw["sign"])))
    return None


def _position_estimate(v: TelemetryView, faults: FaultClock | None) -> PoseEstimate:
    est = v.estimate
    if faults is None:
        return est
    if faults.hostile("nan_position", v.armed) is not None:
        return dataclasses.replace(est, north_m=math.nan, east_m=math.nan)
    absurd = faults.hostile("absurd_position", v.armed)
    if absurd is not None:
        d = float(str(absurd["distance_m"]))
        return dataclasses.replace(est, north_m=d, east_m=d)
    return est


def _gps_raw_int(v: TelemetryView, t: int) -> messages.Message:
    """GPS_RAW_INT once the EKF has an origin: no fix after a gps_loss, no GPS once the
    receiver's driver timed out, the last fix (its time frozen) while it is silent, else the
    fix now (``t``: this message's time_boot_ms)."""
    if v.gps_lost:
        return messages.gps_raw_int(t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, fix_type=1, satellites=0)
    held = v.gps_held
    if held is not None and held.no_gps:  # the driver timed out: state cleared
        return messages.gps_raw_int(
            held.time_boot_ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, fix_type=0, satellites=0
        )
    if held is not None:  # the last fix again, its time frozen
        lat, lon = ne_to_latlon(held.north_m, held.east_m, v.origin_lat_deg, v.origin_lon_deg)
        return messages.gps_raw_int(
            held.time_boot_ms, lat, lon, v.origin_alt_m, 0.0, 0.0, v.gps_accuracy_m
        )
    lat, lon = ne_to_latlon(v.gps_north_m, v.gps_east_m, v.origin_lat_deg, v.origin_lon_deg)
    course = math.atan2(v.truth.v_east_mps, v.truth.v_north_mps)
    return messages.gps_raw_int(
        t, lat, lon, v.origin_alt_m, v.truth.speed_mps, course, v.gps_accuracy_m
    )


def build(
    msg_id: int, v: TelemetryView, faults: FaultClock | None = None
) -> messages.Message | None:
    """The message for ``msg_id`` now, or None when the vehicle would not send it
    (ArduPilot sends no position before the EKF has an origin).

    ``faults``: the simulator's active faults; hostile-telemetry faults
    (:data:`helixd.sim.faults.HOSTILE_TELEMETRY_FAULTS`) corrupt LOCAL_POSITION_NED, ATTITUDE
    and every ``time_boot_ms`` here, on the wire only (physics and estimator are untouched).
    """
    t = _time_boot_ms(v, faults)
    if msg_id == st.MSG_HEARTBEAT:
        return messages.heartbeat(v.mode, v.armed, v.system_status())
    if msg_id == st.MSG_SYS_STATUS:
        gps_ok = v.origin_set and not v.gps_lost and not (v.gps_held and v.gps_held.no_gps)
        return messages.sys_status(
            v.rc_ok, gps_ok, v.ekf.position_ok, v.prearm_ok, v.fence, v.battery_failsafe
        )
    if msg_id == st.MSG_EKF_STATUS_REPORT:
        return messages.ekf_status_report(v.ekf)
    if msg_id == st.MSG_ATTITUDE:
        if v.booting:
            return None
        return messages.attitude(t, v.estimate, raw_yaw_rad=_attitude_yaw(v, faults))
    if msg_id == st.MSG_RC_CHANNELS:
        return messages.rc_channels(t, v.radio_in_us)
    if msg_id == st.MSG_SERVO_OUTPUT_RAW:
        return messages.servo_output_raw(t, v.outputs_us)
    if msg_id == st.MSG_SYSTEM_TIME:
        return messages.system_time(t)
    if msg_id == st.MSG_AUTOPILOT_VERSION:
        return messages.autopilot_version(v.sysid)
    if msg_id == st.MSG_RELAY_STATUS:
        return messages.relay_status(t, *v.relay_masks)
    if msg_id == st.MSG_MISSION_CURRENT:
        return messages.mission_current(*v.mission_current)
    if msg_id == st.MSG_GPS_RAW_INT and not v.origin_set:
        # before the first fix ArduPilot still sends it (AP_GPS::send_mavlink_gps_raw): no fix
        # yet, no fix time, no satellites
        return messages.gps_raw_int(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, fix_type=1, satellites=0)
    if not v.origin_set:
        return None
    if msg_id == st.MSG_LOCAL_POSITION_NED:
        return messages.local_position_ned(t, _position_estimate(v, faults))
    if msg_id == st.MSG_GLOBAL_POSITION_INT:
        lat, lon = ne_to_latlon(
            v.estimate.north_m, v.estimate.east_m, v.origin_lat_deg, v.origin_lon_deg
        )
        return messages.global_position_int(t, lat, lon, v.origin_alt_m, v.estimate)
    if msg_id == st.MSG_GPS_RAW_INT:
        return _gps_raw_int(v, t)
    if msg_id == st.MSG_VFR_HUD:
        return messages.vfr_hud(v.truth.speed_mps, v.estimate.yaw_ned_rad, v.origin_alt_m)
    if msg_id == st.MSG_GPS_GLOBAL_ORIGIN:
        return messages.gps_global_origin(
            v.origin_lat_deg, v.origin_lon_deg, v.origin_alt_m, t * 1000
        )
    if msg_id == st.MSG_POSITION_TARGET_GLOBAL_INT:
        if v.position_target is None:
            return None  # send_position_target_global_int: only with a desired location
        return messages.position_target_global_int(t, *v.position_target)
    if msg_id == st.MSG_HOME_POSITION:
        if v.home is None:
            return None  # GCS_MAVLINK::send_home_position: nothing while home is not set
        lat, lon, north, east = v.home
        return messages.home_position(lat, lon, v.origin_alt_m, t * 1000, north, east)
    return None
