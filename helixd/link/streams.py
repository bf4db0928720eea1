"""Message rates: ask with MAV_CMD_SET_MESSAGE_INTERVAL for what will be granted, watch them.

ArduPilot refuses (DENIED, with the STATUSTEXT "Requested rate for message ID … too fast.
Increase SCHED_LOOP_RATE") an interval shorter than 1.25 × its scheduler period
(GCS_MAVLINK::cap_message_interval: denied when ``interval_ms * 800 < loop_period_us``, the
interval in whole milliseconds): Rover's default 50 Hz loop denies 20 ms and grants 25 ms
(40 Hz). So ``SCHED_LOOP_RATE`` is read first and each stream is asked at
``pose_rate_hz`` / ``telemetry_rate_hz`` or the fastest interval that loop grants, whichever
is slower — no DENIED, no STATUSTEXT on every start. If the parameter cannot be read, or a
DENIED comes anyway, the old fallback remains: on each DENIED an interval
``stream_step_factor`` (1.25) times longer, down to ``pose_rate_min_hz``. The granted rate is
logged and returned.

Rates drop while parameters or missions transfer, and another GCS's REQUEST_DATA_STREAM can
reset them, so :class:`RateMonitor` counts arrivals and, once per ``stream_check_window_s``,
names the streams observed below ``stream_slow_fraction`` of their granted rate; each is
re-requested at most once per window.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.link.payload_msgs import PAYLOAD_STREAMS
from helixd.link.services.command_client import ALL_RESULTS, CommandError, result_name
from helixd.mav.constants import (
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
)

log = structlog.get_logger(__name__)

POSE_STREAMS = ("LOCAL_POSITION_NED", "ATTITUDE")
TELEMETRY_STREAMS = (
    "EKF_STATUS_REPORT",
    "SYS_STATUS",
    "RC_CHANNELS",
    "SERVO_OUTPUT_RAW",
    # ArduPilot streams it in EXTENDED_STATUS at SRn_EXT_STAT (Rover: 1 Hz), which a GCS's
    # REQUEST_DATA_STREAM can stop; asked for by id like the rest (MSG_CURRENT_WAYPOINT)
    "MISSION_CURRENT",
    # fix type and satellites, watched in flight (safety.gps_*): the EKF dead-reckons for
    # seconds after a GPS loss before it reports anything
    "GPS_RAW_INT",
)
# the autopilot's HEARTBEAT (arm and mode: what ``serve`` waits on after QGroundControl's arm)
# at ``link.autopilot_heartbeat_rate_hz`` on helixd's own link: ArduPilot sends it at 1 Hz
# by default (GCS_MAVLINK::initialise_message_intervals_from_streamrates) and takes
# SET_MESSAGE_INTERVAL for it like any message (mavlink_id_to_ap_message_id: MSG_HEARTBEAT),
# per link, so the ground station's own link stays at 1 Hz
STATE_STREAMS = ("HEARTBEAT",)
# sent by ArduPilot only in a mode with a place to go (GCS_MAVLINK::
# send_position_target_global_int): asked for like the rest, never counted as slow
TARGET_STREAMS = ("POSITION_TARGET_GLOBAL_INT",)
# sent by ArduPilot only once its EKF has an origin (GCS_MAVLINK::send_local_position needs
# ahrs.get_relative_position_NED_origin): silent before that, as asked, never counted as slow
ORIGIN_STREAMS = ("LOCAL_POSITION_NED",)
US_PER_S = 1_000_000
US_PER_MS = 1000
MS_DENY_FACTOR = 800  # cap_message_interval: denied when interval_ms * 800 < loop period (µs)
MAX_LOOP_RATE_HZ = 2000  # SCHED_LOOP_RATE's documented range is 50..400 (Copter up to 2000)
LOOP_RATE_PARAM = "SCHED_LOOP_RATE"

CommandFn = Callable[..., Awaitable[int]]
ParamFn = Callable[..., Awaitable[float | None]]


def message_id(name: str) -> int:
    return int(getattr(mavlink, f"MAVLINK_MSG_ID_{name}"))


def interval_us(rate_hz: float) -> int:
    return round(US_PER_S / rate_hz)


def rate_hz(interval: int) -> float:
    return US_PER_S / interval if interval > 0 else 0.0


def step_down(interval: int, factor: float) -> int:
    """The next, longer interval to ask for after a DENIED."""
    return max(interval + 1, math.ceil(interval * factor))


def fastest_granted_interval_us(loop_rate_hz: int) -> int | None:
    """The shortest interval ArduPilot grants at ``SCHED_LOOP_RATE`` (None if not sane).

    AP_Scheduler::get_loop_period_us = 1e6 / loop rate; set_message_interval keeps whole
    milliseconds and cap_message_interval denies ``interval_ms * 800 < period_us``.
    """
    if not 1 <= loop_rate_hz <= MAX_LOOP_RATE_HZ:
        return None
    period_us = US_PER_S // loop_rate_hz
    return math.ceil(period_us / MS_DENY_FACTOR) * US_PER_MS


def first_interval_us(want_hz: float, loop_rate_hz: int | None) -> int:
    """What to ask first: the wanted interval, or the fastest one granted if that is slower.

    ArduPilot truncates to whole milliseconds, so the wanted interval is rounded up to one.
    """
    want = math.ceil(interval_us(want_hz) / US_PER_MS) * US_PER_MS
    fastest = None if loop_rate_hz is None else fastest_granted_interval_us(loop_rate_hz)
    return want if fastest is None else max(want, fastest)


def candidate_intervals(
    rate_hz_: float, min_rate_hz: float, factor: float, first_us: int | None = None
) -> list[int]:
    """Intervals to try in order: ``first_us`` (default: ``rate_hz_``'s) and its step-downs,
    none slower than the floor (the first is always tried)."""
    out = [interval_us(rate_hz_) if first_us is None else first_us]
    floor_interval = interval_us(min(min_rate_hz, rate_hz_))
    while True:
        nxt = step_down(out[-1], factor)
        if nxt > floor_interval:
            return out
        out.append(nxt)


@dataclass
class RateMonitor:
    """Counts arrivals per stream; :meth:`check` names the slow ones once per window."""

    window_s: float
    slow_fraction: float
    granted_hz: dict[str, float] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    window_start_s: float | None = None

    def grant(self, name: str, rate: float, now_s: float) -> None:
        self.granted_hz[name] = rate
        self.restart(now_s)

    def restart(self, now_s: float) -> None:
        self.counts = dict.fromkeys(self.granted_hz, 0)
        self.window_start_s = now_s

    def record(self, name: str) -> None:
        if name in self.counts:
            self.counts[name] += 1

    def check(
        self, now_s: float, waiting: frozenset[str] = frozenset()
    ) -> list[tuple[str, float]] | None:
        """None until a window is complete; then (name, observed Hz) of every slow stream,
        those in ``waiting`` (not sent yet by design, e.g. no EKF origin) left out."""
        if self.window_start_s is None or now_s - self.window_start_s < self.window_s:
            return None
        span = now_s - self.window_start_s
        slow = [
            (name, self.counts.get(name, 0) / span)
            for name, granted in self.granted_hz.items()
            if granted > 0
            and name not in waiting
            and self.counts.get(name, 0) / span < self.slow_fraction * granted
        ]
        self.restart(now_s)
        return slow


def silent_streams(slow: Sequence[tuple[str, float]], granted_hz: dict[str, float]) -> bool:
    """Was every granted stream silent (nothing at all arrived in the window)? (pure)"""
    granted = {name for name, rate in granted_hz.items() if rate > 0}
    return bool(granted) and {n for n, hz in slow if hz == 0.0} >= granted


class StreamManager:
    """Negotiates the message intervals and re-requests slow streams."""

    def __init__(self, command: CommandFn, cfg: LinkConfig, get_param: ParamFn | None = None):
        self._command = command
        self._get_param = get_param
        self._cfg = cfg
        self.loop_rate_hz: int | None = None
        self.monitor = RateMonitor(cfg.stream_check_window_s, cfg.stream_slow_fraction)
        self.requested = False
        self._lock = asyncio.Lock()
        self._flight_hz: dict[str, float] = {}  # the pose rates request_all negotiated

    @property
    def granted_hz(self) -> dict[str, float]:
        return dict(self.monitor.granted_hz)

    async def request_all(self) -> dict[str, float]:
        """Ask for every stream; return name → granted rate (0.0 = not granted)."""
        cfg = self._cfg
        async with self._lock:
            self.loop_rate_hz = await self._read_loop_rate()
            granted: dict[str, float] = {}
            pose_first = await self._negotiate(
                POSE_STREAMS[0], cfg.pose_rate_hz, cfg.pose_rate_min_hz
            )
            granted[POSE_STREAMS[0]] = pose_first
            for name in POSE_STREAMS[1:]:
                start = pose_first if pose_first > 0 else cfg.pose_rate_hz
                granted[name] = await self._negotiate(name, start, cfg.pose_rate_min_hz)
            for name in TELEMETRY_STREAMS:
                floor = min(cfg.pose_rate_min_hz, cfg.telemetry_rate_hz)
                granted[name] = await self._negotiate(name, cfg.telemetry_rate_hz, floor)
            for name in STATE_STREAMS:
                floor = min(cfg.autopilot_heartbeat_rate_hz, 1.0)
                granted[name] = await self._negotiate(name, cfg.autopilot_heartbeat_rate_hz, floor)
            now = now_s()
            self._flight_hz = {name: granted[name] for name in POSE_STREAMS}
            for name, rate in granted.items():
                self.monitor.grant(name, rate, now)
            for name in TARGET_STREAMS:
                floor = min(cfg.pose_rate_min_hz, cfg.telemetry_rate_hz)
                granted[name] = await self._negotiate(name, cfg.telemetry_rate_hz, floor)
            # the payload's readings (payload.csv): asked once each, never counted as slow
            if cfg.payload_rate_hz > 0:
                for name in PAYLOAD_STREAMS:
                    rate = cfg.payload_rate_hz
                    granted[name] = await self._negotiate(name, rate, rate, optional=True)
            self.requested = True
            log.info("streams_granted", **{n.lower(): round(r, 2) for n, r in granted.items()})
            return granted

    async def pace_pose(self, rate_hz: float | None) -> None:
        """The pose streams asked at ``rate_hz`` (never faster than negotiated), or at the
        rate :meth:`request_all` negotiated (None): ``serve`` idles between flights on slow
        ones, and every flight asks the fast ones back before it starts. Nothing is sent for
        a stream already at that rate; a refusal leaves the stream as it was."""
        async with self._lock:
            for name in POSE_STREAMS:
                flight_hz = self._flight_hz.get(name, 0.0)
                want = flight_hz if rate_hz is None else min(rate_hz, flight_hz)
                if want <= 0.0 or want == self.monitor.granted_hz.get(name):
                    continue
                result = await self._command(
                    MAV_CMD_SET_MESSAGE_INTERVAL,
                    (message_id(name), interval_us(want)),
                    ok_results=ALL_RESULTS,
                )
                if result == MAV_RESULT_ACCEPTED:
                    self.monitor.grant(name, want, now_s())
                    log.info("stream_paced", stream=name, rate_hz=round(want, 2))

    async def _read_loop_rate(self) -> int | None:
        """SCHED_LOOP_RATE (Hz), read once per negotiation (it changes only with a reboot)."""
        if self._get_param is None:
            return None
        try:
            value = await self._get_param(LOOP_RATE_PARAM, self._cfg.command_timeout_s, 1)
        except CommandError as exc:
            value = None
            log.info("stream_loop_rate_unknown", error=str(exc))
        if value is None or not math.isfinite(value):
            log.info("stream_loop_rate_unknown", param=LOOP_RATE_PARAM)
            return None
        rate = round(value)
        fastest = fastest_granted_interval_us(rate)
        if fastest is None:
            log.warning("stream_loop_rate_invalid", param=LOOP_RATE_PARAM, value=value)
            return None
        log.info(
            "stream_loop_rate",
            loop_rate_hz=rate,
            fastest_interval_us=fastest,
            fastest_hz=round(rate_hz(fastest), 2),
        )
        return rate

    async def _negotiate(
        self, name: str, want_hz: float, floor_hz: float, optional: bool = False
    ) -> float:
        """The rate granted for ``name`` (0.0: none); ``optional``: a refusal is news, not a
        warning (an autopilot without the sensor)."""
        msg_id = message_id(name)
        first = first_interval_us(want_hz, self.loop_rate_hz)
        steps = candidate_intervals(want_hz, floor_hz, self._cfg.stream_step_factor, first)
        for interval in steps:
            result = await self._command(
                MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, interval), ok_results=ALL_RESULTS
            )
            if result == MAV_RESULT_ACCEPTED:
                granted = rate_hz(interval)
                log.info(
                    "stream_rate_granted",
                    stream=name,
                    asked_hz=round(want_hz, 2),
                    granted_hz=round(granted, 2),
                    interval_us=interval,
                )
                return granted
            if result != MAV_RESULT_DENIED:
                (log.info if optional else log.warning)(
                    "stream_rate_refused",
                    stream=name,
                    result=result_name(result),
                    interval_us=interval,
                )
                return 0.0
            log.info(
                "stream_rate_denied",
                stream=name,
                interval_us=interval,
                rate_hz=round(rate_hz(interval), 2),
            )
        (log.info if optional else log.error)(
            "stream_rate_not_granted", stream=name, floor_hz=floor_hz
        )
        return 0.0

    async def rerequest(self, slow: Sequence[tuple[str, float]], booting: bool = False) -> None:
        """Ask again, at the granted interval, for streams observed too slow. When every
        granted stream was silent (an autopilot booting, or one that forgot the intervals), one
        ``streams_silent`` event names them all instead of a ``stream_slow`` per stream; while
        the autopilot says it boots (``booting``) that event is info, not a warning."""
        silent = silent_streams(slow, self.monitor.granted_hz)
        if silent:
            names = [name for name, _ in slow]
            (log.info if booting else log.warning)(
                "streams_silent",
                streams=names,
                booting=booting,
                window_s=self.monitor.window_s,
                why="the autopilot sent none of them; asked again",
            )
        for name, observed in slow:
            granted = self.monitor.granted_hz.get(name, 0.0)
            if not silent:
                log.warning(
                    "stream_slow",
                    stream=name,
                    observed_hz=round(observed, 2),
                    granted_hz=round(granted, 2),
                )
            try:
                await self._command(
                    MAV_CMD_SET_MESSAGE_INTERVAL,
                    (message_id(name), interval_us(granted)),
                    ok_results=ALL_RESULTS,
                )
            except CommandError as exc:
                log.warning("stream_rerequest_failed", stream=name, error=str(exc))

    def due(
        self, now_s: float, link_up: bool, booting: bool = False, origin_known: bool = True
    ) -> list[tuple[str, float]] | None:
        """The slow streams to re-request now (once per window, while the link is up, the
        autopilot is not booting and no request is in flight); None otherwise. A window that
        saw the autopilot boot starts again when it has booted (a booting ArduPilot sends only
        HEARTBEAT), and the streams that need an EKF origin are not judged before the
        autopilot has one (``origin_known``). Called by the link's housekeeping tick."""
        if not link_up or booting or self._lock.locked():
            self.monitor.restart(now_s)
            return None
        waiting = frozenset() if origin_known else frozenset(ORIGIN_STREAMS)
        return self.monitor.check(now_s, waiting) or None

    async def rerequest_and_restart(
        self, slow: list[tuple[str, float]], booting: bool = False
    ) -> None:
        """Re-request ``slow`` and start a new observation window."""
        await self.rerequest(slow, booting)
        self.monitor.restart(now_s())
