"""Message rates: ask with MAV_CMD_SET_MESSAGE_INTERVAL, step down on DENIED, watch them.

ArduPilot refuses (DENIED) an interval shorter than 1.25 × its scheduler period: Rover's
default 50 Hz loop denies 20 ms and grants 25 ms (40 Hz). The pose streams are therefore asked
at ``pose_rate_hz`` and, on each DENIED, at an interval ``stream_step_factor`` (1.25) times
longer — 20 ms → 25 ms lands exactly on Rover's fastest granted rate — down to
``pose_rate_min_hz``. The granted rate is logged and returned.

Rates drop while parameters or missions transfer, and another GCS's REQUEST_DATA_STREAM can
reset them, so :class:`RateMonitor` counts arrivals and, once per ``stream_check_window_s``,
names the streams observed below ``stream_slow_fraction`` of their granted rate; each is
re-requested at most once per window.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config import LinkConfig
from helixd.link.commands import (
    ALL_RESULTS,
    MAV_RESULT_ACCEPTED,
    CommandError,
    result_name,
)

log = structlog.get_logger(__name__)

POSE_STREAMS = ("LOCAL_POSITION_NED", "ATTITUDE")
TELEMETRY_STREAMS = ("EKF_STATUS_REPORT", "SYS_STATUS", "RC_CHANNELS", "SERVO_OUTPUT_RAW")
MAV_CMD_SET_MESSAGE_INTERVAL = int(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL)
MAV_RESULT_DENIED = int(mavlink.MAV_RESULT_DENIED)
US_PER_S = 1_000_000

CommandFn = Callable[..., Awaitable[int]]


def message_id(name: str) -> int:
    return int(getattr(mavlink, f"MAVLINK_MSG_ID_{name}"))


def interval_us(rate_hz: float) -> int:
    return round(US_PER_S / rate_hz)


def rate_hz(interval: int) -> float:
    return US_PER_S / interval if interval > 0 else 0.0


def step_down(interval: int, factor: float) -> int:
    """The next, longer interval to ask for after a DENIED."""
    return max(interval + 1, math.ceil(interval * factor))


def candidate_intervals(rate_hz_: float, min_rate_hz: float, factor: float) -> list[int]:
    """Intervals to try in order: ``rate_hz_`` and its step-downs, none slower than the floor."""
    out = [interval_us(rate_hz_)]
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

    def check(self, now_s: float) -> list[tuple[str, float]] | None:
        """None until a window is complete; then (name, observed Hz) of every slow stream."""
        if self.window_start_s is None or now_s - self.window_start_s < self.window_s:
            return None
        span = now_s - self.window_start_s
        slow = [
            (name, self.counts.get(name, 0) / span)
            for name, granted in self.granted_hz.items()
            if granted > 0 and self.counts.get(name, 0) / span < self.slow_fraction * granted
        ]
        self.restart(now_s)
        return slow


class StreamManager:
    """Negotiates the message intervals and re-requests slow streams."""

    def __init__(self, command: CommandFn, cfg: LinkConfig) -> None:
        self._command = command
        self._cfg = cfg
        self.monitor = RateMonitor(cfg.stream_check_window_s, cfg.stream_slow_fraction)
        self.requested = False
        self._lock = asyncio.Lock()

    @property
    def granted_hz(self) -> dict[str, float]:
        return dict(self.monitor.granted_hz)

    async def request_all(self) -> dict[str, float]:
        """Ask for every stream; return name → granted rate (0.0 = not granted)."""
        cfg = self._cfg
        async with self._lock:
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
            now = time.monotonic()
            for name, rate in granted.items():
                self.monitor.grant(name, rate, now)
            self.requested = True
            log.info("streams_granted", **{n.lower(): round(r, 2) for n, r in granted.items()})
            return granted

    async def _negotiate(self, name: str, want_hz: float, floor_hz: float) -> float:
        msg_id = message_id(name)
        for interval in candidate_intervals(want_hz, floor_hz, self._cfg.stream_step_factor):
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
                log.warning(
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
        log.error("stream_rate_not_granted", stream=name, floor_hz=floor_hz)
        return 0.0

    async def rerequest(self, slow: Sequence[tuple[str, float]]) -> None:
        """Ask again, at the granted interval, for streams observed too slow."""
        for name, observed in slow:
            granted = self.monitor.granted_hz.get(name, 0.0)
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

    async def run_monitor(self, link_up: Callable[[], bool]) -> None:
        """Forever: once per window, re-request the slow streams (while the link is up)."""
        poll_s = self._cfg.stream_check_window_s / 4  # check() itself acts once per window
        while True:
            await asyncio.sleep(poll_s)
            now = time.monotonic()
            if not link_up() or self._lock.locked():
                self.monitor.restart(now)
                continue
            slow = self.monitor.check(now)
            if slow:
                await self.rerequest(slow)
                self.monitor.restart(time.monotonic())
