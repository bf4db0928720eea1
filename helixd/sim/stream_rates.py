"""Per-link message rates, as ArduPilot's GCS_MAVLINK keeps them (pure; simulated seconds).

* Until a GCS asks, every message goes out at its stream's SRn_* default rate (Rover's are
  slow: LOCAL_POSITION_NED arrived at about 1 Hz on SITL). HEARTBEAT is always 1 Hz.
* MAV_CMD_SET_MESSAGE_INTERVAL (GCS_MAVLINK::set_message_interval, GCS_Common.cpp):
  param3 ≠ 0 → DENIED; unknown message → DENIED; 0 → default rate; −1 → stop; other
  negatives → DENIED; < 1000 µs → 1 ms; interval_ms = interval_us / 1000 (integer division);
  and DENIED ("Requested rate for message ID N too fast. Increase SCHED_LOOP_RATE") when
  cap_message_interval would raise it, i.e. when interval_ms·800 < the scheduler period in µs
  (faster than 0.8 × SCHED_LOOP_RATE): at 50 Hz, 20 ms is DENIED and 25 ms (40 Hz) accepted.
* REQUEST_DATA_STREAM sets every message of the stream (or all streams) to the requested
  rate — silently capped, not refused — and so resets earlier SET_MESSAGE_INTERVAL grants.
Intervals are per link: a grant on one link does not speed up another.
* Messages of one interval go out together, as ArduPilot's deferred-message buckets send them
  (GCS_MAVLINK::update_send): a message given an interval that others already have joins
  their bucket's phase, and a bucket is sent in ``ap_message`` order (``AP_MESSAGE_ORDER``) —
  so MISSION_CURRENT (a mode's ``mission_mode``) leaves just before the mode's
  POSITION_TARGET_GLOBAL_INT when both stream at one rate.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as _mav

from helixd.mav.constants import MAV_RESULT_ACCEPTED, MAV_RESULT_DENIED
from helixd.mav.constants import MAV_RESULT_FAILED as MAV_RESULT_FAILED

# the message ids this simulator streams (the dialect's MAVLINK_MSG_ID_*)
MSG_HEARTBEAT: int = _mav.MAVLINK_MSG_ID_HEARTBEAT
MSG_SYS_STATUS: int = _mav.MAVLINK_MSG_ID_SYS_STATUS
MSG_SYSTEM_TIME: int = _mav.MAVLINK_MSG_ID_SYSTEM_TIME
MSG_GPS_RAW_INT: int = _mav.MAVLINK_MSG_ID_GPS_RAW_INT
MSG_ATTITUDE: int = _mav.MAVLINK_MSG_ID_ATTITUDE
MSG_MISSION_CURRENT: int = _mav.MAVLINK_MSG_ID_MISSION_CURRENT
MSG_LOCAL_POSITION_NED: int = _mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED
MSG_GLOBAL_POSITION_INT: int = _mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
MSG_SERVO_OUTPUT_RAW: int = _mav.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW
MSG_GPS_GLOBAL_ORIGIN: int = _mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN
MSG_RC_CHANNELS: int = _mav.MAVLINK_MSG_ID_RC_CHANNELS
MSG_VFR_HUD: int = _mav.MAVLINK_MSG_ID_VFR_HUD
MSG_POSITION_TARGET_GLOBAL_INT: int = _mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT
MSG_AUTOPILOT_VERSION: int = _mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION
MSG_EKF_STATUS_REPORT: int = _mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT
MSG_HOME_POSITION: int = _mav.MAVLINK_MSG_ID_HOME_POSITION
MSG_RELAY_STATUS: int = _mav.MAVLINK_MSG_ID_RELAY_STATUS
MSG_DISTANCE_SENSOR: int = _mav.MAVLINK_MSG_ID_DISTANCE_SENSOR
MSG_RANGEFINDER: int = _mav.MAVLINK_MSG_ID_RANGEFINDER
MSG_WATER_DEPTH: int = _mav.MAVLINK_MSG_ID_WATER_DEPTH

# ap_message (GCS_MAVLink/ap_message.h) of each message this simulator streams: the order in
# which one deferred-message bucket sends them
AP_MESSAGE_ORDER: dict[int, int] = {
    MSG_HEARTBEAT: 0,
    MSG_ATTITUDE: 3,
    MSG_GLOBAL_POSITION_INT: 5,  # MSG_LOCATION
    MSG_VFR_HUD: 6,
    MSG_SYS_STATUS: 7,
    MSG_MISSION_CURRENT: 11,  # MSG_CURRENT_WAYPOINT
    MSG_SERVO_OUTPUT_RAW: 12,
    MSG_RC_CHANNELS: 13,
    MSG_GPS_RAW_INT: 22,  # MSG_GPS_RAW
    MSG_SYSTEM_TIME: 26,
    MSG_EKF_STATUS_REPORT: 55,
    MSG_LOCAL_POSITION_NED: 56,  # MSG_LOCAL_POSITION
    MSG_POSITION_TARGET_GLOBAL_INT: 62,
    MSG_GPS_GLOBAL_ORIGIN: 69,  # MSG_ORIGIN
    MSG_HOME_POSITION: 70,  # MSG_HOME
    MSG_AUTOPILOT_VERSION: 73,
    MSG_RELAY_STATUS: 95,
    MSG_RANGEFINDER: 37,
    MSG_DISTANCE_SENSOR: 38,
    MSG_WATER_DEPTH: 77,
}

# MAV_DATA_STREAM ids → the messages ArduPilot puts in them (the ones this simulator sends)
STREAM_ALL = 0
STREAMS: dict[int, tuple[int, ...]] = {
    # EXTENDED_STATUS (MISSION_CURRENT is its MSG_CURRENT_WAYPOINT: STREAM_EXTENDED_STATUS_msgs
    # in GCS_MAVLink_Parameters.cpp), with POSITION_TARGET_GLOBAL_INT (sent only in a mode
    # with a place to go)
    2: (MSG_SYS_STATUS, MSG_MISSION_CURRENT, MSG_GPS_RAW_INT, MSG_POSITION_TARGET_GLOBAL_INT),
    3: (MSG_SERVO_OUTPUT_RAW, MSG_RC_CHANNELS),  # RC_CHANNELS
    6: (MSG_GLOBAL_POSITION_INT, MSG_LOCAL_POSITION_NED),  # POSITION
    10: (MSG_ATTITUDE,),  # EXTRA1
    11: (MSG_VFR_HUD,),  # EXTRA2
    # EXTRA3 (DISTANCE_SENSOR: sent only for a rangefinder with data; WATER_DEPTH only on
    # boats, FRAME_CLASS 2, which the Helix is not)
    12: (MSG_SYSTEM_TIME, MSG_EKF_STATUS_REPORT, MSG_DISTANCE_SENSOR),
}
STREAMED = tuple(m for msgs in STREAMS.values() for m in msgs)
# messages that can be asked for with REQUEST_MESSAGE / SET_MESSAGE_INTERVAL
KNOWN_MESSAGES = frozenset(
    {
        *STREAMED,
        MSG_HEARTBEAT,
        MSG_GPS_GLOBAL_ORIGIN,
        MSG_AUTOPILOT_VERSION,
        MSG_HOME_POSITION,
        MSG_RELAY_STATUS,
        MSG_RANGEFINDER,
        MSG_WATER_DEPTH,
    }
)


def loop_period_us(loop_rate_hz: int) -> int:
    return 1_000_000 // max(1, loop_rate_hz)


def cap_message_interval_ms(interval_ms: int, loop_rate_hz: int) -> int:
    """GCS_MAVLINK::cap_message_interval: at most 0.8 × the main loop rate."""
    period_us = loop_period_us(loop_rate_hz)
    if interval_ms != 0 and interval_ms * 800 < period_us:
        return int(period_us / 800.0)
    return interval_ms


@dataclass(frozen=True, slots=True)
class IntervalDecision:
    result: int
    interval_ms: int | None = None  # new interval (0 = stopped) when ACCEPTED
    text: str | None = None


def decide_set_message_interval(
    msg_id: int, interval_us: int, param3: float, loop_rate_hz: int, default_ms: int
) -> IntervalDecision:
    if param3 != 0.0:
        return IntervalDecision(MAV_RESULT_DENIED)
    if msg_id not in KNOWN_MESSAGES:
        return IntervalDecision(MAV_RESULT_DENIED)
    if interval_us == 0:
        interval_ms = default_ms
    elif interval_us == -1:
        interval_ms = 0
    elif interval_us < 0:
        return IntervalDecision(MAV_RESULT_DENIED)
    elif interval_us < 1000:
        interval_ms = 1
    elif interval_us > 60_000_000:
        interval_ms = 60_000
    else:
        interval_ms = interval_us // 1000
    if interval_ms != 0 and cap_message_interval_ms(interval_ms, loop_rate_hz) > interval_ms:
        text = f"Requested rate for message ID {msg_id} too fast. Increase SCHED_LOOP_RATE"
        return IntervalDecision(MAV_RESULT_DENIED, text=text)
    return IntervalDecision(MAV_RESULT_ACCEPTED, interval_ms)


def rate_to_interval_ms(rate_hz: float) -> int:
    return 0 if rate_hz <= 0.0 else max(1, round(1000.0 / rate_hz))


class StreamSchedule:
    """Which messages are due on one link. Times in simulated seconds."""

    def __init__(self, default_rate_hz: float, loop_rate_hz: int) -> None:
        self.loop_rate_hz = loop_rate_hz
        self.default_ms = rate_to_interval_ms(default_rate_hz)
        self.interval_ms: dict[int, int] = {m: self.default_ms for m in STREAMED}
        self.interval_ms[MSG_HEARTBEAT] = 1000
        self._next_due_s: dict[int, float] = {}

    def default_interval_ms(self, msg_id: int) -> int:
        if msg_id == MSG_HEARTBEAT:
            return 1000
        return self.default_ms if msg_id in STREAMED else 0

    def set_interval(self, msg_id: int, interval_ms: int, now_s: float) -> None:
        self.interval_ms[msg_id] = interval_ms
        self._next_due_s.pop(msg_id, None)
        if interval_ms > 0:
            bucket = (t for m, t in self._next_due_s.items() if self.interval_ms[m] == interval_ms)
            self._next_due_s[msg_id] = next(bucket, now_s + interval_ms / 1000.0)

    def request_data_stream(self, stream_id: int, rate_hz: int, start: bool, now_s: float) -> None:
        interval = rate_to_interval_ms(float(rate_hz)) if start else 0
        interval = cap_message_interval_ms(interval, self.loop_rate_hz)
        ids: Iterable[int]
        ids = STREAMED if stream_id == STREAM_ALL else STREAMS.get(stream_id, ())
        for msg_id in ids:
            self.set_interval(msg_id, interval, now_s)

    def next_due_s(self) -> float:
        """When the next message is due (inf: none streams; a message never sent yet: now)."""
        next_due_s = self._next_due_s
        earliest_s = math.inf
        for msg_id, interval_ms in self.interval_ms.items():  # every loop of a quiet step: no list
            if interval_ms > 0:
                due_s = next_due_s.get(msg_id, -math.inf)
                if due_s < earliest_s:
                    earliest_s = due_s
        return earliest_s

    def due(self, now_s: float) -> list[int]:
        """Messages to send now; the schedule keeps the average rate on a coarse loop."""
        out: list[int] = []
        for msg_id, interval_ms in self.interval_ms.items():
            if interval_ms <= 0:
                continue
            interval_s = interval_ms / 1000.0
            next_due = self._next_due_s.get(msg_id)
            if next_due is None:
                self._next_due_s[msg_id] = now_s + interval_s
                out.append(msg_id)
                continue
            if now_s + 1e-9 >= next_due:
                out.append(msg_id)
                next_due += interval_s
                if next_due <= now_s:  # fell more than one interval behind: no bursts
                    next_due = now_s + interval_s
                self._next_due_s[msg_id] = next_due
        if len(out) > 1:
            out.sort(key=lambda m: AP_MESSAGE_ORDER.get(m, len(AP_MESSAGE_ORDER) + m))
        return out
