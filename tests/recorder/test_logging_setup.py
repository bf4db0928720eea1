"""logging_setup: console vs journald rendering and the events.jsonl tee."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest
import structlog

from helixd.recorder import logging_setup
from helixd.recorder.logging_setup import attach_events_file, configure_logging, detach_events_file

pytestmark = pytest.mark.usefixtures("reset_logging")

ESC = "\x1b"


def test_journald_lines_have_no_escape_codes_and_one_line_per_event() -> None:
    out = io.StringIO()
    configure_logging(tty=False, stream=out, clock=lambda: 12.5)
    log = structlog.get_logger("t")
    log.info("fallback", cause="stall", detail="red \x1b[31mtext\x1b[0m\nsecond line", ok=True)
    try:
        raise ValueError("boom")
    except ValueError:
        log.exception("crashed")
    text = out.getvalue()
    assert ESC not in text
    lines = text.splitlines()
    assert len(lines) == 2  # the traceback is escaped onto its event's line
    assert "level=info event=fallback cause=stall" in lines[0]
    assert "ok=true" in lines[0] and "\\x1b[31m" in lines[0] and "\\nsecond line" in lines[0]
    assert lines[0].startswith("ts=")
    assert "t_mono_s" not in lines[0]  # internal clock kept for the JSON tee only
    assert "event=crashed" in lines[1] and "ValueError: boom" in lines[1]


def test_terminal_rendering_is_concise_and_coloured() -> None:
    out = io.StringIO()
    configure_logging(tty=True, stream=out)
    structlog.get_logger("t").warning("link_lost", silent_s=3.2)
    text = out.getvalue()
    assert "link_lost" in text and "silent_s" in text and ESC in text
    assert len(text.splitlines()) == 1


def test_level_filter_and_bad_level() -> None:
    out = io.StringIO()
    configure_logging(tty=False, stream=out, level="warning")
    log = structlog.get_logger("t")
    log.info("hidden")
    log.warning("shown")
    assert "hidden" not in out.getvalue() and "shown" in out.getvalue()
    with pytest.raises(ValueError, match="unknown log level"):
        configure_logging(tty=False, level="loud")


def test_events_file_tee_writes_json_lines(tmp_path: Path) -> None:
    configure_logging(tty=False, stream=io.StringIO(), clock=lambda: 42.0)
    log = structlog.get_logger("t")
    log.info("before_run")
    path = tmp_path / "events.jsonl"
    attach_events_file(path)
    assert logging_setup.events_file_path() == str(path)
    log.info("waypoint_reached", index=2, error_m=0.41, where=Path("/x"))
    log.warning("fallback", cause="stall")
    detach_events_file()
    log.info("after_run")
    events = [json.loads(line) for line in path.read_text().splitlines()]
    assert [e["event"] for e in events] == ["waypoint_reached", "fallback"]
    assert events[0]["index"] == 2 and events[0]["where"] == "/x"
    assert events[0]["t_mono_s"] == 42.0 and events[0]["level"] == "info"
    assert events[0]["ts"].endswith("Z")


def test_full_disk_drops_the_events_file_with_one_warning() -> None:
    out = io.StringIO()
    configure_logging(tty=False, stream=out)
    log = structlog.get_logger("t")
    attach_events_file(Path("/dev/full"))  # every write fails with ENOSPC, even as root
    for i in range(5):
        log.info("tick", i=i)  # must not raise
    assert logging_setup.events_file_path() is None
    text = out.getvalue()
    assert text.count("event=events_file_degraded") == 1
    assert "errno=28" in text and "/dev/full" in text
    assert text.count("event=tick") == 5  # the console keeps every event


def test_json_file_receives_every_event() -> None:
    sink = io.StringIO()
    configure_logging(tty=False, stream=io.StringIO(), json_file=sink)
    structlog.get_logger("t").info("hello", n=1)
    (event,) = [json.loads(x) for x in sink.getvalue().splitlines()]
    assert event["event"] == "hello" and event["n"] == 1


def test_render_logfmt_quotes_and_nulls() -> None:
    line = logging_setup.render_logfmt(
        None, "info", {"event": "e", "a": "two words", "b": None, "c": 'q"x', "d": 0.1234567891}
    )
    assert line == 'event=e a="two words" b=null c="q\\"x" d=0.123457'


def test_render_logfmt_flattens_dicts_and_writes_lists_without_python_repr() -> None:
    line = logging_setup.render_logfmt(
        None,
        "info",
        {
            "event": "e",
            "stats": {"rx": 5, "inner": {"ok": True}},
            "empty": {},
            "channels": [1, 2, 3],
            "local": ("0.0.0.0", 0),
            "names": ["a b", None],
        },
    )
    assert line == (
        "event=e stats.rx=5 stats.inner.ok=true empty={} channels=[1,2,3] "
        'local=[0.0.0.0,0] names="[\\"a b\\",null]"'
    )
    assert "'" not in line  # no Python repr anywhere


def test_console_renderer_flattens_dicts_too() -> None:
    out = io.StringIO()
    configure_logging(tty=True, stream=out)
    structlog.get_logger("t").info("link_closed", stats={"rx_messages": 5})
    text = out.getvalue()
    assert "stats.rx_messages" in text and "{'" not in text


def test_console_renderer_writes_lists_without_python_repr() -> None:
    out = io.StringIO()
    configure_logging(tty=True, stream=out)
    structlog.get_logger("t").info("sim_started", links=["udpin:1.2.3.4:5"], local=("h", 0))
    text = out.getvalue()
    assert "[udpin:1.2.3.4:5]" in text and "['" not in text and "('" not in text


def test_a_quiet_console_keeps_the_run_record_whole(tmp_path: Path) -> None:
    """``make demo`` runs with ``--log-level warning`` (before: ~70 lines in two formats);
    the console then shows warnings only, and events.jsonl still gets the info events."""
    out = io.StringIO()
    configure_logging(tty=False, stream=out, level="warning")
    log = structlog.get_logger("t")
    path = tmp_path / "events.jsonl"
    attach_events_file(path)
    log.debug("not_recorded")
    log.info("waypoint_reached", index=1)
    log.warning("fallback", cause="stall")
    detach_events_file()
    assert [line.split()[2] for line in out.getvalue().splitlines()] == ["event=fallback"]
    events = [json.loads(line)["event"] for line in path.read_text().splitlines()]
    assert events == ["waypoint_reached", "fallback"]
