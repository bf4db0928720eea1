"""Operator display: live line on a terminal, throttled progress events otherwise."""

from __future__ import annotations

import io
from collections.abc import Iterator

import pytest
import structlog
from rich.console import Console

from helixd import logging_setup
from helixd.display import ProgressDisplay, ProgressInfo, progress_line
from helixd.recorder.summary import SummaryBuilder
from tests.unit.test_recorder import FakeClock

LOOP_HZ = 50


@pytest.fixture(autouse=True)
def _reset_logging() -> Iterator[None]:
    yield
    structlog.reset_defaults()


def info(i: int, **kw: object) -> ProgressInfo:
    base: dict[str, object] = dict(
        waypoint_index=2,
        waypoints_total=4,
        distance_to_go_m=7.25 - i * 0.01,
        speed_mps=0.55,
        heading_error_deg=-4.2,
        link_ok=True,
        pose_fresh=True,
        elapsed_s=i / LOOP_HZ,
        nav_state="track",
    )
    base.update(kw)
    return ProgressInfo(**base)  # type: ignore[arg-type]


def fly(display: ProgressDisplay, clock: FakeClock, seconds: float, **kw: object) -> None:
    for i in range(int(seconds * LOOP_HZ)):
        display.update(info(i, **kw))
        clock.advance(1.0 / LOOP_HZ)


def test_not_a_terminal_emits_throttled_progress_events_without_escape_codes() -> None:
    clock = FakeClock()
    out = io.StringIO()
    logging_setup.configure_logging(tty=False, stream=out, clock=clock)
    display = ProgressDisplay(tty=False, clock=clock)
    display.phase("fly")
    fly(display, clock, 10.0)
    display.update(info(0, link_ok=False, pose_fresh=False))  # within 2 s: throttled
    summary = SummaryBuilder("square", "roll", 4).build(True, None, 0)
    display.final(summary)
    display.close()
    text = out.getvalue()
    assert "\x1b" not in text
    lines = text.splitlines()
    progress = [ln for ln in lines if "event=progress" in ln]
    assert len(progress) == 5  # 500 updates over 10 s at one event per 2 s
    assert display.outputs == 5
    first = progress[0]
    for field in (
        "phase=fly",
        "waypoint=2/4",
        "distance_to_go_m=7.25",
        "speed_mps=0.55",
        "heading_error_deg=-4.2",
        "link_ok=true",
        "pose_fresh=true",
        "elapsed_s=0.0",
    ):
        assert field in first
    assert any("event=phase phase=fly" in ln for ln in lines)
    assert sum("event=result" in ln for ln in lines) == 1
    assert "completed=true" in next(ln for ln in lines if "event=result" in ln)


def test_terminal_live_line_redraws_at_most_4_hz() -> None:
    clock = FakeClock()
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=160, color_system="standard")
    display = ProgressDisplay(tty=True, console=console, clock=clock)
    display.phase("fly")
    fly(display, clock, 10.0)
    # one redraw for the phase, then ≤ 4 per second of updates
    assert 38 <= display.outputs <= 42
    fly(display, clock, 0.5, link_ok=False)
    display.close()
    text = buf.getvalue()
    assert "wp 2/4 track" in text and "m to go" in text and "0.55 m/s" in text
    assert "hdg -4°" in text and "LOST" in text
    b = SummaryBuilder("square", "roll", 4)
    b.arrival(0, 10.0, 0.5)
    display.final(b.build(False, "stall: no motion", 4))
    text = buf.getvalue()
    assert "helixd run result" in text and "NOT completed" in text and "stall: no motion" in text


def test_phase_in_info_overrides() -> None:
    clock = FakeClock()
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=160)
    display = ProgressDisplay(tty=True, console=console, clock=clock)
    display.update(info(0, phase="stop", distance_to_go_m=123.4, elapsed_s=1234.0))
    display.close()
    assert "STOP" in buf.getvalue()


def test_live_line_fits_80_columns_in_the_usual_case() -> None:
    usual = info(
        0,
        distance_to_go_m=23.4,
        elapsed_s=345.0,
        waypoint_index=12,
        waypoints_total=25,
        heading_error_deg=-45.0,
    )
    line = progress_line("fly", usual)
    assert len(line.plain) <= 80, line.plain
