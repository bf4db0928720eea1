"""helixd.report.gcs_feed: the daemon's reporting shell never breaks a run, sends off the loop."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest

from helixd.config.recorder import GcsReportConfig
from helixd.report.gcs_feed import OUTBOX_MAX, GcsFeed, report_fallback
from helixd.safety.supervisor import FallbackReport


class Clock:
    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def texts(msgs: list[Any]) -> list[str]:
    return [str(m.text) for m in msgs if m.get_type() == "STATUSTEXT"]


def test_events_are_only_remembered_until_a_tick_sends_them() -> None:
    clock, sent = Clock(), []
    feed = GcsFeed(GcsReportConfig(), clock)
    feed.phase("preflight")
    feed.waypoint(0, 3)
    feed.progress(0.25, 1)
    assert sent == []  # nothing goes out from the caller's side
    feed.start_sync(lambda m: sent.append(m) or True)
    feed.pump()
    assert texts(sent) == ["helixd: preflight", "helixd: reached WP 1/3"]
    named = {str(m.name): float(m.value) for m in sent if m.get_type() == "NAMED_VALUE_FLOAT"}
    assert named == {"xtrack_m": 0.25, "wp_index": 1.0}


def test_an_exception_in_sending_stops_reporting_once_and_never_raises() -> None:
    clock, calls = Clock(), []

    def broken(msg: Any) -> bool:
        calls.append(msg)
        raise OSError("socket gone")

    feed = GcsFeed(GcsReportConfig(), clock)
    feed.start_sync(broken)
    feed.phase("preflight")
    feed.pump()
    assert feed.dead and len(calls) == 1
    feed.fault("link_lost", "x")  # no-ops from now on
    feed.progress(float("nan"), 2)
    clock.now_s += 10.0
    feed.pump()
    assert len(calls) == 1


def test_a_failing_feed_stops_reporting_without_raising(monkeypatch: pytest.MonkeyPatch) -> None:
    feed = GcsFeed(GcsReportConfig(), Clock())

    def boom(*_: Any) -> list[Any]:
        raise ValueError("bug")

    monkeypatch.setattr(feed._reporter, "feed", boom)
    feed.phase("armed")
    assert feed.dead


def test_transport_drops_are_counted_not_fatal() -> None:
    feed = GcsFeed(GcsReportConfig(), Clock())
    feed.start_sync(lambda m: False)
    feed.phase("armed")
    feed.pump()
    assert feed.dropped == 1 and not feed.dead


def test_outbox_is_bounded() -> None:
    feed = GcsFeed(GcsReportConfig(burst=50, max_text_chars=500), Clock())
    for _ in range(8):
        feed.fault(f"x{_}", "y" * 490)  # 12 lines each (cut in 42s after "helixd: ")
    assert len(feed._outbox) == OUTBOX_MAX
    assert feed.dropped == 8 * 12 - OUTBOX_MAX


def test_disabled_sends_nothing() -> None:
    sent: list[Any] = []
    feed = GcsFeed(GcsReportConfig(enabled=False), Clock())
    feed.start_sync(lambda m: sent.append(m) or True)
    feed.fault("x")
    feed.pump()
    assert sent == []


def test_fallback_outcome() -> None:
    sent: list[Any] = []
    feed = GcsFeed(GcsReportConfig(), Clock())
    feed.start_sync(lambda m: sent.append(m) or True)
    report_fallback(feed, FallbackReport("signal", "", hold_acked=True))
    report_fallback(feed, FallbackReport("signal", "", errors=["HOLD refused"]))
    feed.pump()
    assert texts(sent) == [
        "helixd: secured: scrolls neutral, HOLD",
        "helixd: FAULT: stop incomplete: HOLD refused",
    ]
    assert [int(m.severity) for m in sent] == [5, 2]  # NOTICE, CRITICAL


async def test_close_flushes_what_the_rate_limit_held_back() -> None:
    sent: list[Any] = []
    cfg = GcsReportConfig(burst=1, rate_hz=20.0, tick_hz=50.0, final_flush_s=2.0)
    feed = GcsFeed(cfg)
    feed.start(lambda m: sent.append(m) or True)
    for i in range(4):
        feed.phase(f"p{i}")
    await feed.close()
    assert texts(sent) == ["helixd: p0", "helixd: p1", "helixd: p2", "helixd: p3"]
    assert feed.dead


async def test_close_is_bounded_when_the_rate_cannot_keep_up() -> None:
    sent: list[Any] = []
    cfg = GcsReportConfig(burst=1, rate_hz=0.5, final_flush_s=0.2)
    feed = GcsFeed(cfg)
    feed.start(lambda m: sent.append(m) or True)
    for i in range(5):
        feed.phase(f"p{i}")
    loop = asyncio.get_running_loop()
    t0 = loop.time()
    await feed.close()
    assert loop.time() - t0 < 1.0
    assert len(texts(sent)) < 5
