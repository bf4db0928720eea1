"""The daemon's side of :mod:`helixd.report.gcs_report`: notes events, sends what the reporter
returns.

:class:`GcsFeed` is the I/O shell around the pure
:class:`helixd.report.gcs_report.GcsReporter`. The
daemon calls :meth:`GcsFeed.phase`, :meth:`GcsFeed.waypoint`, :meth:`GcsFeed.fault` and
:meth:`GcsFeed.progress` from wherever it is; those only remember (no socket, no await, never
raise). A small task started by :meth:`GcsFeed.start` sends at ``gcs_report.tick_hz`` — off the
control loop's latency path: the loop's command has long left when a text is encoded and sent.

Reporting can never break a run: the first exception anywhere in it is logged once
(``gcs_report_failed``) and reporting stops for the rest of the run; a message the transport
drops is counted, not retried. :meth:`GcsFeed.close` sends what is still queued (the fault,
the final phase) for at most ``gcs_report.final_flush_s`` before the link is closed.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

import structlog

from helixd.base.clock import now_s
from helixd.base.tasks import stop_task
from helixd.config.recorder import GcsReportConfig
from helixd.report.gcs_report import (
    GcsReporter,
    PhaseChange,
    Progress,
    ReportedFault,
    Said,
    WaypointReached,
)
from helixd.safety.supervisor import FallbackReport
from helixd.safety.watchdogs import NEXT_FLIGHT_CAUSES, FaultCause

__all__ = ["GcsFeed", "report_fallback"]

log = structlog.get_logger(__name__)

Send = Callable[[Any], bool]
OUTBOX_MAX = 64  # messages the reporter returned that the task has not sent yet


class GcsFeed:
    def __init__(self, cfg: GcsReportConfig, clock: Callable[[], float] = now_s) -> None:
        self.cfg = cfg
        self._clock = clock
        self._reporter = GcsReporter(cfg, clock())
        self._send: Send | None = None
        self._outbox: list[Any] = []
        self._progress: Progress | None = None
        self._task: asyncio.Task[None] | None = None
        self.dead = not cfg.enabled  # reporting off, or stopped by an error
        self.sent = 0
        self.dropped = 0  # refused by the transport (or outbox full)

    # -- the daemon's calls (cheap, never raise) ------------------------------------------------

    def phase(self, name: str) -> None:
        self._feed(PhaseChange(name))

    def waypoint(self, index: int, total: int, lap: str = "") -> None:
        self._feed(WaypointReached(index, total, lap))

    def fault(self, name: str, detail: str = "", stopped: bool = True) -> None:
        self._feed(ReportedFault(name, detail, stopped))

    def say(self, text: str, severity: int) -> None:
        """One line of the service's own at ``severity`` (MAV_SEVERITY)."""
        self._feed(Said(text, severity))

    def progress(self, xtrack_m: float | None, wp_index: int | None) -> None:
        """Latest guidance numbers (called at the control rate: only remembered here)."""
        if not self.dead:
            self._progress = Progress(xtrack_m, wp_index)

    def _feed(self, event: PhaseChange | WaypointReached | ReportedFault | Said) -> None:
        if self.dead:
            return
        try:
            self._queue(self._reporter.feed(event, self._clock()))
        except Exception:
            self._fail("feed")

    # -- the shell ----------------------------------------------------------------------------

    def start(self, send: Send) -> None:
        """Begin sending with ``send`` (e.g. ``Autopilot.send_message``); needs a running loop."""
        if self.dead or self._task is not None:
            return
        self._send = send
        self._task = asyncio.create_task(self._run(), name="gcs-report")

    def start_sync(self, send: Send) -> None:
        """Set the sender without a task (the caller pumps; for tests and tools)."""
        if not self.dead:
            self._send = send

    async def _run(self) -> None:
        period_s = 1.0 / self.cfg.tick_hz
        while not self.dead:
            self.pump()
            await asyncio.sleep(period_s)

    def pump(self) -> None:
        """One tick: the latest progress, what the rate limit lets out, then send it all."""
        if self.dead or self._send is None:
            return
        try:
            now_s = self._clock()
            if self._progress is not None:
                self._reporter.feed(self._progress, now_s)
                self._progress = None
            self._queue(self._reporter.tick(now_s))
            outbox, self._outbox = self._outbox, []
            for msg in outbox:
                if self._send(msg):
                    self.sent += 1
                else:
                    self.dropped += 1
        except Exception:
            self._fail("send")

    def _queue(self, msgs: list[Any]) -> None:
        room = OUTBOX_MAX - len(self._outbox)
        self._outbox.extend(msgs[:room])
        self.dropped += max(0, len(msgs) - room)

    def _fail(self, where: str) -> None:
        self.dead = True
        log.exception("gcs_report_failed", where=where, action="ground-station reporting stopped")

    @property
    def pending(self) -> int:
        return 0 if self.dead else len(self._outbox) + self._reporter.queued

    async def close(self) -> None:
        """Send what is queued for at most ``final_flush_s``, then stop the task."""
        task, self._task = self._task, None
        await stop_task(task)
        if self._send is None:
            return
        deadline = self._clock() + self.cfg.final_flush_s
        self.pump()
        while self.pending and self._clock() < deadline:
            await asyncio.sleep(1.0 / self.cfg.tick_hz)
            self.pump()
        if self.pending:
            log.warning("gcs_report_unsent", messages=self.pending)
        self.dead = True


def report_fallback(feed: GcsFeed, report: FallbackReport) -> None:
    """The fall-back's own outcome: secured (NOTICE), or a fault naming what went wrong; a
    release to the pilot asks no HOLD (``released``)."""
    if report.cause == FaultCause.RELEASED.value and not report.errors:
        feed.phase("released: overrides released, the pilot's radio drives")
    elif report.cause in NEXT_FLIGHT_CAUSES and not report.errors:
        pass  # the next flight starts at once
    elif report.errors or not report.hold_acked:
        detail = "; ".join(report.errors) or "HOLD not acknowledged"
        feed.fault("fallback", detail)
    else:
        feed.phase("secured: scrolls neutral, HOLD")
