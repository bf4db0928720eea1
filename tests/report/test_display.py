"""Operator display: live line on a terminal, throttled progress events otherwise."""

from __future__ import annotations

import dataclasses
import io
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from rich.console import Console

from helixd.base.exitcodes import ExitCode
from helixd.recorder import logging_setup
from helixd.recorder.rows import nan_row
from helixd.recorder.summary import RunSummary, SummaryBuilder
from helixd.report.display import (
    AutopilotElapsed,
    ProgressDisplay,
    ProgressInfo,
    exit_result_line,
    progress_fields,
    progress_line,
    result_line,
    summary_rows,
)
from tests.support.recorder_runs import FakeClock

pytestmark = pytest.mark.usefixtures("reset_logging")

LOOP_HZ = 50


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


def logged_flight() -> tuple[FakeClock, io.StringIO, ProgressDisplay]:
    """A display without a terminal in the fly phase, the log going to ``out`` (logfmt), on a
    fake clock: (clock, out, display)."""
    clock = FakeClock()
    out = io.StringIO()
    logging_setup.configure_logging(tty=False, stream=out, clock=clock)
    display = ProgressDisplay(tty=False, clock=clock)
    display.phase("fly")
    return clock, out, display


def test_not_a_terminal_emits_throttled_progress_events_without_escape_codes() -> None:
    clock, out, display = logged_flight()
    fly(display, clock, 10.0)
    display.update(info(0, link_ok=False, pose_fresh=False))  # within 2 s: throttled
    summary = SummaryBuilder("square", "roll", 4).build(True, None, 0)
    display.final(summary)  # logs the result event, no table off a terminal
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
        "elapsed_wall_s=0.0",
        "elapsed_autopilot_s=null",  # nobody told the display the autopilot clock
    ):
        assert field in first
    assert not any("event=phase " in ln for ln in lines)  # the daemon logs phase_start
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
    line = progress_line("fly", dataclasses.replace(usual, autopilot_elapsed_s=1380.0))
    for row in line.plain.splitlines():
        assert len(row) <= 80, row
    assert "1380 s autopilot clock, 345 s wall" in line.plain


def test_progress_names_both_clocks_from_the_rows_it_was_told_about() -> None:
    clock, out, display = logged_flight()
    for i in range(5 * LOOP_HZ):  # 5 s wall, the autopilot clock 4x faster (sim speed-up)
        display.autopilot_time(100.0 + 4.0 * i / LOOP_HZ)
        display.update(info(i))
        clock.advance(1.0 / LOOP_HZ)
    last = [ln for ln in out.getvalue().splitlines() if "event=progress" in ln][-1]
    fields = dict(kv.split("=", 1) for kv in last.split())
    wall, ap = float(fields["elapsed_wall_s"]), float(fields["elapsed_autopilot_s"])
    assert wall == pytest.approx(4.0, abs=0.1)  # the 3rd event, 2 s apart
    assert ap == pytest.approx(4.0 * wall, abs=0.2)


def test_autopilot_elapsed_survives_a_reboot_and_nan() -> None:
    ap = AutopilotElapsed()
    assert ap.elapsed_s is None
    for t in (50.0, 51.0, math.nan, 52.5, 0.2, 1.2, math.inf):
        ap.add(t)
    assert ap.elapsed_s == pytest.approx(3.5)  # 2.5 s before the reboot, 1.0 s after


def _summary(code: ExitCode, fault: str | None, rows: int, reached: int = 0) -> RunSummary:
    b = SummaryBuilder("square", "roll", 4)
    for k in range(rows):
        b.add(nan_row(t_mono_s=10.0 + 0.25 * k, t_boot_s=40.0 + 1.0 * k, pose_fresh=False))
    for i in range(reached):
        b.arrival(i, 41.0 + i, 0.9)
    return b.build(code is ExitCode.OK, fault, int(code), wall_duration_s=30.0)


@pytest.mark.parametrize(
    ("code", "fault", "rows", "reached", "expected"),
    [
        (
            ExitCode.OK,
            None,
            73,
            4,
            "helixd: RESULT ok — 4/4 waypoints, 72.0 s autopilot time (18.0 s wall), exit 0",
        ),
        (
            ExitCode.FAULT,
            "pose_stale: no pose for 0.6 s",
            9,
            1,
            "helixd: RESULT fault pose_stale: no pose for 0.6 s — 1/4 waypoints, "
            "8.0 s autopilot time (2.0 s wall), exit 4",
        ),
        (
            ExitCode.OPERATOR_STOP,
            "signal: SIGINT received",
            0,
            0,
            "helixd: RESULT stopped signal: SIGINT received — 0/4 waypoints, not flown, exit 5",
        ),
        (
            ExitCode.PREFLIGHT,
            "preflight: EKF not healthy;\nno fresh pose",
            0,
            0,
            "helixd: RESULT refused preflight: EKF not healthy; no fresh pose — 0/4 waypoints, "
            "not flown, exit 3",
        ),
        (
            ExitCode.LINK,
            "link_lost: no HEARTBEAT within 10 s",
            0,
            0,
            "helixd: RESULT link-failed link_lost: no HEARTBEAT within 10 s — 0/4 waypoints, "
            "not flown, exit 6",
        ),
        (
            ExitCode.INTERNAL_ERROR,
            "exception: ValueError: boom",
            0,
            0,
            "helixd: RESULT internal-error exception: ValueError: boom — 0/4 waypoints, "
            "not flown, exit 1",
        ),
    ],
)
def test_result_line_for_every_exit_path(
    code: ExitCode, fault: str | None, rows: int, reached: int, expected: str
) -> None:
    line = result_line(_summary(code, fault, rows, reached))
    assert line == expected
    assert "\n" not in line


def test_a_patrol_ended_by_its_time_limit_gives_no_total_of_its_planned_laps() -> None:
    """A DO_JUMP repeated forever is flown until stopped: '6/96 waypoints' would count laps
    planned beyond the time limit as if they were the mission; the line says a patrol."""
    summary = _summary(ExitCode.FAULT, "mission_time: mission running 150 s", 9, 4)
    summary = summary.model_copy(update={"items_total": 5, "patrol_item": 4})
    line = result_line(summary)
    assert line.startswith(
        "helixd: RESULT fault mission_time: mission running 150 s — 4 waypoints as flown "
        "(mission items 1–5, a patrol: DO_JUMP item 4 repeats until stopped), "
    ), line
    rows = dict(summary_rows(summary))
    assert rows["estimated at preflight"] == "a patrol: until stopped or the time limit"


def test_result_line_after_an_autopilot_reboot_and_a_long_cause() -> None:
    b = SummaryBuilder("square", "roll", 4)
    b.add(nan_row(t_mono_s=1.0, t_boot_s=90.0))
    b.add(nan_row(t_mono_s=3.0, t_boot_s=1.0))  # clock stepped back
    cause = "reboot: " + "x" * 500 + "\n  and the end of it"
    line = result_line(b.build(False, cause, int(ExitCode.FAULT)))
    assert "2.0 s wall (autopilot clock reset: rebooted)" in line
    assert "autopilot time" not in line
    # the whole cause, on the one line (it used to be cut at 160 characters)
    assert "\n" not in line and "…" not in line and line.endswith("exit 4")
    assert "reboot: " + "x" * 500 + " and the end of it — " in line


def test_a_simulated_clock_run_claims_no_wall_time() -> None:
    """Before: `run --sim --sim-clock simulated` said `flight time (wall clock) 71.0 s` and
    `(71.0 s wall)` for a command that took 9.8 s: those seconds were simulated ones."""
    summary = _summary(ExitCode.OK, None, 73, 4).model_copy(update={"companion_clock": "simulated"})
    assert result_line(summary) == (
        "helixd: RESULT ok — 4/4 waypoints, 72.0 s autopilot time (simulated clock), exit 0"
    )
    rows = dict(summary_rows(summary))
    assert rows["flight time (autopilot clock)"] == "72.0 s"
    assert rows["whole run (simulated clock)"] == "30.0 s"
    assert not any("wall" in label for label in rows), rows


def test_result_table_labels_every_time_with_its_clock() -> None:
    rows = dict(summary_rows(_summary(ExitCode.OK, None, 73, 4)))
    assert rows["flight time (autopilot clock)"] == "72.0 s"
    assert rows["flight time (wall clock)"] == "18.0 s"
    assert rows["whole run (wall clock)"] == "30.0 s"
    assert rows["arrivals"].startswith("#1 +1.0 s (0.90 m), #2 +2.0 s")  # numbered from 1
    assert rows["arrivals"].endswith("(autopilot clock)")
    assert not any(label == "duration" for label in rows)


def test_live_line_left_on_screen_shows_the_autopilot_clock() -> None:
    clock = FakeClock()
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=160, color_system=None)
    display = ProgressDisplay(tty=True, console=console, clock=clock)
    display.phase("fly")
    for i in range(LOOP_HZ):  # 1 s wall; the last update is not redrawn until close()
        display.autopilot_time(7.0 + 4.0 * i / LOOP_HZ)
        display.update(info(i))
        clock.advance(1.0 / LOOP_HZ)
    display.close()
    assert "mission time: 4 s autopilot clock, 1 s wall" in buf.getvalue()
    assert "mission time: - s" not in buf.getvalue().rsplit("FLY", 1)[-1]


def test_many_arrivals_are_condensed_in_the_table() -> None:
    b = SummaryBuilder("circle", "scroll", 25)
    b.add(nan_row(t_mono_s=0.0, t_boot_s=10.0))
    for i in range(25):
        b.arrival(i, 12.0 + 2.0 * i, 0.28 + 0.001 * i)
    text = dict(summary_rows(b.build(True, None, 0)))["arrivals"]
    assert text == (
        "25 waypoints, error 0.28–0.30 m, last #25 +50.0 s (0.30 m) (autopilot clock); "
        "each in summary.json"
    )


def test_one_result_event_on_a_terminal_too_and_the_table() -> None:
    clock = FakeClock()
    log_out = io.StringIO()
    logging_setup.configure_logging(tty=False, stream=log_out, clock=clock)
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=160, color_system=None)
    display = ProgressDisplay(tty=True, console=console, clock=clock)
    summary = _summary(ExitCode.OK, None, 73, 4)
    display.log_result(summary)
    display.final(summary, log_event=False)
    assert log_out.getvalue().count("event=result") == 1
    assert "flight_autopilot_s=72.0 flight_wall_s=18.0 run_wall_s=30.0" in log_out.getvalue()
    assert "helixd run result" in buf.getvalue()


def test_no_negative_zero_and_only_the_phase_word_shouts() -> None:
    line = progress_line("fly", info(0, heading_error_deg=-0.3, speed_mps=-0.001)).plain
    assert "hdg +0°" in line and "-0" not in line
    assert progress_fields("fly", info(0, heading_error_deg=-0.01))["heading_error_deg"] == 0.0
    assert str(progress_fields("fly", info(0, heading_error_deg=-0.01))["heading_error_deg"]) == (
        "0.0"
    )
    text = progress_line("arm (autopilot says: PreArm: waiting for home)", None).plain
    assert text == " ARM (autopilot says: PreArm: waiting for home) "


@given(
    st.text(max_size=400),
    st.sampled_from(list(ExitCode)),
    st.integers(min_value=0, max_value=30),
)
def test_result_line_is_one_greppable_line_for_any_cause(
    fault: str, code: ExitCode, rows: int
) -> None:
    line = result_line(_summary(code, fault or None, rows))
    assert line.startswith("helixd: RESULT ") and line.endswith(f"exit {int(code)}")
    assert len(line.splitlines()) == 1 and "\n" not in line and "\r" not in line
    assert len(line) <= 300


def test_exit_result_line_without_a_run() -> None:
    line = exit_result_line(ExitCode.USAGE, "mission.yaml: waypoints: field required")
    assert line == (
        "helixd: RESULT usage-error mission.yaml: waypoints: field required — not flown, exit 2"
    )


def test_via_points_are_shown_as_such_not_as_the_operators_waypoints() -> None:
    """The pond crossing (3 waypoints, 9 planned via points) said "12/12 waypoints"."""
    b = SummaryBuilder("pond-crossing", "roll", 3, via_points_total=9)
    b.add(nan_row(t_mono_s=0.0, t_boot_s=10.0))
    b.add(nan_row(t_mono_s=28.8, t_boot_s=240.2))
    for i in range(12):
        b.arrival(i, 20.0 + i, 0.1, number=1 + (i > 3) + (i > 6), via=i not in (3, 6, 11))
    s = b.build(True, None, 0)
    assert result_line(s).startswith(
        "helixd: RESULT ok — 3/3 waypoints (+9/9 via points), 230.2 s autopilot time"
    )
    rows = dict(summary_rows(s))
    assert rows["waypoints"] == "3/3 (+9/9 via points)"
    assert rows["arrivals"].startswith("#1 +13.0 s (0.10 m), #2 +16.0 s (0.10 m), #3 +21.0 s")
    shown = progress_fields("fly", info(0, waypoint_index=2, waypoints_total=3, via=True))
    assert shown["waypoint"] == "via → 2/3"


def test_a_quiet_console_off_a_terminal_still_gets_progress_lines_and_the_table() -> None:
    """``make demo`` (console at warning, not a terminal): the info progress events are
    hidden, so the progress line is printed plain every event interval and the table at the
    end — without escape codes."""
    clock = FakeClock()
    logging_setup.configure_logging(tty=False, stream=io.StringIO(), clock=clock, level="warning")
    buf = io.StringIO()
    console = Console(file=buf, width=100, color_system=None)
    display = ProgressDisplay(tty=False, plain_lines=True, console=console, clock=clock)
    display.phase("fly")
    fly(display, clock, 10.0)
    display.final(_summary(ExitCode.OK, None, 73, 4))
    text = buf.getvalue()
    assert "\x1b" not in text
    progress = [ln for ln in text.splitlines() if ln.startswith("FLY wp ")]
    assert len(progress) == 5  # one per 2 s event interval over 10 s, one line each
    assert "helixd run result" in text


def test_plain_lines_are_off_on_a_terminal_and_by_default() -> None:
    buf = io.StringIO()
    console = Console(file=buf, width=100, color_system=None)
    clock = FakeClock()
    logging_setup.configure_logging(tty=False, stream=io.StringIO(), clock=clock)
    display = ProgressDisplay(tty=False, console=console, clock=clock)
    display.phase("fly")
    fly(display, clock, 10.0)
    display.final(_summary(ExitCode.OK, None, 73, 4))
    assert buf.getvalue() == ""  # the events say it; nothing printed twice
