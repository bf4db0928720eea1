"""``helixd replay``: summary and event timeline of a recorded run."""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
import structlog
import typer
from typer.testing import CliRunner

from helixd import logging_setup
from helixd.recorder import command
from helixd.recorder.events import read_events, timeline
from tests.unit.test_recorder import synth_run


@pytest.fixture(autouse=True)
def _reset_logging() -> Iterator[None]:
    yield
    logging_setup.detach_events_file()
    structlog.reset_defaults()


@pytest.fixture
def app() -> typer.Typer:
    app = typer.Typer()
    command.register(app)
    return app


def test_replay_prints_summary_and_timeline(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=40.0)
    result = CliRunner().invoke(app, ["replay", str(run_dir)])
    assert result.exit_code == 0, result.output
    out = result.stdout
    assert "\x1b" not in out  # not a terminal: plain text
    assert re.search(r"result\s+NOT completed", out)
    assert re.search(r"fault\s+stall", out)
    assert re.search(r"waypoints\s+2/4", out)
    lines = out.splitlines()
    timeline_lines = lines[lines.index(next(ln for ln in lines if ln.startswith("events"))) + 1 :]
    names = [ln.split()[2] for ln in timeline_lines]
    assert names[0] == "run_started"
    assert names[1:4] == ["waypoint_reached", "waypoint_reached", "fallback"]
    assert names[-1] == "run_recorded"
    fallback = next(ln for ln in timeline_lines if " fallback " in ln)
    t_s = float(fallback.split()[0])
    assert t_s == pytest.approx(40.0, abs=0.06)  # seconds since the run started
    assert "cause=stall" in fallback and "warning" in fallback
    reached = next(ln for ln in timeline_lines if "waypoint_reached" in ln)
    assert "index=0" in reached


def test_periodic_events_only_with_all(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, clock = synth_run(tmp_path)
    logging_setup.configure_logging(tty=False, stream=io.StringIO(), clock=clock)
    logging_setup.attach_events_file(run_dir / "events.jsonl")
    structlog.get_logger("t").info("progress", waypoint="4/4")
    logging_setup.detach_events_file()
    runner = CliRunner()
    plain = runner.invoke(app, ["replay", str(run_dir)]).stdout
    full = runner.invoke(app, ["replay", str(run_dir), "--all"]).stdout
    assert " progress " not in plain and " progress " in full


def test_replay_of_a_crashed_run(tmp_path: Path, app: typer.Typer) -> None:
    run_dir, _ = synth_run(tmp_path)
    (run_dir / "summary.json").unlink()
    result = CliRunner().invoke(app, ["replay", str(run_dir)])
    assert result.exit_code == 0
    assert "did not finish cleanly" in result.stdout
    assert re.search(r"flight\.csv: \d{3,} rows", result.stdout)


def test_replay_rejects_a_non_run_directory(tmp_path: Path, app: typer.Typer) -> None:
    result = CliRunner().invoke(app, ["replay", str(tmp_path / "missing")])
    assert result.exit_code == 2 and "not a directory" in result.output


def test_rich_replay_on_a_terminal(tmp_path: Path) -> None:
    run_dir, _ = synth_run(tmp_path, fault_at_s=20.0)
    out = io.StringIO()
    command.print_replay(run_dir, tty=True, out=out)
    text = out.getvalue()
    assert "helixd run result" in text and "fallback" in text and "run_started" in text
    assert "NOT completed" in text


def test_timeline_tolerates_torn_lines(tmp_path: Path) -> None:
    path = tmp_path / "events.jsonl"
    path.write_text(
        '{"event": "run_started", "t_mono_s": 10.0, "level": "info", "ts": "x"}\n'
        '{"event": "fallback", "t_mono_s": 12.5, "level": "warning", "cause": "link"}\n'
        '{"event": "torn", "t_mo'
    )
    entries = timeline(read_events(path))
    assert [(e.event, e.t_s, e.fields) for e in entries] == [
        ("run_started", 0.0, ""),
        ("fallback", 2.5, "cause=link"),
    ]
